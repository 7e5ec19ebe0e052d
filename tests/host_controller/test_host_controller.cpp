// `deltactl host` against `deltactl virtual-board` through a pseudo-terminal, the acceptance of
// experiment 1 streamed and followed (joints and plate), the host stopped (SIGSTOP: the
// board's watchdog, then exit 4 without re-enabling), 1 % of the bytes corrupted by a tap, an
// encoder skip (exit 3), the board killed (exit 4 within 100 ms), and bad trajectories refused
// before any byte is sent (exit 2). The virtual board runs at ~0.1-0.3 x real time: the host is
// paced by telemetry; time bounds on the board are read from its truth (board time).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "delta/board_facts.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/io/pseudo_terminal.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/nn/weights_file.hpp"
#include "host_bench.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

// The co-simulation of the same run: the same host code (the plan, the streaming loop) in board
// time against the model board and the paper-like robot (the virtual board's default), experiment 1
// for `duration_s`; its plate error, RMS distance from path time 0.4 s [m].
double cosim_plate_rms_m(const std::string& weights, double duration_s) {
  const CommandResult cosim =
      run_deltactl("cosim --fidelity model --weights " + weights + " --effects " + std::string(DELTA_SOURCE_DIR) +
                   "/sim/paper_like_effects.json --trajectory experiment1 --duration " + std::to_string(duration_s));
  if (cosim.exit_code != 0) throw std::runtime_error("deltactl cosim: " + cosim.err);
  std::istringstream lines(cosim.out);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("| closed loop:", 0) != 0) continue;
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, '|');) cells.push_back(cell);
    return std::stod(cells.at(5)) * 1e-6;  // | label | x | y | z | distance | max |
  }
  throw std::runtime_error("deltactl cosim printed no closed-loop row: " + cosim.out);
}

// The golden joint reference (degrees, Q24.8 counts converted) the board plays for a position
// code: the network's answer y, then round_shift(25 y, 4) (docs/board_link.md).
double golden_reference_deg(const golden::QuantisedNetwork& network, const Vec3& position_m, int joint) {
  const golden::RawOutput raw = golden::evaluate_raw(network, golden::encode_position(network.formats, position_m));
  const std::int64_t counts_q8 = (25 * raw.alpha[joint] + 8) >> 4;
  return counts_q8 / 256.0 * 0.01;
}

// Joint tracking of a host run's recording: RMS of encoder - the board's joint reference per joint
// over the path (tau >= 0) with the drives on; `frames` gets how many rows that is.
Vec3 joint_tracking_rms_deg(const Table& out, std::size_t* frames = nullptr) {
  Vec3 sum_sq = Vec3::Zero();
  std::size_t n = 0;
  for (std::size_t i = 0; i < out.rows.size(); ++i) {
    if (out.at(i, "tau_s") < 0.0 || out.at(i, "drives_enabled") == 0) continue;
    for (int j = 0; j < 3; ++j) {
      const std::string k = std::to_string(j + 1);
      const double e = out.at(i, "alpha" + k + "_deg") - out.at(i, "alpha" + k + "_ref_deg");
      sum_sq[j] += e * e;
    }
    ++n;
  }
  if (frames != nullptr) *frames = n;
  return (sum_sq / static_cast<double>(n)).cwiseSqrt();
}

// Rows of the recording where the board's joint reference is not the golden answer for the
// position the host sent (stream samples only, the drives on, no underrun or lost frame near).
std::size_t reference_mismatches(const Table& out, const golden::QuantisedNetwork& network, std::size_t* checked) {
  std::size_t mismatches = 0;
  *checked = 0;
  for (std::size_t i = 3; i < out.rows.size(); ++i) {
    if (out.at(i, "stream_sample") < 0 || out.at(i, "drives_enabled") == 0) continue;
    if (out.at(i, "underruns") != out.at(i - 3, "underruns")) continue;
    if (std::lround((out.at(i, "t_s") - out.at(i - 1, "t_s")) * 1e3) != 1) continue;  // a frame lost before
    const Vec3 p(out.at(i, "x_ref_m"), out.at(i, "y_ref_m"), out.at(i, "z_ref_m"));
    ++*checked;
    for (int j = 0; j < 3; ++j) {
      const double board = out.at(i, "alpha" + std::to_string(j + 1) + "_ref_deg");
      if (std::abs(board - golden_reference_deg(network, p, j)) > 1e-9) {
        if (mismatches < 5) std::cout << "mismatch at t = " << out.at(i, "t_s") << " joint " << j + 1 << "\n";
        ++mismatches;
        break;
      }
    }
  }
  return mismatches;
}

