// JSON input files with line-accurate errors.
#include "delta/json_input.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "delta/input_error.hpp"

namespace delta {

std::size_t line_of_offset(const std::string& text, std::size_t offset) {
  offset = std::min(offset, text.size());
  return 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + offset, '\n'));
}

std::size_t line_of_key(const std::string& text, const std::string& key) {
  const std::size_t found = text.find("\"" + key + "\"");
  return found == std::string::npos ? 1 : line_of_offset(text, found);
}

std::string read_input_text(const std::string& path) {
  std::ifstream input(path);
  if (!input) throw InputError(path, 0, "cannot open file");
  std::stringstream buffer;
  buffer << input.rdbuf();
  std::string text = buffer.str();
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) throw InputError(path, 0, "empty file");
  return text;
}

nlohmann::json parse_json_input(const std::string& text, const std::string& path) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& error) {
    std::string reason = error.what();
    const auto detail = reason.find("parse error");
    if (detail != std::string::npos) reason = reason.substr(detail);
    throw InputError(path, error.byte ? line_of_offset(text, error.byte - 1) : 0, "invalid JSON: " + reason);
  } catch (const nlohmann::json::out_of_range& error) {
    // A number too large for a double (1e999): name the line of the offending text.
    const std::string reason = error.what();
    const std::size_t quote = reason.find('\'');
    const std::string token = quote == std::string::npos ? "" : reason.substr(quote + 1, reason.rfind('\'') - quote - 1);
    const std::size_t at = token.empty() ? std::string::npos : text.find(token);
    throw InputError(path, at == std::string::npos ? 0 : line_of_offset(text, at),
                     "a number is not finite (overflows a double): " + token);
  }
}

}  // namespace delta
