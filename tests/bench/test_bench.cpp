// `deltactl bench` against the model-fidelity virtual board over its pty (kept to real time): each
// subcommand refuses without --limits-confirmed and on a board with a fault latched; the switches
// are seen toggling, at the count where the arms cross them, when the stage drags the arms through
// them; the encoder scale is measured between two angles the stage holds the arms at (exact on
// the nominal robot, 1 % off on a joint whose encoder scale is 1 % off); a soak over 10 s counts
// nothing, and one through a link that drops bytes fails naming the counters.
#include <gtest/gtest.h>

#include <poll.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "delta/geometry.hpp"
#include "delta/io/pseudo_terminal.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/kinematics.hpp"
#include "host_controller/host_bench.hpp"

namespace delta::test {
namespace {

const char* const kSubcommands[] = {"switches --duration 1", "scale --joint 1 --from 0 --to 20 --settle 0",
                                    "soak --seconds 1", "jog --joint 1 --direction +"};

TEST(BenchCli, EverySubcommandRefusesWithoutLimitsConfirmedBeforeOpeningThePort) {
  for (const char* sub : kSubcommands) {
    const CommandResult r = run_deltactl(std::string("bench ") + sub + " --port /nonexistent/tty");
    EXPECT_EQ(r.exit_code, 2) << sub << ": " << r.err;
    EXPECT_EQ(r.out, "") << sub;
    // One line: what to set and the flag (the port, which does not exist, was never opened).
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("LPC and LCC"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--limits-confirmed"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("nonexistent"), std::string::npos) << r.err;
  }
}

TEST(BenchCli, EverySubcommandsHelpSaysWhatItDoesWhatToDoWhatItPrintsAndItsExitCodes) {
  for (const char* sub : {"switches", "scale", "soak", "jog"}) {
    const CommandResult r = run_deltactl(std::string("bench ") + sub + " --help");
    EXPECT_EQ(r.exit_code, 0) << sub;
    for (const char* part : {"What it does:", "What you do:", "What it prints:", "Exit codes:", "--limits-confirmed"}) {
      EXPECT_NE(r.out.find(part), std::string::npos) << sub << " --help lacks " << part;
    }
  }
}

// The virtual board, model fidelity, not homed (the bench needs no homing).
Bench model_board(const std::string& name, std::vector<std::string> extra = {}) {
  std::vector<std::string> arguments = {"--fidelity", "model"};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  return Bench(name, arguments, false);
}

std::string bench_command(const Bench& b, const std::string& sub) {
  return "bench " + sub + " --port " + b.link + " --limits-confirmed --link-timeout-ms 2000";
}

// `host status` once it names `text` (the board's time runs from its start: a fault injected at
// S s of board time is latched some time after the ready line), within 10 s.
CommandResult status_naming(const Bench& b, const std::string& text) {
  CommandResult status;
  for (int attempt = 0; attempt < 100; ++attempt) {
    status = run_deltactl("host status --port " + b.link + " --link-timeout-ms 2000");
    if (status.out.find(text) != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return status;
}

TEST(Bench, EverySubcommandRefusesABoardWithAFaultLatchedNamingIt) {
  // An encoder skip at 50 ms of board time latches fault cause 0 (the drives off).
  Bench b = model_board("fault", {"--inject-encoder-skip-at", "0.05"});
  const CommandResult status = status_naming(b, "encoder skip");
  ASSERT_NE(status.out.find("encoder skip"), std::string::npos) << status.out << status.err;
  for (const char* sub : kSubcommands) {
    const CommandResult r = run_deltactl(bench_command(b, sub));
    EXPECT_EQ(r.exit_code, 3) << sub << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("fault latched"), std::string::npos) << sub << ": " << r.err;
    EXPECT_NE(r.err.find("encoder skip"), std::string::npos) << sub << ": " << r.err;
  }
}

// A stage drag file: the plate at FK(a, a, a) of the nominal robot (every joint at a), through
// (time s, angle deg) waypoints, cosine-blended between them, every 10 ms.
std::string write_drag(const std::string& path, const std::vector<std::pair<double, double>>& waypoints) {
  std::ofstream out(path);
  out << "t_s,x_m,y_m,z_m\n";
  for (std::size_t k = 0; k + 1 < waypoints.size(); ++k) {
    const auto [t0, a0] = waypoints[k];
    const auto [t1, a1] = waypoints[k + 1];
    for (double t = t0; t < t1 - 1e-9; t += 0.01) {
      const double s = 0.5 - 0.5 * std::cos(M_PI * (t - t0) / (t1 - t0));
      const double a = a0 + (a1 - a0) * s;
      const FkSolution fk = forward_kinematics(Geometry::nominal(), Vec3(a, a, a));
      if (!fk.ok()) throw std::runtime_error("no pose at " + std::to_string(a) + " deg");
      out << t << ',' << fk.position_m.x() << ',' << fk.position_m.y() << ',' << fk.position_m.z() << '\n';
    }
  }
  const FkSolution end = forward_kinematics(Geometry::nominal(), Vec3::Constant(waypoints.back().second));
  out << waypoints.back().first << ',' << end.position_m.x() << ',' << end.position_m.y() << ',' << end.position_m.z()
      << '\n';
  return path;
}

TEST(Bench, SwitchesAreSeenTogglingWhereTheStageDragsTheArmsAcrossThem) {
  // The nominal robot at rest with every arm at 26 deg (below its switch at 30 deg); the board counts
  // from its home count (3000) there. The stage lifts the arms to 34 deg and lowers them again (at
  // most 6.3 deg/s: 6.3 counts between telemetry frames).
  const std::string dir = temp_dir("bench_switch_drag");
  const std::string drag =
      write_drag(dir + "/drag.csv", {{0.0, 26.0}, {0.5, 26.0}, {2.5, 34.0}, {4.5, 26.0}, {5.0, 26.0}});
  Bench b = model_board("switches", {"--effects", "", "--start-angles", "26,26,26", "--stage", "drag:" + drag,
                                     "--stage-log", dir + "/stage.csv", "--stage-seed", "1"});
  const CommandResult r = run_deltactl(bench_command(b, "switches --duration 7.5"));
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("switches at the start: 1 open (count 3000), 2 open (count 3000), 3 open (count 3000)"),
            std::string::npos)
      << r.out;
  for (int j = 1; j <= 3; ++j) {
    const std::string s = std::to_string(j);
    EXPECT_NE(r.out.find("switch " + s + " closed at count"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("switch " + s + " opened at count"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("switch " + s + ": seen open and closed"), std::string::npos) << r.out;
  }
  // Each switch closes at 30 deg, 4 deg (400 counts) above where the arms started, and opens there: the
  // frame that shows it within 1 ms and the synchroniser's clocks of the crossing.
  std::istringstream lines(r.out);
  int edges = 0;
  for (std::string line; std::getline(lines, line);) {
    const std::size_t at = line.find(" at count ");
    if (line.find(": switch ") == std::string::npos || at == std::string::npos) continue;
    const int count = std::stoi(line.substr(at + 10));
    EXPECT_NEAR(count, 3400, 8) << line;
    ++edges;
  }
  EXPECT_EQ(edges, 6) << r.out;  // each switch once closed, once opened
}

TEST(Bench, SwitchesNeverMovedFailNamingThem) {
  Bench b = model_board("switches_still", {"--effects", "", "--start-angles", "22,22,22"});
  const CommandResult r = run_deltactl(bench_command(b, "switches --duration 0.5"));
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("switch 1 never seen closed, switch 2 never seen closed, switch 3 never seen closed"),
            std::string::npos)
      << r.err;
}

// Scale: the stage holds the arms at 20 deg (from 1 s of board time on, after its 1 s approach),
// then at 40 deg from 5 s on; the readings come after --settle 3 s at each fixture.
struct ScaleRun {
  CommandResult result;
  double error_percent = NAN;
};
// `reading`: how the readings are taken (--settle 3, or Enter from `input`, a shell pipe's first part).
ScaleRun scale_run(const std::string& name, const std::string& effects_json, int joint,
                   const std::string& reading = "--settle 3", const std::string& input = "") {
  const std::string dir = temp_dir("bench_scale_" + name);
  const std::string drag = write_drag(dir + "/drag.csv", {{0.0, 20.0}, {2.5, 20.0}, {4.0, 40.0}, {6.0, 40.0}});
  std::vector<std::string> extra = {"--start-angles", "30,30,30",         "--stage",      "drag:" + drag,
                                    "--stage-log",    dir + "/stage.csv", "--stage-seed", "2"};
  std::string effects = "";
  if (!effects_json.empty()) {
    effects = dir + "/effects.json";
    write_text(effects, effects_json);
  }
  extra.insert(extra.begin(), {"--effects", effects});
  Bench b = model_board("scale_" + name, extra);
  ScaleRun run;
  run.result =
      run_deltactl(bench_command(b, "scale --joint " + std::to_string(joint) + " --from 20 --to 40 " + reading), input);
  const std::size_t at = run.result.out.find("error ");
  if (at != std::string::npos) run.error_percent = std::stod(run.result.out.substr(at + 6));
  return run;
}

TEST(Bench, ScaleMeasuresTheEncodersCountsPerDegreeBetweenTwoHeldAngles) {
  // The nominal robot: 2000 counts over the 20 deg, to the stage's 7 nm noise.
  const ScaleRun exact = scale_run("nominal", "", 1);
  EXPECT_EQ(exact.result.exit_code, 0) << exact.result.out << exact.result.err;
  EXPECT_NEAR(exact.error_percent, 0.0, 0.05) << exact.result.out;
  EXPECT_NE(exact.result.out.find("expected (0.01 deg a count)"), std::string::npos) << exact.result.out;
  // Joint 2's encoder 1 % fast: 101 counts per degree, outside the 0.5 % tolerance.
  const ScaleRun off = scale_run("off", R"({"encoder_scale": [0.0, 0.01, 0.0]})", 2);
  EXPECT_EQ(off.result.exit_code, 1) << off.result.out << off.result.err;
  EXPECT_NEAR(off.error_percent, 1.0, 0.05) << off.result.out;
  EXPECT_NE(off.result.err.find("joint 2's scale is 1.0"), std::string::npos) << off.result.err;
}

TEST(Bench, ScaleReadsAtEachEnterAndRefusesAnInputThatEndsFirst) {
  // Enter 3 s and 6 s after the start (the board keeps to the wall clock): at 20 and at 40 deg.
  const ScaleRun entered = scale_run("enter", "", 3, "", "(sleep 3; echo; sleep 3; echo) | ");
  EXPECT_EQ(entered.result.exit_code, 0) << entered.result.out << entered.result.err;
  EXPECT_NEAR(entered.error_percent, 0.0, 0.05) << entered.result.out;
  EXPECT_NE(entered.result.err.find("hold joint 3 at the second fixture, 40.00 deg, then press Enter"),
            std::string::npos)
      << entered.result.err;
  const ScaleRun ended = scale_run("no_enter", "", 3, "", "true | ");
  EXPECT_EQ(ended.result.exit_code, 2) << ended.result.out << ended.result.err;
  EXPECT_NE(ended.result.err.find("give --settle S"), std::string::npos) << ended.result.err;
  EXPECT_EQ(ended.result.out.find("scale:"), std::string::npos) << ended.result.out;
}

TEST(Bench, SoakOnACleanLinkCountsNothing) {
  Bench b = model_board("soak");
  // Late frames are wall time: on a test machine shared with builds the virtual board's process can
  // fall 100 ms behind and catch up (its telemetry then comes in a burst), so 1 s here.
  const CommandResult r = run_deltactl(bench_command(b, "soak --seconds 10 --late-ms 1000"));
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* counter :
       {"board bad frames: 0", "board underruns: 0", "board saturations: 0", "board slew limits: 0", "board refused: 0",
        "host CRC errors: 0", "lost telemetry frames: 0", "missed telemetry periods: 0", "late telemetry frames: 0",
        "unanswered identify requests: 0"}) {
    EXPECT_NE(r.out.find(counter), std::string::npos) << counter << "\n" << r.out;
  }
  // Every telemetry frame of the 10 s read (a frame a millisecond), identify replies at full rate.
  ASSERT_NE(r.out.find("  telemetry frames: "), std::string::npos) << r.out;
  EXPECT_NEAR(std::stoi(r.out.substr(r.out.find("  telemetry frames: ") + 20)), 10000, 50) << r.out;
  EXPECT_GT(std::stoi(r.out.substr(r.out.find("identify replies: ") + 18)), 3000) << r.out;
  EXPECT_NE(r.err.find("bench soak: 10 s of board time, drives off"), std::string::npos) << r.err;
}

TEST(Bench, ACtrlCEndsASoakWithItsCountersSoFar) {
  Bench b = model_board("soak_interrupted");
  HostProcess soak(
      {"bench", "soak", "--minutes", "10", "--port", b.link, "--limits-confirmed", "--link-timeout-ms", "2000"},
      b.dir + "/soak");
  std::this_thread::sleep_for(std::chrono::seconds(2));
  ::kill(soak.pid(), SIGINT);
  EXPECT_EQ(soak.wait(10.0), 128 + SIGINT) << soak.err();
  EXPECT_NE(soak.out().find("host CRC errors: 0"), std::string::npos) << soak.out();
  EXPECT_NE(soak.err().find("bench soak: stopped by signal 2 (drives off)"), std::string::npos) << soak.err();
}

// A link between the virtual board's pty and a pty of its own that drops every Nth byte each way.
class LossyLink {
 public:
  LossyLink(const std::string& board_link, const std::string& host_link, std::size_t drop_to_host_every,
            std::size_t drop_to_board_every)
      : board_(board_link, 1000000),
        host_(host_link),
        to_host_every_(drop_to_host_every),
        to_board_every_(drop_to_board_every) {
    thread_ = std::thread([this] { run(); });
  }
  ~LossyLink() {
    stop_ = true;
    thread_.join();
  }
  std::size_t dropped() const { return dropped_; }

 private:
  // Returns the bytes read from `from`.
  std::size_t forward(io::ByteStream& from, io::ByteStream& to, std::size_t every, std::size_t& counter) {
    std::uint8_t buffer[1024], kept[1024];
    const std::size_t got = from.read_some(buffer, sizeof buffer);
    if (&to == &host_ && !host_spoke_) return got;  // nobody there yet: a board's bytes go nowhere
    std::size_t n = 0;
    for (std::size_t i = 0; i < got; ++i) {
      if (++counter % every == 0) {
        ++dropped_;
      } else {
        kept[n++] = buffer[i];
      }
    }
    if (n > 0) to.write_all(kept, n, 100);
    return got;
  }
  void run() {
    std::size_t to_host = 0, to_board = 0;
    for (int turn = 0; !stop_; ++turn) {
      pollfd p[2] = {{board_.fd(), POLLIN, 0}, {host_.fd(), POLLIN, 0}};
      ::poll(p, 2, 1);
      try {
        forward(board_, host_, to_host_every_, to_host);
        // The board's bytes reach the host from its first byte on (before it, they would wait in
        // the pty for the host to open it: stale telemetry a host would count against its identify).
        if (forward(host_, board_, to_board_every_, to_board) > 0) host_spoke_ = true;
      } catch (const std::exception&) {  // the host side full or gone: the bytes are dropped
      }
      if (turn % 128 == 0) host_.release_exclusive();
    }
  }
  io::SerialPort board_;
  io::PseudoTerminal host_;
  std::size_t to_host_every_, to_board_every_;
  bool host_spoke_ = false;
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> dropped_{0};
  std::thread thread_;
};

TEST(Bench, SoakThroughALinkThatDropsBytesFailsNamingTheCounters) {
  Bench b = model_board("soak_lossy");
  const std::string lossy = b.dir + "/lossy";
  LossyLink link(b.link, lossy, 20011, 7001);  // primes: the drops wander through the frames
  const CommandResult r =
      run_deltactl("bench soak --seconds 5 --port " + lossy + " --limits-confirmed --link-timeout-ms 2000");
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_GT(link.dropped(), 10u);
  // Bytes lost on the way to the host break its frames; bytes lost on the way to the board break the board's.
  EXPECT_NE(r.err.find("the link counted faults: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("host CRC errors"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("board bad frames"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lost telemetry frames"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("host CRC errors: 0"), std::string::npos) << r.out;
}

TEST(Bench, ABoardWhoseEstopChainOpenedIsRefusedNamingIt) {
  Bench b = model_board("estop", {"--estop-open-at", "0.1"});
  const CommandResult status = status_naming(b, "e-stop input open");
  ASSERT_NE(status.out.find("e-stop input open"), std::string::npos) << status.out << status.err;
  for (const char* sub : kSubcommands) {
    const CommandResult r = run_deltactl(bench_command(b, sub));
    EXPECT_EQ(r.exit_code, 3) << sub << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("e-stop input open"), std::string::npos) << sub << ": " << r.err;
  }
}

// The truth's drives_enabled column: the board time of its first and last row at 1, and the rows at 1.
struct DrivesOn {
  double first_s = -1.0, last_s = -1.0;
  std::size_t rows = 0;
  bool off_at_end = false;
};
DrivesOn drives_on_in(const std::string& truth_path) {
  const Table truth = read_table(truth_path);
  DrivesOn on;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    if (truth.at(i, "drives_enabled") == 0) continue;
    if (on.first_s < 0) on.first_s = truth.at(i, "t_s");
    on.last_s = truth.at(i, "t_s");
    ++on.rows;
  }
  on.off_at_end = !truth.rows.empty() && truth.at(truth.rows.size() - 1, "drives_enabled") == 0;
  return on;
}

TEST(Bench, AJogMovesTheJointTheWayItsCurrentPushesForHalfASecondThenTheDrivesAreOff) {
  for (const char* direction : {"+", "-"}) {
    Bench b = model_board(std::string("jog") + (direction[0] == '+' ? "_up" : "_down"));
    const CommandResult r =
        run_deltactl(bench_command(b, std::string("jog --max-move-deg 90 --joint 2 --direction ") + direction));
    EXPECT_EQ(r.exit_code, 0) << direction << ": " << r.out << r.err;
    EXPECT_NE(r.out.find(direction[0] == '+' ? "count rising" : "count falling"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("jog: ok"), std::string::npos) << r.out;
    ASSERT_EQ(b.board->terminate(), 0);
    // The board's drive enable pin: on once, for the jog's 0.5 s, off at the end.
    const DrivesOn on = drives_on_in(b.truth);
    EXPECT_NEAR(static_cast<double>(on.rows), 500.0, 3.0) << direction;
    EXPECT_NEAR(on.last_s - on.first_s, 0.5, 0.005) << direction;
    EXPECT_TRUE(on.off_at_end) << direction;
  }
}

TEST(Bench, TheHostEndsAJogOnceTheJointHasMovedFiveDegrees) {
  Bench b = model_board("jog_bounded");
  const CommandResult r = run_deltactl(bench_command(b, "jog --joint 1 --direction +"));
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.err.find("the host ended the jog (--max-move-deg 5.00)"), std::string::npos) << r.err;
  const std::size_t at = r.out.find("joint 1 moved ");
  ASSERT_NE(at, std::string::npos) << r.out;
  const int moved = std::stoi(r.out.substr(at + 14));
  // At least the bound (the disable goes out at the frame that shows 5 deg; the arm moves on meanwhile,
  // and further still should the virtual board fall behind the wall clock and catch up).
  EXPECT_GE(moved, 500) << r.out;
  ASSERT_EQ(b.board->terminate(), 0);
  const DrivesOn on = drives_on_in(b.truth);
  EXPECT_GT(on.rows, 0u);
  EXPECT_LT(on.rows, 450u);
  EXPECT_TRUE(on.off_at_end);
}

TEST(Bench, AJogTheWrongWayOrOfASeizedJointFails) {
  {
    Bench b = model_board("jog_reversed");
    const CommandResult r = run_deltactl(bench_command(b, "jog --joint 1 --direction - --expect-sign +"));
    EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("joint 1 moved the wrong way"), std::string::npos) << r.err;
  }
  {
    Bench b = model_board("jog_seized", {"--inject-seized-joint", "3"});
    const CommandResult r = run_deltactl(bench_command(b, "jog --joint 3 --direction +"));
    EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("joint 3 did not move"), std::string::npos) << r.err;
    ASSERT_EQ(b.board->terminate(), 0);
    EXPECT_TRUE(drives_on_in(b.truth).off_at_end);
  }
}

TEST(Bench, ACtrlCInAJogTurnsTheDrivesOffAtOnce) {
  Bench b = model_board("jog_interrupted");
  HostProcess jog({"bench", "jog", "--joint", "1", "--direction", "+", "--port", b.link, "--limits-confirmed",
                   "--link-timeout-ms", "2000"},
                  b.dir + "/jog");
  // Signalled 100 ms after the jog was sent (its note on stderr).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline && jog.err().find("open loop") == std::string::npos) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ::kill(jog.pid(), SIGINT);
  EXPECT_EQ(jog.wait(10.0), 128 + SIGINT) << jog.err();
  ASSERT_EQ(b.board->terminate(), 0);
  const DrivesOn on = drives_on_in(b.truth);
  EXPECT_GT(on.rows, 0u);
  EXPECT_LT(on.rows, 450u);  // ended before the board's own 0.5 s
  EXPECT_TRUE(on.off_at_end);
}

}  // namespace
}  // namespace delta::test
