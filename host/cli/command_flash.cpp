// deltactl flash: writes the bitstream to the iCEBreaker's SPI flash (iceprog, or openFPGALoader
// -b ice40_generic), waits for the board's UART to come back and checks its identify against the
// bitstream's gateware build id (identify.mem beside it). The gateware is the same for every model:
// the model is data the host loads (deltactl host load), so a flashed board comes back with none.
// --dry-run prints the plan only.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/deploy/bitstream.hpp"
#include "delta/deploy/board_probe.hpp"
#include "delta/deploy/config.hpp"
#include "delta/gateware.hpp"
#include "delta/input_error.hpp"

extern char** environ;

namespace delta {
namespace {

struct FlashOptions {
  std::string config = deploy::kDefaultConfigPath;
  std::string bitstream;
  std::string programmer = "iceprog";
  bool dry_run = false;
  bool force = false;
  int wait_s = 10;
};

int run_program(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const std::string& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, args[0], nullptr, nullptr, args.data(), environ) != 0) {
    throw std::runtime_error(argv[0] + ": not found (apt install fpga-icestorm, or openFPGALoader)");
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

void flash(const FlashOptions& options) {
  const deploy::DeployConfig config = deploy::read_config(options.config);
  const std::string bitstream = options.bitstream.empty() ? config.bitstream : options.bitstream;
  if (bitstream.empty()) {
    throw InputError(options.config, 0, "network.bitstream is empty and no --bitstream was given");
  }
  const deploy::BitstreamSummary layout = deploy::check_up5k_bitstream_file(bitstream);  // refuses any other file
  const auto identify_path = deploy::identify_mem_beside(bitstream);
  if (!identify_path) {
    throw InputError(bitstream, 0,
                     "no identify.mem beside the bitstream: cannot tell which weights and gateware it holds");
  }
  const link::IdentifyPayload expected = deploy::read_identify_mem(*identify_path);
  std::vector<std::string> command;
  if (options.programmer == "iceprog") {
    command = {"iceprog", bitstream};
  } else {
    command = {"openFPGALoader", "-b", "ice40_generic", "-f", bitstream};
  }
  std::cout << "bitstream: " << bitstream << ": iCE40 UP5K, " << layout.bytes << " bytes, CRC " << std::hex
            << layout.crc << std::dec << "\n"
            << "  identify.mem: " << *identify_path << ": gateware build id " << deploy::hex32(expected.build_id)
            << "\n"
            << "this deltactl: gateware build id " << deploy::hex32(kGatewareBuildId) << "\n";
  if (expected.build_id != static_cast<std::uint32_t>(kGatewareBuildId)) {
    // This deltactl speaks the link of its own gateware only: after such a flash every run fails.
    if (!options.force) {
      throw InputError(
          *identify_path, 0,
          "the bitstream's gateware build id " + deploy::hex32(expected.build_id) + " is not this deltactl's " +
              deploy::hex32(kGatewareBuildId) +
              " (flash the bitstream built with this deltactl, install the matching deltactl, or --force)");
    }
    std::cout << "warning: the bitstream's gateware build id differs from this deltactl's (--force)\n";
  }
  std::cout << "command:";
  for (const std::string& arg : command) std::cout << ' ' << arg;
  std::cout << "\nverify: wait up to " << options.wait_s << " s for " << config.port
            << " to come back, send an identify request (" << config.baud
            << " baud, 1 s timeout), expect gateware build id " << deploy::hex32(expected.build_id) << "\n"
            << "then: deltactl host load --port " << config.port << " --weights " << config.weights
            << " (the model; the service loads its own when it starts)\n";
  if (options.dry_run) {
    std::cout << "dry run: nothing written\n";
    return;
  }
  std::cout.flush();  // before the programmer's own output
  const int status = run_program(command);
  if (status != 0) throw std::runtime_error(command[0] + " exited with " + std::to_string(status));
  // The FT2232H re-enumerates after the programmer releases it: the port vanishes and comes back.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(options.wait_s);
  std::string last_error = "not tried";
  while (std::chrono::steady_clock::now() < deadline) {
    try {
      const link::IdentifyPayload board = deploy::identify_board(config.port, static_cast<int>(config.baud), 1000);
      std::cout << "board: gateware build id " << deploy::hex32(board.build_id)
                << (board.weights_crc != 0 ? ", model CRC-32 " + deploy::hex32(board.weights_crc) : ", no model")
                << "\n";
      if (board.build_id != expected.build_id) {
        throw std::runtime_error("the board's gateware build id differs from the bitstream's");
      }
      std::cout << "flash: verified\n";
      if (board.weights_crc == 0) {
        std::cout << "load the model: deltactl host load --port " << config.port << " --weights " << config.weights
                  << "\n";
      }
      return;
    } catch (const std::runtime_error& error) {
      last_error = error.what();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  throw std::runtime_error("flashed, but the board did not identify: " + last_error);
}

const RegisterCommand kRegister("flash", 91, [](CLI::App& root) {
  auto options = std::make_shared<FlashOptions>();
  auto* sub = root.add_subcommand("flash", "Write the bitstream to the iCEBreaker's flash and verify its identify");
  sub->footer(
      "\nThe bitstream must be an iCE40 UP5K bitstream (sync word, the UP5K's configuration banks, its CRC);\n"
      "its identify.mem (beside it) must hold this deltactl's gateware build id, or --force. The gateware\n"
      "is the same for every model: a flashed board comes back without one, and 'deltactl host load\n"
      "--port PORT --weights W.json' loads it in well under a second (the service loads its configured\n"
      "model when it starts). A new model needs no flashing.\n"
      "Example: deltactl flash --dry-run");
  sub->add_option("--config", options->config, "configuration file")->capture_default_str();
  sub->add_option("--bitstream", options->bitstream, "bitstream (.bin; default: network.bitstream of the config)");
  sub->add_option("--programmer", options->programmer, "iceprog (fpga-icestorm) or openFPGALoader")
      ->check(CLI::IsMember({"iceprog", "openFPGALoader"}))
      ->capture_default_str();
  sub->add_option("--wait", options->wait_s, "seconds to wait for the board after flashing")
      ->check(CLI::Range(1, 120))
      ->capture_default_str();
  sub->add_flag("--dry-run", options->dry_run, "print the programmer command and the verification, write nothing");
  sub->add_flag("--force", options->force, "flash a bitstream of another gateware than this deltactl's");
  sub->callback([options] { flash(*options); });
});

}  // namespace
}  // namespace delta
