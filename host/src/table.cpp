// Markdown pipe tables with aligned columns.
#include "delta/table.hpp"

#include <algorithm>
#include <cstdio>

namespace delta {

void Table::print(std::ostream& out) const {
  std::vector<std::size_t> width(header_.size(), 3);
  auto widen = [&](const std::vector<std::string>& row) {
    for (std::size_t k = 0; k < row.size() && k < width.size(); ++k) width[k] = std::max(width[k], row[k].size());
  };
  widen(header_);
  for (const auto& row : rows_) widen(row);
  auto line = [&](const std::vector<std::string>& row) {
    out << '|';
    for (std::size_t k = 0; k < width.size(); ++k) {
      const std::string cell = k < row.size() ? row[k] : "";
      out << ' ' << cell << std::string(width[k] - cell.size(), ' ') << " |";
    }
    out << '\n';
  };
  line(header_);
  out << '|';
  for (std::size_t w : width) out << std::string(w + 2, '-') << '|';
  out << '\n';
  for (const auto& row : rows_) line(row);
}

std::string fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

}  // namespace delta