// ---------------------------------------------------------------------------------------------

TEST(HostRun, ExperimentOneFollowsTheNetworkReferencesAndThePlateTheCosimulation) {
  Bench bench("experiment1");
  const auto start = std::chrono::steady_clock::now();
  HostProcess host(bench.run_arguments(bench.link, 5.0), bench.dir + "/host");
  const int code = host.wait(600);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << host.out() << host.err() << "wall " << wall << " s\n";
  ASSERT_EQ(code, 0);
  ASSERT_EQ(bench.board->terminate(), 0);

  const Table out = read_table(bench.dir + "/out.csv");
  const Table truth = read_table(bench.truth);
  ASSERT_GT(out.rows.size(), 5000u);
  // Joints: encoder - the board's joint reference, over the path (tau >= 0, drives on).
  std::size_t n = 0;
  const Vec3 joint_rms = joint_tracking_rms_deg(out, &n);
  std::cout << "joint rms over the path (" << n << " frames): " << joint_rms.transpose() << " deg\n";
  for (int j = 0; j < 3; ++j) EXPECT_LT(joint_rms[j], 0.01) << "joint " << j + 1;

  // The board's references are the golden answers to the positions sent, frame for frame.
  const golden::QuantisedNetwork network = golden::quantise(nn::read_weights_file(kWeights).network);
  std::size_t checked = 0;
  EXPECT_EQ(reference_mismatches(out, network, &checked), 0u);
  EXPECT_GT(checked, 5000u);

  // Plate: the truth (board time, 1 ms) against the reference due at the same tick, path time
  // 0.4 s .. 5 s (the co-simulation's window starts at 0.4 s too).
  std::map<long, std::size_t> truth_at;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) truth_at[std::lround(truth.at(i, "t_s") * 1e3)] = i;
  // The recording with the stage's measurement merged (the truth's x/y/z at the same tick) is a
  // SPEC recording: `deltactl compare` takes it.
  std::ofstream merged(bench.dir + "/merged.csv");
  merged << "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m\n" << std::setprecision(17);
  double distance_sq = 0.0, max_distance = 0.0;
  std::size_t m = 0;
  for (std::size_t i = 0; i < out.rows.size(); ++i) {
    const auto found = truth_at.find(std::lround(out.at(i, "t_s") * 1e3));
    if (found == truth_at.end()) continue;
    const std::size_t r = found->second;
    const Vec3 measured(truth.at(r, "x_m"), truth.at(r, "y_m"), truth.at(r, "z_m"));
    if (out.at(i, "drives_enabled") == 1) {
      merged << out.at(i, "t_s") << ',' << out.at(i, "alpha1_deg") << ',' << out.at(i, "alpha2_deg") << ','
             << out.at(i, "alpha3_deg") << ',' << measured[0] << ',' << measured[1] << ',' << measured[2] << '\n';
    }
    if (out.at(i, "tau_s") < 0.4) continue;
    const Vec3 reference(out.at(i, "x_ref_m"), out.at(i, "y_ref_m"), out.at(i, "z_ref_m"));
    distance_sq += (measured - reference).squaredNorm();
    max_distance = std::max(max_distance, (measured - reference).norm());
    ++m;
  }
  const double plate_rms = std::sqrt(distance_sq / static_cast<double>(m));
  const double cosim_rms = cosim_plate_rms_m(kWeights, 5.0);
  std::cout << "plate error over path time 0.4..5 s (" << m << " ms): rms " << plate_rms * 1e6 << " um, max "
            << max_distance * 1e6 << " um (cosim " << cosim_rms * 1e6 << " um; bound " << 1.1 * cosim_rms * 1e6
            << ")\n";
  EXPECT_GT(m, 4000u);
  EXPECT_LT(plate_rms, 1.1 * cosim_rms);
  merged.close();
  const CommandResult compare = run_deltactl("compare --data " + bench.dir + "/merged.csv");
  EXPECT_EQ(compare.exit_code, 0) << compare.err;
  EXPECT_NE(compare.out.find("Forward kinematics"), std::string::npos) << compare.out;
  std::filesystem::remove_all(bench.dir);
}

