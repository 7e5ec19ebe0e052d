// deltactl: the command line of the Delta robot co-design (simulate, compare, ik, train, ...).
#include <algorithm>
#include <iostream>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/input_error.hpp"
#include "delta/run_files.hpp"
#include "delta/utf8_text.hpp"

namespace delta {
std::vector<CommandSpec>& command_registry() {
  static std::vector<CommandSpec> commands;
  return commands;
}
}  // namespace delta

int main(int argc, char** argv) {
  CLI::App app{
      "deltactl: neural-network kinematics and joint control of a miniature Delta robot.\n"
      "Simulate the robot, compare models with recordings, train and evaluate the network in float,\n"
      "fixed point, HLS C++ and RTL, and diagnose the sim-to-real gap.",
      "deltactl"};
  app.require_subcommand(1, 1);
  app.footer(
      "\nExamples:\n"
      "  deltactl simulate --experiment validation --effects sim/paper_like_effects.json --out rec.csv\n"
      "  deltactl compare --data rec.csv --plot rec_errors.png\n"
      "  deltactl ik --model nominal --in rec.csv --out angles.csv\n"
      "Run 'deltactl COMMAND --help' for the options of each command.\n"
      "Exit codes: 0 success, 1 failure, 2 bad input (FILE:LINE: reason printed, no output written).");
  auto& commands = delta::command_registry();
  std::stable_sort(commands.begin(), commands.end(), [](const auto& a, const auto& b) { return a.order < b.order; });
  for (const auto& command : commands) command.setup(app);
  delta::track_run_files(true);  // no output of this run may be one of its inputs or another output
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);
  } catch (const CLI::CallForAllHelp& help) {
    return app.exit(help);
  } catch (const CLI::ParseError& error) {
    std::string where = "deltactl";
    for (const CLI::App* sub : app.get_subcommands()) where += " " + sub->get_name();
    std::cerr << "deltactl: error: " << error.what() << " (see '" << where << " --help')\n";
    return delta::kExitBadInput;
  } catch (const delta::InputError& error) {
    std::cerr << "deltactl: error: " << delta::escape_invalid_utf8(error.what()) << '\n';
    return delta::kExitBadInput;
  } catch (const delta::CommandExit& exit) {
    return exit.code;
  } catch (const std::invalid_argument& error) {
    std::cerr << "deltactl: error: " << delta::escape_invalid_utf8(error.what()) << '\n';
    return delta::kExitBadInput;
  } catch (const std::exception& error) {
    std::cerr << "deltactl: failed: " << delta::escape_invalid_utf8(error.what()) << '\n';
    return delta::kExitFailure;
  }
  return delta::kExitOk;
}
