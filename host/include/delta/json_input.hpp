// JSON input files with line-accurate errors (effect files, weights files): reading, parsing,
// and the line of a key, since nlohmann::json keeps no source positions.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace delta {

// Whole file as text. Throws InputError: cannot open, or empty (only white space).
std::string read_input_text(const std::string& path);

// Deepest nesting of arrays and objects an input may have (the weights file needs 4).
constexpr std::size_t kMaxJsonDepth = 64;

// Throws InputError(path, line, reason) for nesting deeper than kMaxJsonDepth or a key given
// twice in one object; leaves syntax errors to parse_json_input.
void check_json_structure(const std::string& text, const std::string& path);

// Parses JSON after check_json_structure; syntax errors and numbers that overflow a double become InputError(path,
// line, reason).
nlohmann::json parse_json_input(const std::string& text, const std::string& path);

// 1-based line of a byte offset, and of the first quoted occurrence of a key (1 if absent).
std::size_t line_of_offset(const std::string& text, std::size_t offset);
std::size_t line_of_key(const std::string& text, const std::string& key);

}  // namespace delta
