// Plain-text tables in Markdown pipe layout, so printed results paste straight into a README.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace delta {

class Table {
 public:
  explicit Table(std::vector<std::string> header) : header_(std::move(header)) {}
  void add_row(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  void print(std::ostream& out) const;

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

// Fixed-point decimal text, e.g. fixed(0.82704, 4) == "0.8270".
std::string fixed(double value, int decimals);

}  // namespace delta
