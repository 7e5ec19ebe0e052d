// Runs a command line in a shell for CLI tests and captures its exit code, stdout and stderr.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "support/tree_paths.hpp"

namespace delta::test {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string read_text(const std::string& path) {
  std::ifstream input(path);
  std::stringstream buffer;
  buffer << input.rdbuf();
  return buffer.str();
}

// `arguments` is appended to the deltactl path as shell words; `shell_prefix` runs before it in the
// same shell (e.g. "ulimit -f 8; ").
inline CommandResult run_deltactl(const std::string& arguments, const std::string& shell_prefix = "") {
  static int counter = 0;
  // Unique across the test processes CTest runs in parallel.
  const std::string stem =
      ::testing::TempDir() + "deltactl_run_" + std::to_string(::getpid()) + "_" + std::to_string(++counter);
  const std::string command =
      shell_prefix + std::string(DELTACTL_PATH) + " " + arguments + " >" + stem + ".out 2>" + stem + ".err";
  const int status = std::system(command.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = read_text(stem + ".out");
  result.err = read_text(stem + ".err");
  return result;
}

inline void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

inline bool file_exists(const std::string& path) { return std::ifstream(path).good(); }

}  // namespace delta::test