// The deployed model (weights/paper_like_deployed.json, what the board ships) through the
// same pty against the model board in real time: the host drives it unchanged, the joints follow
// their (compensated) references as closely, and the plate is within 1.2 x the co-simulation's of
// the same run (the same host code in board time). Measured: 15.7 um against 14.5 um (here the host
// streams through a real pty in real time and the board was homed at its references).
TEST(HostRun, TheDeployedModelPlacesThePlateAsTheCosimulationDoes) {
  Bench bench("deployed", {"--fidelity", "model"}, true,
              std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json");
  HostProcess host(bench.run_arguments(bench.link, 5.0), bench.dir + "/host");
  const int code = host.wait(120);
  std::cout << host.out() << host.err();
  ASSERT_EQ(code, 0);
  ASSERT_EQ(bench.board->terminate(), 0);
  const Table out = read_table(bench.dir + "/out.csv");
  const Table truth = read_table(bench.truth);
  const PlateError plate = plate_error_on_path(out, truth, 0.4, 5.0);
  const std::size_t m = plate.samples;
  ASSERT_GT(m, 4000u);
  const Vec3 joint_rms = joint_tracking_rms_deg(out);
  const double plate_rms = plate.rms_m;
  std::cout << "deployed model: joint rms " << joint_rms.transpose() << " deg; plate error over path time 0.4..5 s "
            << plate_rms * 1e6 << " um RMS (" << m << " ms)\n";
  for (int j = 0; j < 3; ++j) EXPECT_LT(joint_rms[j], 0.01) << "joint " << j + 1;
  const double cosim_rms = cosim_plate_rms_m(bench.weights, 5.0);
  std::cout << "co-simulation of the same run: " << cosim_rms * 1e6 << " um RMS\n";
  EXPECT_LT(plate_rms, 1.2 * cosim_rms);
  // The summary ends with run-report's headline: the joints (the plate needs a measurement).
  EXPECT_NE(host.out().find("run-report: joint tracking (reference - encoder"), std::string::npos) << host.out();
  EXPECT_NE(host.out().find("run-report: plate: not measured"), std::string::npos) << host.out();
  std::filesystem::remove_all(bench.dir);
}

TEST(HostRun, StoppedHostLetsTheWatchdogDisableTheDrivesAndExitsFourWithoutReEnabling) {
  Bench bench("sigstop");
  HostProcess host(bench.run_arguments(bench.link, 3.0), bench.dir + "/host");
  std::this_thread::sleep_for(std::chrono::seconds(8));  // into the stream (about 0.3-1 s of board time)
  ASSERT_EQ(host.wait(0), -1) << host.err();
  ::kill(host.pid(), SIGSTOP);
  std::this_thread::sleep_for(std::chrono::seconds(5));  // >= 0.5 s of board time: past the watchdog
  ::kill(host.pid(), SIGCONT);
  const int code = host.wait(60);
  std::cout << host.out() << host.err();
  EXPECT_EQ(code, 4);
  EXPECT_NE(host.err().find("link lost"), std::string::npos);
  std::this_thread::sleep_for(std::chrono::seconds(2));  // the board runs on: nothing re-enables
  ASSERT_EQ(bench.board->terminate(), 0);

  const Table out = read_table(bench.dir + "/out.csv");
  const Table truth = read_table(bench.truth);
  ASSERT_FALSE(out.rows.empty());
  const double last_telemetry = out.at(out.rows.size() - 1, "t_s");
  const double watchdog_s = static_cast<double>(board::kWatchdogPeriods) / board::kControlRateHz;
  double off = -1.0;
  std::size_t enabled_after = 0;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    const double t = truth.at(i, "t_s");
    if (t < last_telemetry) continue;
    if (off < 0.0 && truth.at(i, "drives_enabled") == 0) off = t;
    if (off >= 0.0 && truth.at(i, "drives_enabled") != 0) ++enabled_after;
  }
  std::cout << "last telemetry the host read at " << last_telemetry << " s; drives off at " << off
            << " s: " << (off - last_telemetry) * 1e3 << " ms later (bound: the watchdog's " << watchdog_s * 1e3
            << " ms + 1 ms period + the last frame's transit)\n";
  ASSERT_GE(off, 0.0);
  EXPECT_GE(off - last_telemetry, watchdog_s);
  EXPECT_LE(off - last_telemetry, watchdog_s + 0.001 + 0.0015);
  EXPECT_EQ(enabled_after, 0u);
  EXPECT_GT(truth.at(truth.rows.size() - 1, "t_s") - off, 0.02);  // the truth goes on past it
  std::filesystem::remove_all(bench.dir);
}

