// JSON input files with line-accurate errors.
#include "delta/json_input.hpp"

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "delta/input_error.hpp"
#include "delta/input_file.hpp"

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
  std::ifstream input = open_input_file(path);
  std::string text;
  char chunk[1 << 16];
  while (input.read(chunk, sizeof(chunk)) || input.gcount() > 0) {
    text.append(chunk, static_cast<std::size_t>(input.gcount()));
    if (text.size() > kMaxInputBytes) {
      throw InputError(path, 0,
                       "larger than " + std::to_string(kMaxInputBytes >> 20) + " MiB, too large for an input file");
    }
  }
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) throw InputError(path, 0, "empty file");
  return text;
}

void check_json_structure(const std::string& text, const std::string& path) {
  // A lexical pass before nlohmann::json builds (and later dumps or destroys) the document
  // recursively: deep nesting would overflow the stack, and a repeated key would silently keep
  // the last value. Malformed text is left to the parser for its own message.
  struct Container {
    bool object;
    bool expecting_key;
    std::set<std::string> keys;
  };
  std::vector<Container> open;
  std::size_t line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
    } else if (c == '"') {
      const std::size_t start = i + 1;
      for (++i; i < text.size() && text[i] != '"'; ++i) {
        if (text[i] == '\\') ++i;
      }
      if (!open.empty() && open.back().object && open.back().expecting_key) {
        const std::string key = text.substr(start, std::min(i, text.size()) - start);
        if (!open.back().keys.insert(key).second) {
          throw InputError(path, line, "duplicate key " + quoted_excerpt(key) + " in one object");
        }
        open.back().expecting_key = false;
      }
    } else if (c == '{' || c == '[') {
      if (open.size() >= kMaxJsonDepth) {
        throw InputError(path, line, "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
      }
      open.push_back({c == '{', c == '{', {}});
    } else if (c == '}' || c == ']') {
      if (!open.empty()) open.pop_back();
    } else if (c == ',' && !open.empty() && open.back().object) {
      open.back().expecting_key = true;
    }
  }
}

nlohmann::json parse_json_input(const std::string& text, const std::string& path) {
  check_json_structure(text, path);
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
    const std::string token =
        quote == std::string::npos ? "" : reason.substr(quote + 1, reason.rfind('\'') - quote - 1);
    const std::size_t at = token.empty() ? std::string::npos : text.find(token);
    throw InputError(path, at == std::string::npos ? 0 : line_of_offset(text, at),
                     "a number is not finite (overflows a double): " + token);
  }
}

}  // namespace delta
