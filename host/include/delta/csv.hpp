// Numeric CSV tables (docs/contracts.md recording rules): one header line, '#' comments, any column
// order, extra columns ignored, every error reported as FILE:LINE: reason.
#pragma once

#include <istream>
#include <optional>
#include <string>
#include <vector>

namespace delta {

// A number as the project's files write it, decimal only: an optional sign, digits with an optional
// point, an optional exponent (1, -0.5, .25, 6.87e-9), or inf / nan (which the callers refuse as
// not finite). Anything else is nullopt: hexadecimal floats (0x1p5, which strtod reads as 32),
// spaces, trailing characters, an empty field. The one number parser of every input reader.
std::optional<double> parse_decimal(const std::string& text);

struct CsvTable {
  std::string path;
  std::vector<std::string> columns;        // the requested columns, in request order (required, then optional)
  std::vector<bool> present;               // present[k]: column k is in the file (always for required ones)
  std::vector<std::vector<double>> rows;   // rows[i][k]: requested column k of data row i (0 when absent)
  std::vector<std::size_t> line_numbers;   // file line of each data row, for later errors
  std::vector<std::string> comments;       // the '#' lines before the header, each without its '#', trimmed
  std::vector<std::size_t> comment_lines;  // file line of each
};

// Reads the requested columns; all of them must be present, numeric and finite on every row.
// Throws InputError for a missing file, an empty file (no header or no data), a missing column,
// a wrong field count, or a non-numeric or non-finite field.
// Optional columns are read (with the same checks) when the header names them.
CsvTable read_csv(const std::string& path, const std::vector<std::string>& required_columns,
                  const std::vector<std::string>& optional_columns = {});

// The same on an open stream; `path` names it in errors (the fuzzer feeds bytes this way).
CsvTable parse_csv(std::istream& input, const std::string& path, const std::vector<std::string>& required_columns,
                   const std::vector<std::string>& optional_columns = {});

}  // namespace delta