// A host frozen for 100 ms mid-run (SIGSTOP) loses nothing: the board plays on from the lead the
// host keeps in its buffer (docs/board_link.md, "Streaming budget"), the host refills it when it
// runs again; exit 0, no underrun, no fault. The model board keeps to real time.
TEST(HostRun, HostStoppedForOneHundredMillisecondsLosesNothing) {
  Bench bench("stop100", {"--fidelity", "model"});
  std::vector<std::string> arguments = bench.run_arguments(bench.link, 3.0);
  arguments.resize(arguments.size() - 2);  // the default link bound (200 ms), not the bench's 1000 ms
  HostProcess host(arguments, bench.dir + "/host");
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));  // into the stream
  ASSERT_EQ(host.wait(0), -1) << host.err();
  ::kill(host.pid(), SIGSTOP);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ::kill(host.pid(), SIGCONT);
  const int code = host.wait(60);
  std::cout << host.out() << host.err();
  EXPECT_EQ(code, 0);
  EXPECT_NE(host.out().find("underruns while streaming 0"), std::string::npos) << host.out();
  ASSERT_EQ(bench.board->terminate(), 0);
  const Table out = read_table(bench.dir + "/out.csv");
  ASSERT_FALSE(out.rows.empty());
  EXPECT_EQ(out.at(out.rows.size() - 1, "fault_bits"), 0);
  std::filesystem::remove_all(bench.dir);
}

// A host killed mid-run (SIGKILL: nothing more is sent) cannot stop the drives itself: the board
// plays what it was sent, holds, and its watchdog turns the torque off within its bound (250 ms and
// one period) of the host's last frame. Board time is real time on the paced model board: the kill
// is placed in board time by the wall clock since the board's ready line (allowance 30 ms for that
// mapping); the truth gives the moment the drives went off.
TEST(HostRun, KilledHostsDrivesGoOffWithinTheWatchdogBound) {
  Bench bench("sigkill", {"--fidelity", "model"}, false);
  const auto ready = std::chrono::steady_clock::now();
  const CommandResult home = run_deltactl("host home --quiet --port " + bench.link + " --weights " + bench.weights);
  ASSERT_EQ(home.exit_code, 0) << home.err;
  HostProcess host(bench.run_arguments(bench.link, 3.0), bench.dir + "/host");
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));
  ASSERT_EQ(host.wait(0), -1) << host.err();
  const auto killed = std::chrono::steady_clock::now();
  ::kill(host.pid(), SIGKILL);
  host.wait(10);
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  ASSERT_EQ(bench.board->terminate(), 0);
  const double kill_s = std::chrono::duration<double>(killed - ready).count();
  const double bound_s = static_cast<double>(board::kWatchdogPeriods + 1) / board::kControlRateHz;
  const Table truth = read_table(bench.truth);
  double on = -1.0, off = -1.0;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    const double t = truth.at(i, "t_s");
    if (truth.at(i, "drives_enabled") != 0) {
      on = t;
      off = -1.0;
    } else if (on >= 0.0 && off < 0.0) {
      off = t;
    }
  }
  std::cout << "host killed at board time ~" << kill_s << " s; drives off at " << off << " s: " << (off - kill_s) * 1e3
            << " ms later (bound " << bound_s * 1e3 << " ms + 30 ms mapping)\n";
  ASSERT_GE(on, 0.0) << "the drives were never on";
  ASSERT_GE(off, 0.0) << "the drives stayed on";
  EXPECT_LE(off - kill_s, bound_s + 0.030);
  EXPECT_GE(off - kill_s, -0.030) << "off before the kill";
  std::filesystem::remove_all(bench.dir);
}

