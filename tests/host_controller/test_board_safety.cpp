// The board's own safety against the model-fidelity virtual board (kept to real time) through its
// pty: an e-stop chain opened and a drive's fault line raised mid-run (`deltactl virtual-board
// --estop-open-at`, `--drive-fault-at`) each turn the drives off within 1 ms of board time, latch
// their named cause (status names it), end the run with exit 3 naming it and the recording kept,
// and nothing moves whatever the host sends until the input is back and a clear is sent; then a
// run works. The host's e-stop sends the board's e-stop command: the board itself latches, so a
// second program's enable is refused.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"
#include "host_bench.hpp"

namespace delta::test {
namespace {

// The board time at which the input goes to stop: well after homing from the home pose (the
// homing's board time is checked), and the run started right after it streams past it.
constexpr double kStopAtS = 14.0;
constexpr double kStopUntilS = 24.0;

// One command frame written to the board's port by a second program beside the host.
void send_command_from_another_program(const std::string& port, std::uint8_t command) {
  const int fd = ::open(port.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  ASSERT_GE(fd, 0) << port;
  link::Frame frame;
  frame.type = link::FrameType::kCommand;
  frame.payload = {command};
  const std::vector<std::uint8_t> bytes = link::encode_frame(frame);
  ASSERT_EQ(::write(fd, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  ::close(fd);
}

nlohmann::json board_status(const std::string& port) {
  const CommandResult status = run_deltactl("host status --port " + port + " --json");
  EXPECT_EQ(status.exit_code, 0) << status.err;
  return nlohmann::json::parse(status.out, nullptr, false);
}

// Waits (wall time) until the board's time has passed t_s.
void wait_for_board_time(const std::string& port, double t_s) {
  for (int i = 0; i < 600; ++i) {
    const nlohmann::json s = board_status(port);
    if (s.is_object() && s.value("tick", 0.0) / 1e4 > t_s) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  FAIL() << "board time never passed " << t_s << " s";
}

// The truth from `from_s` on: the drives never on before `until_s` (and, with `input`, the input's
// column at stop exactly over [stop_s, stop_until_s)); the board time of the first drives-on row at or
// after until_s (-1: none).
double check_truth(const std::string& truth_path, const std::string& input, double from_s, double until_s) {
  const Table truth = read_table(truth_path);
  double first_on_after = -1.0;
  std::size_t rows = 0;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    const double t = truth.at(i, "t_s");
    const bool at_stop = t >= kStopAtS - 5e-7 && t < kStopUntilS - 5e-7;
    EXPECT_EQ(truth.at(i, input) != 0, at_stop) << input << " at " << t << " s";
    if (t < from_s) continue;
    ++rows;
    const bool on = truth.at(i, "drives_enabled") != 0;
    if (t < until_s) {
      EXPECT_FALSE(on) << "the drives on at " << t << " s, after the stop at " << kStopAtS << " s";
    } else if (on && first_on_after < 0) {
      first_on_after = t;
    }
  }
  EXPECT_GT(rows, 1000u);
  return first_on_after;
}

// A run of `host run` that meets the stop: exit 3 naming `cause`, the recording kept with the fault in it.
void expect_run_ended_by(const HostProcess& host, int code, const std::string& record, const std::string& cause) {
  std::cout << host.out() << host.err();
  EXPECT_EQ(code, 3);
  EXPECT_NE((host.out() + host.err()).find(cause), std::string::npos) << host.out() << host.err();
  ASSERT_TRUE(std::filesystem::exists(record)) << record;
  const Table out = read_table(record);
  ASSERT_GT(out.rows.size(), 500u);
  std::size_t on = 0, faulted = 0;
  for (std::size_t i = 0; i < out.rows.size(); ++i) {
    on += out.at(i, "drives_enabled") != 0;
    faulted += out.at(i, "board_fault_bits") != 0;
  }
  EXPECT_GT(on, 500u);
  EXPECT_GT(faulted, 0u) << "the recording does not show the board's cause";
  EXPECT_EQ(out.at(out.rows.size() - 1, "drives_enabled"), 0);
}

TEST(BoardSafety, AnEstopInputOpenedMidRunStopsEverythingUntilItClosesAndAClearIsSent) {
  Server server("board_estop_input", {"--estop-open-at", std::to_string(kStopAtS) + "," + std::to_string(kStopUntilS)});
  ASSERT_EQ(server.ctl("home").exit_code, 0);
  const double homed_at = server.status().value("board_time_s", 1e9);
  std::cout << "homed at board time " << homed_at << " s\n";
  ASSERT_LT(homed_at, kStopAtS - 3.0) << "homing took too long for the test's stop time";
  auto run = server.start_run(kStopAtS - homed_at + 4.0, "stopped.csv");
  const int code = run->wait(120);
  expect_run_ended_by(*run, code, server.recorded("stopped.csv"), "e-stop input open");
  nlohmann::json status = server.status();
  EXPECT_EQ(status.value("fault", ""), "e-stop input open") << status.dump();
  EXPECT_EQ(status.value("board_fault_bits", -1), 1) << status.dump();
  // While the chain is open: enable and run refused, the clear refused naming the open input.
  for (const std::string asked : {"enable", "run --trajectory experiment1 --duration 1"}) {
    const CommandResult refused = server.ctl(asked);
    EXPECT_EQ(refused.exit_code, 3) << asked << ": " << refused.out << refused.err;
    EXPECT_NE((refused.out + refused.err).find("e-stop input open"), std::string::npos) << asked << refused.err;
  }
  const CommandResult early = server.ctl("clear-fault");
  EXPECT_NE(early.exit_code, 0);
  EXPECT_NE((early.out + early.err).find("e-stop input is still open"), std::string::npos) << early.out << early.err;
  // Closed: still latched until the clear; then a run works.
  ASSERT_TRUE(
      server.wait_for([](const nlohmann::json& s) { return s.value("board_time_s", 0.0) > kStopUntilS + 0.5; }, 60));
  EXPECT_EQ(server.status().value("fault", ""), "e-stop input open");
  const double clear_at = server.status().value("board_time_s", 0.0);
  const CommandResult clear = server.ctl("clear-fault");
  ASSERT_EQ(clear.exit_code, 0) << clear.out << clear.err;
  auto again = server.start_run(1.0, "after.csv");
  EXPECT_EQ(again->wait(120), 0) << again->out() << again->err();
  ::kill(server.serve->pid(), SIGTERM);
  EXPECT_EQ(server.serve->wait(30), 0);
  ASSERT_EQ(server.bench.board->terminate(), 0);
  const double on_again = check_truth(server.bench.truth, "estop_open", kStopAtS + 1e-3, clear_at);
  EXPECT_GT(on_again, clear_at) << "the run after the clear never turned the drives on";
  std::filesystem::remove_all(server.bench.dir);
}

TEST(BoardSafety, ADriveFaultMidRunEndsHostRunNamingItAndNothingMovesUntilAClear) {
  Bench bench("board_drive_fault", {"--fidelity", "model", "--drive-fault-at",
                                    "2," + std::to_string(kStopAtS) + "," + std::to_string(kStopUntilS)});
  const double homed_at = board_status(bench.link).value("tick", 1e9) / 1e4;
  std::cout << "homed at board time " << homed_at << " s\n";
  ASSERT_LT(homed_at, kStopAtS - 3.0) << "homing took too long for the test's stop time";
  HostProcess host(bench.run_arguments(bench.link, kStopAtS - homed_at + 4.0), bench.dir + "/host");
  expect_run_ended_by(host, host.wait(120), bench.dir + "/out.csv", "drive 2 fault");
  nlohmann::json status = board_status(bench.link);
  EXPECT_EQ(status.value("fault", ""), "drive 2 fault") << status.dump();
  EXPECT_EQ(status.value("board_fault_bits", -1), 1 << 2) << status.dump();
  // Whatever is sent: host run refused naming the cause; another program's enable and clear refused.
  HostProcess refused(bench.run_arguments(bench.link, 1.0), bench.dir + "/refused");
  EXPECT_EQ(refused.wait(60), 3);
  EXPECT_NE(refused.err().find("drive 2 fault"), std::string::npos) << refused.err();
  const int rejected = board_status(bench.link).value("rejected", 0);
  send_command_from_another_program(bench.link, static_cast<std::uint8_t>(link::Command::kEnable));
  send_command_from_another_program(bench.link, static_cast<std::uint8_t>(link::Command::kClearFault));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  status = board_status(bench.link);
  EXPECT_EQ(status.value("rejected", 0), rejected + 2) << status.dump();
  EXPECT_EQ(status.value("fault", ""), "drive 2 fault") << status.dump();
  // The drive's fault gone: a clear (from anyone) is taken, then a run works.
  wait_for_board_time(bench.link, kStopUntilS + 0.5);
  const double clear_at = board_status(bench.link).value("tick", 0.0) / 1e4;
  send_command_from_another_program(bench.link, static_cast<std::uint8_t>(link::Command::kClearFault));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_TRUE(board_status(bench.link)["fault"].is_null());
  HostProcess again(bench.run_arguments(bench.link, 1.0), bench.dir + "/again");
  EXPECT_EQ(again.wait(120), 0) << again.out() << again.err();
  ASSERT_EQ(bench.board->terminate(), 0);
  const double on_again = check_truth(bench.truth, "drive_fault2", kStopAtS + 1e-3, clear_at);
  EXPECT_GT(on_again, clear_at);
  // The faulted drive gives no current from its fault on (its plant step after it).
  const Table truth = read_table(bench.truth);
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    const double t = truth.at(i, "t_s");
    if (t > kStopAtS + 2e-4 && t < kStopUntilS) {
      EXPECT_EQ(truth.at(i, "current2_a"), 0.0) << t;
    }
  }
  std::filesystem::remove_all(bench.dir);
}

TEST(BoardSafety, TheHostsEstopLatchesOnTheBoardItselfSoASecondProgramsEnableIsRefused) {
  Server server("board_estop_command");
  ASSERT_EQ(server.ctl("home").exit_code, 0);
  ASSERT_EQ(server.ctl("enable").exit_code, 0);
  const CommandResult estop = server.ctl("estop");
  ASSERT_EQ(estop.exit_code, 0) << estop.err;
  const double estopped_at = server.status().value("board_time_s", 0.0);
  EXPECT_EQ(server.status().value("fault", ""), "e-stop command") << server.status().dump();
  // The controller gone (its latch with it): the board still refuses a second program's enable.
  ::kill(server.serve->pid(), SIGTERM);
  ASSERT_EQ(server.serve->wait(30), 0);
  nlohmann::json status = board_status(server.bench.link);
  EXPECT_TRUE(status.value("estop_on_board", false)) << status.dump();
  const int rejected = status.value("rejected", 0);
  send_command_from_another_program(server.bench.link, static_cast<std::uint8_t>(link::Command::kEnable));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  status = board_status(server.bench.link);
  EXPECT_EQ(status.value("rejected", 0), rejected + 1) << status.dump();
  EXPECT_EQ(status.value("fault", ""), "e-stop command");
  ASSERT_EQ(server.bench.board->terminate(), 0);
  const Table truth = read_table(server.bench.truth);
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    if (truth.at(i, "t_s") > estopped_at + 0.1) {
      EXPECT_EQ(truth.at(i, "drives_enabled"), 0) << truth.at(i, "t_s");
    }
  }
  std::filesystem::remove_all(server.bench.dir);
}

}  // namespace
}  // namespace delta::test
