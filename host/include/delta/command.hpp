// Sub-command registry of deltactl: each command lives in its own file and registers itself.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace delta {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;   // a run that completed but failed its goal, or an internal fault
constexpr int kExitBadInput = 2;  // bad input: a file, line and reason were printed

// Thrown by a command to end with a given exit code after printing its own message.
struct CommandExit {
  int code;
};

struct CommandSpec {
  std::string name;
  int order;                                  // position in `deltactl --help`
  std::function<void(CLI::App& root)> setup;  // adds the sub-command, its options and callback
};

std::vector<CommandSpec>& command_registry();

struct RegisterCommand {
  RegisterCommand(std::string name, int order, std::function<void(CLI::App&)> setup) {
    command_registry().push_back({std::move(name), order, std::move(setup)});
  }
};

}  // namespace delta