TEST(HostRun, SigintStopsAtRestThenDisablesAndExits130) {
  Bench bench("sigint", {"--fidelity", "model"});  // kept to real time: the signal lands mid-stream
  HostProcess host(bench.run_arguments(bench.link, 4.0), bench.dir + "/host");
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  ASSERT_EQ(host.wait(0), -1) << host.err();
  ::kill(host.pid(), SIGINT);
  const int code = host.wait(60);
  std::cout << host.out() << host.err();
  EXPECT_EQ(code, 128 + SIGINT);
  EXPECT_NE(host.err().find("controlled stop, drives off"), std::string::npos);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  ASSERT_EQ(bench.board->terminate(), 0);
  // The recording (the stream's telemetry) ends at rest short of the path's end: the references
  // still over its last 10 ms; then the truth shows the drives off.
  const Table out = read_table(bench.dir + "/out.csv");
  ASSERT_GT(out.rows.size(), 500u);
  // The recording ends with the final hold and disable: the stream's last row is the last one
  // with the drives on.
  std::size_t last = out.rows.size() - 1;
  while (last > 10 && out.at(last, "drives_enabled") == 0) --last;
  double change = 0.0, tau = 0.0;
  for (std::size_t i = 0; i <= last; ++i) tau = std::max(tau, out.at(i, "tau_s"));
  for (int j = 1; j <= 3; ++j) {
    const std::string column = "alpha" + std::to_string(j) + "_ref_deg";
    change = std::max(change, std::abs(out.at(last, column) - out.at(last - 10, column)));
  }
  std::cout << "stopped at path time " << tau << " s; reference change over the last 10 ms " << change << " deg\n";
  EXPECT_LT(tau, 4.0 - 0.1);
  EXPECT_LT(change, 1e-3);
  const Table truth = read_table(bench.truth);
  EXPECT_EQ(truth.at(truth.rows.size() - 1, "drives_enabled"), 0);
  std::filesystem::remove_all(bench.dir);
}

// Relays bytes between the host's port (a pty the test owns) and the virtual board's, corrupting
// each byte with probability `rate` (XOR with a random non-zero byte).
class CorruptingTap {
 public:
  CorruptingTap(const std::string& host_side, const std::string& board_side, double rate, unsigned seed)
      : host_(host_side), board_(board_side, static_cast<int>(board::kLinkBaud)), rate_(rate), random_(seed) {
    thread_ = std::thread([this] { relay(); });
  }
  ~CorruptingTap() {
    stop_ = true;
    thread_.join();
  }
  std::uint64_t corrupted(int direction) const { return corrupted_[direction].load(); }
  std::uint64_t bytes(int direction) const { return bytes_[direction].load(); }

 private:
  void relay() {
    std::uint8_t buffer[4096];
    std::uniform_real_distribution<double> draw(0.0, 1.0);
    std::uniform_int_distribution<int> flip(1, 255);
    while (!stop_) {
      pollfd p[2] = {{host_.fd(), POLLIN, 0}, {board_.fd(), POLLIN, 0}};
      ::poll(p, 2, 10);
      io::ByteStream* from[2] = {&host_, &board_};
      io::ByteStream* to[2] = {&board_, &host_};
      for (int d = 0; d < 2; ++d) {
        std::size_t n = 0;
        try {
          n = from[d]->read_some(buffer, sizeof buffer);
        } catch (const std::exception&) {
          continue;  // the host's side not open yet, or closed
        }
        for (std::size_t i = 0; i < n; ++i) {
          if (draw(random_) < rate_) {
            buffer[i] ^= static_cast<std::uint8_t>(flip(random_));
            ++corrupted_[d];
          }
        }
        bytes_[d] += n;
        try {
          if (n > 0) to[d]->write_all(buffer, n, 100);
        } catch (const std::exception&) {
        }
      }
    }
  }
  io::PseudoTerminal host_;
  io::SerialPort board_;
  double rate_;
  std::mt19937 random_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> corrupted_[2] = {}, bytes_[2] = {};
  std::thread thread_;
};

