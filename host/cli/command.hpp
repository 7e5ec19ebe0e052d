// Sub-command registry of deltactl: each command lives in its own file in host/cli/ and registers
// itself. The only place that sees CLI11.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "delta/exit_codes.hpp"

namespace CLI {
class App;
}

namespace delta {

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
