// Strict numeric CSV reader with file and line in every error.
#include "delta/csv.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>

#include "delta/input_error.hpp"
#include "delta/input_file.hpp"

namespace delta {
namespace {

std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  for (char c : line) {
    if (c == ',') {
      fields.push_back(field);
      field.clear();
    } else {
      field.push_back(c);
    }
  }
  fields.push_back(field);
  return fields;
}

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\"");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\"");
  return text.substr(first, last - first + 1);
}

// std::getline with a bound: a file without line breaks (/dev/zero) fails at kMaxLineBytes.
bool read_line(std::istream& input, std::string& line, const std::string& path, std::size_t line_number) {
  line.clear();
  std::istream::sentry ok(input, true);
  if (!ok) return false;
  std::streambuf* buffer = input.rdbuf();
  for (;;) {
    const int c = buffer->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      if (line.empty()) input.setstate(std::ios::eofbit | std::ios::failbit);
      return !line.empty();
    }
    if (c == '\n') return true;
    if (line.size() >= kMaxLineBytes) {
      throw InputError(path, line_number, "line longer than " + std::to_string(kMaxLineBytes) + " bytes");
    }
    line.push_back(static_cast<char>(c));
  }
}

bool is_blank(const std::string& line) { return line.find_first_not_of(" \t\r") == std::string::npos; }

}  // namespace

std::optional<double> parse_decimal(const std::string& text) {
  std::size_t i = 0;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  std::string word;
  for (std::size_t k = i; k < text.size(); ++k)
    word.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(text[k]))));
  const bool non_finite = word == "inf" || word == "infinity" || word == "nan";
  if (!non_finite) {
    auto digits = [&] {
      const std::size_t from = i;
      while (i < text.size() && text[i] >= '0' && text[i] <= '9') ++i;
      return i - from;
    };
    std::size_t mantissa = digits();
    if (i < text.size() && text[i] == '.') {
      ++i;
      mantissa += digits();
    }
    if (mantissa == 0) return std::nullopt;
    if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
      ++i;
      if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
      if (digits() == 0) return std::nullopt;
    }
    if (i != text.size()) return std::nullopt;
  }
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return std::nullopt;
  return value;
}

CsvTable read_csv(const std::string& path, const std::vector<std::string>& required_columns,
                  const std::vector<std::string>& optional_columns) {
  std::ifstream input = open_input_file(path);
  return parse_csv(input, path, required_columns, optional_columns);
}

CsvTable parse_csv(std::istream& input, const std::string& path, const std::vector<std::string>& required_columns,
                   const std::vector<std::string>& optional_columns) {
  CsvTable table;
  table.path = path;
  table.columns = required_columns;
  table.columns.insert(table.columns.end(), optional_columns.begin(), optional_columns.end());
  table.present.assign(table.columns.size(), true);
  std::vector<std::size_t> field_index(table.columns.size());
  std::size_t header_fields = 0;
  bool have_header = false;
  std::string line;
  std::size_t line_number = 0;
  while (read_line(input, line, path, line_number + 1)) {
    ++line_number;
    if (is_blank(line)) continue;
    if (trim(line).rfind('#', 0) == 0) {
      if (!have_header) {
        table.comments.push_back(trim(trim(line).substr(1)));
        table.comment_lines.push_back(line_number);
      }
      continue;
    }
    const std::vector<std::string> fields = split_fields(line);
    if (!have_header) {
      have_header = true;
      header_fields = fields.size();
      std::set<std::string> names;
      for (const std::string& field : fields) {
        const std::string name = trim(field);
        if (!name.empty() && !names.insert(name).second) {
          throw InputError(path, line_number, "column " + quoted_excerpt(name) + " named twice in the header");
        }
      }
      for (std::size_t k = 0; k < required_columns.size(); ++k) {
        std::size_t found = fields.size();
        for (std::size_t f = 0; f < fields.size(); ++f) {
          if (trim(fields[f]) == required_columns[k]) found = f;
        }
        if (found == fields.size()) {
          std::string expected;
          for (const std::string& name : required_columns) expected += (expected.empty() ? "" : ",") + name;
          throw InputError(path, line_number,
                           "missing column '" + required_columns[k] + "' (required: " + expected + ")");
        }
        field_index[k] = found;
      }
      for (std::size_t k = required_columns.size(); k < table.columns.size(); ++k) {
        field_index[k] = fields.size();
        for (std::size_t f = 0; f < fields.size(); ++f) {
          if (trim(fields[f]) == table.columns[k]) field_index[k] = f;
        }
        table.present[k] = field_index[k] < fields.size();
      }
      continue;
    }
    if (fields.size() != header_fields) {
      throw InputError(path, line_number,
                       "wrong field count: " + std::to_string(fields.size()) + " fields, the header has " +
                           std::to_string(header_fields));
    }
    std::vector<double> row(table.columns.size(), 0.0);
    for (std::size_t k = 0; k < table.columns.size(); ++k) {
      if (!table.present[k]) continue;
      const std::string text = trim(fields[field_index[k]]);
      const std::optional<double> parsed = parse_decimal(text);
      if (!parsed) {
        throw InputError(path, line_number,
                         "column '" + table.columns[k] + "': " + quoted_excerpt(text) + " is not a number" +
                             (text.find_first_of("xX") != std::string::npos ? " (decimal numbers only)" : ""));
      }
      const double value = *parsed;
      if (!std::isfinite(value)) {
        throw InputError(path, line_number,
                         "column '" + table.columns[k] + "': " + quoted_excerpt(text) + " is not finite");
      }
      row[k] = value;
    }
    table.rows.push_back(std::move(row));
    table.line_numbers.push_back(line_number);
  }
  if (!have_header) throw InputError(path, 0, "empty file: no header line");
  if (table.rows.empty()) throw InputError(path, 0, "empty file: a header but no data rows");
  return table;
}

}  // namespace delta