TEST(HostRun, OnePercentOfTheBytesCorruptedCompletesAndNoCorruptedReferenceReachesTheJoints) {
  Bench bench("corrupt");
  const unsigned seed = 1301;
  std::cout << "seed " << seed << "\n";
  const std::string tap_path = bench.dir + "/tap";
  int code = -1;
  std::string summary;
  {
    CorruptingTap tap(tap_path, bench.link, 0.01, seed);
    HostProcess host(bench.run_arguments(tap_path, 0.8), bench.dir + "/host");
    code = host.wait(600);
    summary = host.out() + host.err();
    std::cout << summary << "tap: host -> board " << tap.bytes(0) << " bytes, " << tap.corrupted(0)
              << " corrupted; board -> host " << tap.bytes(1) << " bytes, " << tap.corrupted(1) << " corrupted\n";
    EXPECT_GT(tap.corrupted(0), 0u);
    EXPECT_GT(tap.corrupted(1), 0u);
  }
  ASSERT_EQ(code, 0);
  ASSERT_EQ(bench.board->terminate(), 0);
  // Bad frames counted on both sides.
  EXPECT_EQ(summary.find("bad frames: board 0,"), std::string::npos) << summary;
  EXPECT_EQ(summary.find(", host 0 (crc"), std::string::npos) << summary;
  const Table out = read_table(bench.dir + "/out.csv");
  const golden::QuantisedNetwork network = golden::quantise(nn::read_weights_file(kWeights).network);
  std::size_t checked = 0;
  EXPECT_EQ(reference_mismatches(out, network, &checked), 0u);
  std::cout << checked << " telemetry frames: the board's joint references equal the golden answers to the "
            << "positions sent\n";
  EXPECT_GT(checked, 300u);  // 42 % of the 54-byte telemetry frames are lost at 1 % per byte
  std::filesystem::remove_all(bench.dir);
}

// The skip comes 1.2 s into board time, inside the run: its enable comes about 0.47 s in (board
// time, whatever the host's load), the path runs 3 s. At 0.7 s it could meet the enable itself
// (which refuses with the same cause, in other words).
TEST(HostRun, EncoderSkipExitsThreeNamingTheCause) {
  Bench bench("skip", {"--inject-encoder-skip-at", "1.2"});
  HostProcess host(bench.run_arguments(bench.link, 3.0), bench.dir + "/host");
  const int code = host.wait(600);
  const std::string err = host.err();
  std::cout << host.out() << err;
  EXPECT_EQ(code, 3);
  const std::size_t at = err.find("deltactl: error: ");
  ASSERT_NE(at, std::string::npos) << err;
  const std::string line = err.substr(at, err.find('\n', at) - at);
  EXPECT_NE(line.find("the board faulted: encoder skipped a state"), std::string::npos) << line;
  std::filesystem::remove_all(bench.dir);
}

TEST(HostRun, VirtualBoardKilledMidRunExitsFourWithinOneHundredMilliseconds) {
  Bench bench("kill");
  HostProcess host(bench.run_arguments(bench.link, 3.0), bench.dir + "/host");
  std::this_thread::sleep_for(std::chrono::seconds(6));
  ASSERT_EQ(host.wait(0), -1) << host.err();
  const auto killed = std::chrono::steady_clock::now();
  bench.board->kill_now();
  const int code = host.wait(10);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - killed).count();
  std::cout << host.out() << host.err() << "host exited " << ms << " ms after the board was killed\n";
  EXPECT_EQ(code, 4);
  EXPECT_LT(ms, 100.0);
  EXPECT_NE(host.err().find("link lost"), std::string::npos);
  std::filesystem::remove_all(bench.dir);
}

// Bad trajectories: exit 2, one line naming FILE:LINE and the reason, nothing sent to the port
// (a pty the test holds), no recording.
TEST(HostRun, BadTrajectoriesAreRefusedBeforeAnyByteIsSent) {
  const std::string dir = temp_dir("bad");
  io::PseudoTerminal port(dir + "/tty");
  struct Case {
    std::string name, rows, line, reason;
  };
  // At rest for 1 s, then line 4, then at rest again: at full rate of path time where line 4 begins.
  const std::string head = "t_s,x_m,y_m,z_m\n0,0,0,-0.075\n1,0,0,-0.075\n";
  const std::vector<Case> cases = {
      {"unreachable", head + "1.001,0,0,-0.2\n2,0,0,-0.2\n", ":4:", "unreachable"},
      {"untrained", head + "100,0.008,0,-0.075\n", ":4:", "trained range"},
      {"too_fast", head + "1.005,0.005,0,-0.075\n2,0.005,0,-0.075\n", ":4:", "velocity"},
      {"nan", head + "1.1,nan,0,-0.075\n", ":4:", "not finite"},
      {"backwards", head + "0.5,0,0,-0.075\n", ":4:", "time goes backwards"},
  };
  for (const Case& c : cases) {
    const std::string file = dir + "/" + c.name + ".csv";
    std::ofstream(file) << c.rows;
    const CommandResult result = run_deltactl("host run --port " + dir + "/tty --weights " + kWeights +
                                              " --trajectory " + file + " --record " + dir + "/out.csv");
    std::cout << c.name << ": " << result.err;
    EXPECT_EQ(result.exit_code, 2) << c.name;
    EXPECT_NE(result.err.find(file + c.line), std::string::npos) << c.name << ": " << result.err;
    EXPECT_NE(result.err.find(c.reason), std::string::npos) << c.name << ": " << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_FALSE(std::filesystem::exists(dir + "/out.csv")) << c.name;
    std::uint8_t byte = 0;
    EXPECT_EQ(port.read_some(&byte, 1), 0u) << c.name << ": a byte reached the port";
  }
  std::filesystem::remove_all(dir);
}

