// Bad input: the one error type the command line turns into "FILE:LINE: reason" and exit code 2.
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>

namespace delta {

// Text from an input, fit for a one-line message: quoted, control bytes (escape codes, NUL,
// line breaks) shown as \xHH, cut after `limit` characters with "...".
inline std::string quoted_excerpt(const std::string& text, std::size_t limit = 40) {
  std::string shown = "'";
  for (std::size_t i = 0; i < text.size() && i < limit; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f || c == '\\' || c == '\'') {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", c);
      shown += escaped;
    } else {
      shown.push_back(static_cast<char>(c));
    }
  }
  return shown + (text.size() > limit ? "'..." : "'");
}

class InputError : public std::runtime_error {
 public:
  // line 0: the file as a whole (cannot be opened, empty, ...).
  InputError(const std::string& file, std::size_t line, const std::string& reason)
      : std::runtime_error(format(file, line, reason)), file_(file), line_(line), reason_(reason) {}
  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }
  const std::string& reason() const { return reason_; }

 private:
  static std::string format(const std::string& file, std::size_t line, const std::string& reason) {
    return line ? file + ":" + std::to_string(line) + ": " + reason : file + ": " + reason;
  }
  std::string file_;
  std::size_t line_;
  std::string reason_;
};

}  // namespace delta
