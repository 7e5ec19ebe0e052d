// `deltactl virtual-board` with the host's link session over its pseudo-terminal: the session
// opens PATH as a serial port (io::SerialPort), identifies the board, homes, enables, streams a
// short trajectory paced by telemetry, holds and disables; and the command's refusals.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../support/run_command.hpp"
#include "../support/stream_with_the_lab_loop.hpp"
#include "../support/virtual_board_process.hpp"
#include "delta/board_facts.hpp"
#include "delta/cosim/board_cosim.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/session.hpp"
#include "delta/nn/weights_file.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";

// A 2 mm spiral around where the plate starts, streamed over the pty by the lab's streaming loop:
// every sample is played, no underrun, no frame lost or bad on the clean line, nothing resent,
// drives off at the end.
TEST(VirtualBoard, SessionOverThePseudoTerminalStreamsAShortTrajectory) {
  const std::string dir = ::testing::TempDir() + "virtual_board_session_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string link = dir + "/tty";
  const std::string truth = dir + "/truth.csv";
  VirtualBoardProcess board(link, {"--weights", kWeights, "--truth", truth});
  const std::string ready = board.ready_line(60'000);
  ASSERT_NE(ready.find(link), std::string::npos) << "ready line: '" << ready << "'";

  const golden::QuantisedNetwork network = golden::quantise(nn::read_weights_file(kWeights).network);
  const auto start = std::chrono::steady_clock::now();
  {
    io::SerialPort port(link, static_cast<int>(board::kLinkBaud));
    link::SessionOptions options;
    options.frame_timeout_ms = 5000;  // the RTL simulation runs at about 0.4 x real time
    link::LinkSession session(port, options);
    const link::IdentifyPayload identify = session.identify();
    EXPECT_EQ(identify.protocol_version, board::kProtocolVersion);
    EXPECT_EQ(identify.setpoint_depth, board::kSetpointDepth);
    EXPECT_EQ(identify.build_id, kGatewareBuildId);
    EXPECT_EQ(identify.weights_crc, weights_crc(network));

    EXPECT_TRUE(session.set_home().has(link::TelemetryFlag::kHomed));
    const link::TelemetryPayload enabled = session.enable();
    ASSERT_TRUE(enabled.has(link::TelemetryFlag::kDriveEnable));
    Vec3 counts_deg;
    for (int j = 0; j < 3; ++j) counts_deg[j] = enabled.counts[j] * 0.01;
    const Vec3 centre = cosim::locate_plate(network, Geometry::nominal(), counts_deg);

    constexpr std::size_t kSamples = 200;
    std::vector<Vec3> spiral;  // one turn, radius growing from 0 to 1 mm
    for (std::size_t k = 0; k < kSamples; ++k) {
      const double s = static_cast<double>(k) / kSamples;
      spiral.push_back(centre + Vec3(1e-3 * s * std::cos(2 * M_PI * s), 1e-3 * s * std::sin(2 * M_PI * s), 0.0));
    }
    const LabStream stream = stream_with_the_lab_loop(session, network, spiral);
    const controller::StreamingResult& report = stream.result;
    const link::TelemetryPayload held = session.hold();
    const link::TelemetryPayload disabled = session.disable();
    const link::LinkStatistics& stats = session.statistics();
    std::cout << "played " << report.played << " of " << stream.planned << " from index " << report.first_index
              << "; telemetry " << stats.telemetry_frames << " (lost " << stats.lost_telemetry << ", skipped "
              << stats.skipped_telemetry << "); setpoints sent " << stats.setpoints_sent << " (resent "
              << stats.setpoints_resent << "); wake latency max " << report.latency.max_us() << " us; "
              << link::describe_state(disabled) << '\n';

    EXPECT_EQ(report.outcome, controller::StreamingResult::Outcome::kCompleted);
    EXPECT_GE(stream.planned, kSamples);  // the positions and the ramps' extra time
    EXPECT_EQ(report.played, stream.planned);
    EXPECT_EQ(held.sample_index, report.first_index + stream.planned);  // the board played them all
    EXPECT_EQ(report.last.underruns, report.first.underruns);           // none while streaming
    EXPECT_TRUE(held.has(link::TelemetryFlag::kHolding));
    EXPECT_FALSE(disabled.has(link::TelemetryFlag::kDriveEnable));
    EXPECT_EQ(disabled.fault_cause, 0);
    EXPECT_EQ(disabled.bad_frames, 0);
    // Nothing is lost on a pty: a resend happens only when the host ran late under load (its rule
    // then fires on setpoints still in flight; 10 of 562 once in CI), and each one is a duplicate
    // the board refuses. It never plays a sample twice (the held index above).
    EXPECT_EQ(disabled.rejected, stats.setpoints_resent);
    EXPECT_LE(stats.setpoints_resent * 10, stats.setpoints_sent);
    EXPECT_EQ(stats.lost_telemetry, 0u);
    EXPECT_EQ(stats.decoder.bad_crc + stats.decoder.bad_length + stats.decoder.unknown_type, 0u);
    EXPECT_GE(stats.telemetry_frames, kSamples);
  }
  std::cout << "session over the pty: "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() << " s wall\n";
  EXPECT_EQ(board.terminate(), 0);
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(link)));

  // TRUTH.csv, complete on exit: the SPEC columns at 1 kHz of board time, the drives on while
  // streaming and off at the end, the plate near the nominal home (71.3 mm below the base).
  std::istringstream rows(read_text(truth));
  std::string line;
  ASSERT_TRUE(std::getline(rows, line));
  EXPECT_EQ(line.rfind("t_s,x_m,y_m,z_m,true_alpha1_deg,true_alpha2_deg,true_alpha3_deg,drives_enabled", 0), 0u)
      << line;
  std::size_t count = 0, enabled = 0;
  double last_t = -1.0, z = 0.0;
  bool last_enabled = true;
  while (std::getline(rows, line)) {
    double t = 0, x = 0, y = 0, a1 = 0, a2 = 0, a3 = 0;
    int on = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%d", &t, &x, &y, &z, &a1, &a2, &a3, &on), 8)
        << line;
    if (count > 0) {
      EXPECT_NEAR(t - last_t, 1e-3, 1e-9) << line;
    }
    last_t = t;
    last_enabled = on != 0;
    enabled += on;
    ++count;
  }
  std::cout << "truth: " << count << " rows, drives on in " << enabled << "\n";
  EXPECT_GE(enabled, 200u);
  EXPECT_GT(count, enabled);
  EXPECT_FALSE(last_enabled);
  EXPECT_NEAR(z, -71.3e-3, 2e-3);
  std::filesystem::remove_all(dir);
}