// host run --check: no port, no recording; the allowed box printed (limits prints the same box),
// OK for experiment 1; a file outside the box on two axes and too fast: every problem listed, the
// box problem naming both axes and the box in one line, exit 2. The refusal of the same file by a
// run names both axes too, before the port is opened.
TEST(HostRun, CheckPrintsTheBoxAndEveryProblemWithoutAPort) {
  const std::string dir = temp_dir("check");
  const nn::WeightsFile w = nn::read_weights_file(kWeights);
  const CommandResult limits = run_deltactl("limits --weights " + kWeights + " --json");
  ASSERT_EQ(limits.exit_code, 0) << limits.err;
  const auto box = nlohmann::json::parse(limits.out)["box_mm"];
  for (int a = 0; a < 3; ++a) {
    const std::string axis(1, "xyz"[a]);
    EXPECT_NEAR(box[axis][0].get<double>(), w.network.input_min[a] * 1e3, 1e-9) << axis;
    EXPECT_NEAR(box[axis][1].get<double>(), w.network.input_max[a] * 1e3, 1e-9) << axis;
  }
  const CommandResult ok = run_deltactl("host run --weights " + kWeights + " --trajectory experiment1 --check");
  std::cout << ok.out << ok.err;
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("allowed box"), std::string::npos) << ok.out;
  EXPECT_NE(ok.out.find("check: OK"), std::string::npos) << ok.out;

  // Out along x beyond the box's top, then down in z beyond its bottom, then 4 mm in 20 ms (too fast).
  const Vec3 top = w.network.input_max + Vec3(0.002, 0, 0), low = w.network.input_min - Vec3(0, 0, 0.002);
  std::ostringstream file;
  file << "t_s,x_m,y_m,z_m\n0,0,0," << 0.5 * (w.network.input_min.z() + w.network.input_max.z()) << "\n2," << top.x()
       << ",0," << 0.5 * (w.network.input_min.z() + w.network.input_max.z()) << "\n4,0,0," << low.z()
       << "\n4.02,0.004,0," << low.z() << "\n6,0.004,0," << low.z() << "\n";
  write_text(dir + "/outside.csv", file.str());
  const CommandResult bad =
      run_deltactl("host run --weights " + kWeights + " --trajectory " + dir + "/outside.csv --check");
  std::cout << bad.out << bad.err;
  EXPECT_EQ(bad.exit_code, 2);
  std::size_t problems = 0, box_lines = 0;
  std::istringstream lines(bad.out);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("problem: ", 0) != 0) continue;
    ++problems;
    if (line.find("trained range") == std::string::npos) continue;
    ++box_lines;
    EXPECT_NE(line.find("x reaches"), std::string::npos) << line;
    EXPECT_NE(line.find("z reaches"), std::string::npos) << line;
    EXPECT_NE(line.find("the box x"), std::string::npos) << line;
  }
  EXPECT_EQ(box_lines, 1u);
  EXPECT_GE(problems, 2u);  // and the velocity
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  const CommandResult run = run_deltactl("host run --port " + dir + "/no-such-tty --weights " + kWeights +
                                         " --trajectory " + dir + "/outside.csv --record " + dir + "/out.csv");
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("x reaches"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("z reaches"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out.csv"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace delta::test
