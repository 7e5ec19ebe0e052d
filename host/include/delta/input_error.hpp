// Bad input: the one error type the command line turns into "FILE:LINE: reason" and exit code 2.
#pragma once

#include <stdexcept>
#include <string>

namespace delta {

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