// The model board behind the pty keeps to wall-clock time: a host streams 300 setpoints (a 1 mm
// circle) and every one is played, and the board's clock (telemetry ticks) never runs ahead of the
// wall clock (it may fall behind on a loaded machine, never ahead: the pacing waits).
TEST(VirtualBoard, ModelFidelityKeepsToWallClockTimeOverThePseudoTerminal) {
  const std::string dir = ::testing::TempDir() + "virtual_board_model_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string link = dir + "/tty";
  VirtualBoardProcess board(link, {"--weights", kWeights, "--truth", dir + "/truth.csv", "--fidelity", "model"});
  const std::string ready = board.ready_line(60'000);
  ASSERT_NE(ready.find("model fidelity (real time)"), std::string::npos) << "ready line: '" << ready << "'";

  const golden::QuantisedNetwork network = golden::quantise(nn::read_weights_file(kWeights).network);
  io::SerialPort port(link, static_cast<int>(board::kLinkBaud));
  link::LinkSession session(port);
  EXPECT_EQ(session.identify().weights_crc, weights_crc(network));
  session.set_home();
  const link::TelemetryPayload enabled = session.enable();
  const auto start = std::chrono::steady_clock::now();
  Vec3 counts_deg;
  for (int j = 0; j < 3; ++j) counts_deg[j] = enabled.counts[j] * 0.01;
  const Vec3 centre = cosim::locate_plate(network, Geometry::nominal(), counts_deg);
  constexpr std::size_t kSamples = 300;
  std::vector<Vec3> circle;
  for (std::size_t k = 0; k < kSamples; ++k) {
    const double phase = 2 * M_PI * static_cast<double>(k) / kSamples;
    circle.push_back(centre + 1e-3 * Vec3(std::cos(phase) - 1.0, std::sin(phase), 0.0));
  }
  const LabStream stream = stream_with_the_lab_loop(session, network, circle);
  const controller::StreamingResult& report = stream.result;
  const link::TelemetryPayload disabled = session.disable();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double board_s = (disabled.tick - enabled.tick) * link::kTickSeconds;
  std::cout << "board " << board_s << " s in " << wall_s << " s wall\n";
  EXPECT_EQ(report.outcome, controller::StreamingResult::Outcome::kCompleted);
  EXPECT_EQ(report.played, stream.planned);
  EXPECT_EQ(disabled.fault_cause, 0);
  EXPECT_GT(board_s, 0.3);            // 300 setpoints at 1 kHz, and the buffer drained
  EXPECT_LT(board_s, wall_s + 0.02);  // never ahead of the wall clock
  EXPECT_EQ(board.terminate(), 0);
  std::filesystem::remove_all(dir);
}

// --free-run: the model board runs faster than real time, and left alone (nobody reading, its pty
// full: it drops its bytes without writing into the full pty) it still talks to a host that opens
// the link later: telemetry frames arrive, and board time runs ahead of the wall clock.
TEST(VirtualBoard, FreeRunningModelBoardLeftAloneStillTalksToAHostThatComesLater) {
  const std::string dir = ::testing::TempDir() + "virtual_board_free_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string link = dir + "/tty";
  const std::string truth = dir + "/truth.csv";
  VirtualBoardProcess board(link, {"--weights", kWeights, "--truth", truth, "--fidelity", "model", "--free-run"});
  const std::string ready = board.ready_line(60'000);
  ASSERT_NE(ready.find("model fidelity"), std::string::npos) << "ready line: '" << ready << "'";
  ASSERT_EQ(ready.find("real time"), std::string::npos) << "ready line: '" << ready << "'";
  const auto start = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // nobody reads: the pty fills

  io::SerialPort port(link, static_cast<int>(board::kLinkBaud));
  link::FrameDecoder decoder(link::Receiver::kHost);
  std::vector<std::uint32_t> ticks;
  std::uint8_t buffer[4096];
  const auto reading = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - reading < std::chrono::milliseconds(300)) {
    if (!port.wait_readable(50)) continue;
    const std::size_t got = port.read_some(buffer, sizeof buffer);
    for (const link::Frame& frame : decoder.feed(buffer, got)) {
      if (frame.type == link::FrameType::kTelemetry) ticks.push_back(link::decode_telemetry(frame.payload).tick);
    }
  }
  EXPECT_EQ(board.terminate(), 0);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::size_t rows = 0;
  std::istringstream lines(read_text(truth));
  for (std::string line; std::getline(lines, line);) ++rows;
  const double board_s = static_cast<double>(rows - 1) * 1e-3;  // a row per millisecond of board time
  std::cout << "telemetry frames read in 0.3 s: " << ticks.size() << "; board " << board_s << " s in " << wall_s
            << " s wall\n";
  ASSERT_GE(ticks.size(), 100u);  // the bytes flow again once a host reads
  // Free-running: board time runs ahead of the wall clock, which a paced board never does (how far
  // ahead depends on the machine's load, so no speed is asserted here: scripts/bench_boards.sh).
  EXPECT_GT(board_s, wall_s);
  std::filesystem::remove_all(dir);
}

// Board time is real time, as on the real board: a paced model board whose process could not run
// for 300 ms (SIGSTOP) catches up afterwards instead of dropping the lag. Its truth (a row per
// millisecond of board time) covers the wall time since its ready line, less than one 100 ms
// allowance, and never runs ahead of it.
TEST(VirtualBoard, StarvedModelBoardCatchesUpWithTheWallClock) {
  const std::string dir = ::testing::TempDir() + "virtual_board_starved_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string link = dir + "/tty";
  const std::string truth = dir + "/truth.csv";
  VirtualBoardProcess board(link, {"--weights", kWeights, "--truth", truth, "--fidelity", "model"});
  ASSERT_NE(board.ready_line(60'000).find("real time"), std::string::npos);
  const auto start = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ::kill(board.pid(), SIGSTOP);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(board.pid(), SIGCONT);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(board.terminate(), 0);
  std::size_t rows = 0;
  std::istringstream lines(read_text(truth));
  for (std::string line; std::getline(lines, line);) ++rows;
  const double board_s = static_cast<double>(rows - 1) * 1e-3;
  std::cout << "board " << board_s << " s of board time in " << wall_s << " s wall (300 ms of it stopped)\n";
  EXPECT_GT(board_s, wall_s - 0.1) << "the lag was dropped, not caught up";
  EXPECT_LT(board_s, wall_s + 0.1);
  std::filesystem::remove_all(dir);
}

// The board's receive queue is bounded like a real port's: a writer faster than the line (1 Mbaud)
// is slowed down until its non-blocking writes fail, after at most the queue, the pty's buffer and
// a little more than the line carried meanwhile; then an identify still gets its answer.
TEST(VirtualBoard, AWriterFasterThanTheLineIsHeldBack) {
  const std::string dir = ::testing::TempDir() + "virtual_board_flood_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string link = dir + "/tty";
  VirtualBoardProcess board(link, {"--weights", kWeights, "--fidelity", "model"});
  ASSERT_NE(board.ready_line(60'000).find(link), std::string::npos);
  std::size_t accepted = 0;
  {
    const int fd = ::open(link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    ASSERT_GE(fd, 0);
    std::vector<std::uint8_t> junk(4096, 0x55);  // no sync byte: nothing but bytes to drop
    const auto start = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - start < std::chrono::seconds(2) && accepted < (64u << 20)) {
      const ssize_t n = ::write(fd, junk.data(), junk.size());
      if (n > 0)
        accepted += static_cast<std::size_t>(n);
      else
        ::usleep(1000);
    }
    ::close(fd);
  }
  std::cout << "accepted " << accepted << " bytes in 2 s (the line carries 200,000)\n";
  EXPECT_LT(accepted, 600'000u) << "the board took bytes far faster than its line";
  // What was accepted and not yet carried drains at the line's rate (10 us a byte) before a frame
  // sent now reaches the board.
  const std::size_t backlog = accepted > 200'000u ? accepted - 200'000u : 0;
  std::this_thread::sleep_for(std::chrono::milliseconds(100 + backlog / 100));
  io::SerialPort port(link, static_cast<int>(board::kLinkBaud));
  link::SessionOptions options;
  options.frame_timeout_ms = 5000;  // the queued bytes drain first
  link::LinkSession session(port, options);
  EXPECT_EQ(session.identify().protocol_version, board::kProtocolVersion);
  EXPECT_EQ(board.terminate(), 0);
  std::filesystem::remove_all(dir);
}

// Exclusive mode (TIOCEXCL, which io::SerialPort sets) ends when the program that set it closes
// PATH, as on a serial port, though the board keeps its side open; a second board on the same
// --link is refused and leaves the first's link alone, which still answers.
TEST(VirtualBoard, ExclusiveModeEndsWithItsProgramAndASecondBoardCannotTakeTheLink) {
  const std::string dir = ::testing::TempDir() + "virtual_board_excl_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string link = dir + "/tty";
  VirtualBoardProcess board(link, {"--weights", kWeights, "--fidelity", "model"});
  ASSERT_NE(board.ready_line(60'000).find(link), std::string::npos);
  const std::string target = std::filesystem::read_symlink(link).string();
  {
    io::SerialPort port(link, static_cast<int>(board::kLinkBaud));
    int exclusive = 0;
    ASSERT_EQ(::ioctl(port.fd(), TIOCGEXCL, &exclusive), 0);
    EXPECT_EQ(exclusive, 1) << "the serial port sets exclusive mode";
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  {
    const int fd = ::open(link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    ASSERT_GE(fd, 0);
    int exclusive = 1;
    ASSERT_EQ(::ioctl(fd, TIOCGEXCL, &exclusive), 0);
    EXPECT_EQ(exclusive, 0) << "exclusive mode outlived the program that set it";
    ::close(fd);
  }
  const CommandResult second = run_deltactl("virtual-board --fidelity model --link " + link);
  EXPECT_EQ(second.exit_code, 2) << second.err;
  EXPECT_NE(second.err.find("live"), std::string::npos) << second.err;
  EXPECT_EQ(std::filesystem::read_symlink(link).string(), target) << "the second board took the link";
  {
    io::SerialPort port(link, static_cast<int>(board::kLinkBaud));
    link::LinkSession session(port);
    EXPECT_EQ(session.identify().protocol_version, board::kProtocolVersion);
  }
  EXPECT_EQ(board.terminate(), 0);
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(link))) << "the board left its link";
  std::filesystem::remove_all(dir);
}

// --no-model: the board starts as after power-up, with no model (docs/board_link.md, "The model"):
// identify's CRC 0, flag 7 clear, the enable refused; a host's load over the pty (the model's
// frames as `host load` sends them) gives flag 7 and the model's CRC, and then the enable is taken.
TEST(VirtualBoard, WithNoModelItRefusesTheEnableUntilAHostLoadsOne) {
  const std::string dir = ::testing::TempDir() + "virtual_board_no_model_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string link = dir + "/tty";
  VirtualBoardProcess board(link, {"--no-model", "--fidelity", "model"});  // kept to real time
  const std::string ready = board.ready_line(60'000);
  ASSERT_NE(ready.find("no model"), std::string::npos) << "ready line: '" << ready << "'";
  const golden::QuantisedNetwork network = golden::quantise(nn::read_weights_file(kWeights).network);
  {
    io::SerialPort port(link, static_cast<int>(board::kLinkBaud));
    link::LinkSession session(port);
    EXPECT_EQ(session.identify().weights_crc, 0u);
    const link::TelemetryPayload homed = session.set_home();
    EXPECT_FALSE(homed.has(link::TelemetryFlag::kModel));
    bool refused = false;
    try {
      session.enable();
    } catch (const link::LinkError& error) {
      refused = error.kind() == link::LinkError::Kind::kRefused;
    }
    EXPECT_TRUE(refused) << "the enable was taken with no model";
    EXPECT_FALSE(session.last_telemetry()->has(link::TelemetryFlag::kDriveEnable));

    std::vector<std::uint8_t> bytes;
    std::uint8_t sequence = 200;
    for (const link::ModelPayload& frame : golden::model_frames(network)) {
      const std::vector<std::uint8_t> encoded = link::encode_frame(link::make_frame(sequence++, frame));
      bytes.insert(bytes.end(), encoded.begin(), encoded.end());
    }
    port.write_all(bytes.data(), bytes.size(), 1000);
    link::TelemetryPayload t = session.next_telemetry();
    for (int i = 0; i < 1000 && !t.has(link::TelemetryFlag::kModel); ++i) t = session.next_telemetry();
    EXPECT_TRUE(t.has(link::TelemetryFlag::kModel))
        << link::describe_state(t) << "; refused " << t.rejected << ", bad frames " << t.bad_frames << ", sequence "
        << int(t.sequence);
    EXPECT_EQ(session.identify().weights_crc, weights_crc(network));
    EXPECT_TRUE(session.enable().has(link::TelemetryFlag::kDriveEnable));
    session.disable();
  }
  EXPECT_EQ(board.terminate(), 0);
  // --no-model and --weights exclude each other.
  const CommandResult both = run_deltactl("virtual-board --link " + dir + "/tty2 --no-model --weights " + kWeights);
  EXPECT_EQ(both.exit_code, 2) << both.err;
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(dir + "/tty2")));
  std::filesystem::remove_all(dir);
}

TEST(VirtualBoard, RefusesAnUnknownFidelityAndAPathThatIsNotALink) {
  const std::string dir = ::testing::TempDir() + "virtual_board_refuse_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const CommandResult gates = run_deltactl("virtual-board --link " + dir + "/tty --fidelity gates");
  EXPECT_EQ(gates.exit_code, 2) << gates.err;
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(dir + "/tty")));

  const std::string file = dir + "/file";
  write_text(file, "keep me\n");
  const CommandResult taken = run_deltactl("virtual-board --link " + file);
  EXPECT_EQ(taken.exit_code, 2) << taken.err;
  EXPECT_NE(taken.err.find(file), std::string::npos) << taken.err;
  EXPECT_EQ(read_text(file), "keep me\n");

  const CommandResult effects = run_deltactl("virtual-board --link " + dir + "/tty --effects " + dir + "/none.json");
  EXPECT_EQ(effects.exit_code, 2) << effects.err;
  EXPECT_NE(effects.err.find("none.json"), std::string::npos) << effects.err;
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(dir + "/tty")));
  std::filesystem::remove_all(dir);
}

TEST(VirtualBoard, RefusesBadSafetyInputTimesInOneLineNamingTheOption) {
  const std::string dir = ::testing::TempDir() + "virtual_board_safety_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  for (const std::string bad :
       {"--estop-open-at x", "--estop-open-at 2,1", "--estop-open-at -1", "--estop-open-at 1,2,3",
        "--drive-fault-at 4,1", "--drive-fault-at 2", "--drive-fault-at 1,0.5,0.5",
        "--fidelity model --drive-fault-at 2,1 --drive-fault-at 0,1"}) {
    const CommandResult refused =
        run_deltactl("virtual-board --link " + dir + "/tty --truth " + dir + "/truth.csv " + bad);
    EXPECT_EQ(refused.exit_code, 2) << bad << ": " << refused.err;
    const std::string option = bad.find("drive") != std::string::npos ? "--drive-fault-at" : "--estop-open-at";
    EXPECT_EQ(refused.err.rfind("deltactl: error: " + option + ": ", 0), 0u) << bad << ": " << refused.err;
    EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << bad << ": " << refused.err;
    EXPECT_TRUE(refused.out.empty()) << bad << ": " << refused.out;
    EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(dir + "/tty"))) << bad;
    EXPECT_FALSE(std::filesystem::exists(dir + "/truth.csv")) << bad;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace delta::test
