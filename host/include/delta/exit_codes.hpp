// deltactl's exit codes that every wing returns (the host controller adds 3, 4 and 5 for the board:
// delta/controller/run_job.hpp), and the exception that ends a command with one of them.
#pragma once

namespace delta {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;   // a run that completed but failed its goal, or an internal fault
constexpr int kExitBadInput = 2;  // bad input: a file, line and reason were printed

// Thrown by a command to end with a given exit code after printing its own message.
struct CommandExit {
  int code;
};

}  // namespace delta
