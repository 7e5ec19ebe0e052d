// `deltactl host serve` and its client `deltactl host ctl` against the virtual board (model
// fidelity, kept to real time) through its pty: a run streamed through the control socket with a
// feed hold and a resume (the plate at rest on the path while held, no underrun, the run completed
// to the path's end), a stop by request, SIGTERM while running (a controlled stop, the drives off,
// exit 0), and the board vanishing and coming back (reconnected, nothing enabled by itself).
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <mutex>
#include <vector>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "delta/geometry.hpp"
#include "host_bench.hpp"

namespace delta::test {
namespace {

constexpr int kFlagDrives = 1, kFlagHolding = 4;

// The drives-on intervals of a truth file, [from, to) in board seconds.
std::vector<std::pair<double, double>> drive_intervals(const Table& truth) {
  std::vector<std::pair<double, double>> out;
  bool on = false;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    const bool enabled = truth.at(i, "drives_enabled") != 0;
    if (enabled && !on) out.push_back({truth.at(i, "t_s"), 1e300});
    if (!enabled && on) out.back().second = truth.at(i, "t_s");
    on = enabled;
  }
  return out;
}

// systemd's notify socket, emulated: the time of every WATCHDOG=1 datagram.
class NotifySocket {
 public:
  NotifySocket() : path_(::testing::TempDir() + "notify_" + std::to_string(::getpid()) + ".sock") {
    ::unlink(path_.c_str());
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::copy(path_.begin(), path_.end(), address.sun_path);
    if (::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) throw std::runtime_error(path_);
    reader_ = std::thread([this] {
      char message[4096];
      while (!done_.load()) {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, 50) <= 0) continue;
        const ssize_t n = ::recv(fd_, message, sizeof message, 0);
        if (n > 0 && std::string(message, static_cast<std::size_t>(n)).find("WATCHDOG=1") != std::string::npos) {
          std::lock_guard<std::mutex> lock(mutex_);
          pings_.push_back(std::chrono::steady_clock::now());
        }
      }
    });
  }
  ~NotifySocket() {
    done_.store(true);
    reader_.join();
    ::close(fd_);
    ::unlink(path_.c_str());
  }
  const std::string& path() const { return path_; }
  // The longest time without a ping within [from, to], seconds.
  double longest_gap(std::chrono::steady_clock::time_point from, std::chrono::steady_clock::time_point to) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto last = from;
    double gap = 0.0;
    for (const auto& t : pings_) {
      if (t < from || t > to) continue;
      gap = std::max(gap, std::chrono::duration<double>(t - last).count());
      last = t;
    }
    return std::max(gap, std::chrono::duration<double>(to - last).count());
  }

 private:
  std::string path_;
  int fd_ = -1;
  std::atomic<bool> done_{false};
  std::mutex mutex_;
  std::vector<std::chrono::steady_clock::time_point> pings_;
  std::thread reader_;
};

std::size_t played(const nlohmann::json& status) {
  return status.contains("run") ? status["run"].value("played", std::size_t{0}) : 0;
}

TEST(HostServe, CtlRunWithAFeedHoldRestsOnThePathThenFinishesIt) {
  Server server("serve_hold");
  const CommandResult home = server.ctl("home");
  ASSERT_EQ(home.exit_code, 0) << home.err;
  EXPECT_EQ(server.status().value("state", ""), "homed");

  auto run = server.start_run(2.0, "out.csv");
  const std::string record = server.recorded("out.csv");
  ASSERT_TRUE(server.wait_for([](const nlohmann::json& s) { return played(s) > 1200; }, 120)) << server.serve->err();
  const CommandResult hold = server.ctl("hold");
  ASSERT_EQ(hold.exit_code, 0) << hold.err;
  ASSERT_TRUE(server.wait_for(
      [](const nlohmann::json& s) { return s.contains("run") && s["run"].value("feed", "") == "held"; }, 60));
  EXPECT_EQ(server.status().value("state", ""), "holding");
  const std::size_t held_at = played(server.status());
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));
  EXPECT_EQ(played(server.status()), held_at) << "samples played while held";
  const CommandResult resume = server.ctl("resume");
  ASSERT_EQ(resume.exit_code, 0) << resume.err;
  const int code = run->wait(300);
  std::cout << run->out() << run->err();
  ASSERT_EQ(code, 0);
  EXPECT_NE(run->out().find("1 feed holds"), std::string::npos) << run->out();
  EXPECT_EQ(server.status().value("state", ""), "homed");  // drives off after the run

  // The recording: a stretch of board time held (drives on, holding) with the references
  // unchanged; no underrun while streaming; the run reaches the path's end. (The recording also
  // holds the primed start's hold before the first sample plays, and the final hold and disable
  // after the path: the feed hold is the first held stretch after the first play.)
  const Table out = read_table(record);
  ASSERT_GT(out.rows.size(), 2000u);
  std::size_t first_play = 0;
  while (first_play < out.rows.size() && out.at(first_play, "stream_sample") < 0) ++first_play;
  ASSERT_LT(first_play, out.rows.size());
  std::size_t held_frames = 0;
  double reference_change = 0.0;
  std::size_t first_held = 0;
  for (std::size_t i = first_play; i < out.rows.size(); ++i) {
    const int flags = static_cast<int>(out.at(i, "flags"));
    if ((flags & kFlagDrives) && (flags & kFlagHolding)) {
      if (held_frames == 0) first_held = i;
      if (held_frames > 0 && i != first_held + held_frames) break;  // the final hold
      ++held_frames;
      for (int j = 1; j <= 3; ++j) {
        const std::string name = "alpha" + std::to_string(j) + "_ref_deg";
        reference_change = std::max(reference_change, std::abs(out.at(i, name) - out.at(first_held, name)));
      }
    }
  }
  std::cout << held_frames << " frames held; largest reference change while held " << reference_change << " deg\n";
  EXPECT_GT(held_frames, 1000u);
  EXPECT_EQ(reference_change, 0.0);
  double last_sample = 0.0;
  for (std::size_t i = 0; i < out.rows.size(); ++i) last_sample = std::max(last_sample, out.at(i, "stream_sample"));
  double last_tau = 0.0;
  for (std::size_t i = first_play; i < out.rows.size(); ++i) {
    if (out.at(i, "drives_enabled") == 0) break;
    if (out.at(i, "stream_sample") >= last_sample) break;  // the path played: the stop's hold and disable follow
    EXPECT_EQ(out.at(i, "underruns"), out.at(first_play, "underruns"))
        << "underrun at t = " << out.at(i, "t_s") << " (flags " << out.at(i, "flags") << ", stream sample "
        << out.at(i, "stream_sample") << ", fill " << out.at(i, "fill") << ", rows " << i << " of " << out.rows.size()
        << ")";
    last_tau = std::max(last_tau, out.at(i, "tau_s"));
    if (out.at(i, "underruns") != out.at(first_play, "underruns")) break;
  }
  EXPECT_NEAR(last_tau, 2.0, 1e-6);

  // The truth, complete once the virtual board has exited, over the frames well inside the hold:
  // the drives hold the motors still (the encoders, motor side, within one count); the arms may
  // only settle inside their backlash (sim/paper_like_effects.json: 0.15, 0.03, 0.03 deg of play).
  ::kill(server.serve->pid(), SIGTERM);
  EXPECT_EQ(server.serve->wait(30), 0) << server.serve->err();
  ASSERT_EQ(server.bench.board->terminate(), 0);
  const Table truth = read_table(server.bench.truth);
  const double t_hold = out.at(first_held, "t_s") + 0.05;
  const double t_end = out.at(first_held + held_frames - 1, "t_s") - 0.05;
  Vec3 encoder_lo = Vec3::Constant(1e9), encoder_hi = Vec3::Constant(-1e9);
  Vec3 arm_lo = Vec3::Constant(1e9), arm_hi = Vec3::Constant(-1e9);
  std::size_t rows = 0;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) {
    const double t = truth.at(i, "t_s");
    if (t < t_hold || t > t_end) continue;
    ++rows;
    EXPECT_EQ(truth.at(i, "drives_enabled"), 1) << "t = " << t;
    for (int j = 0; j < 3; ++j) {
      const double encoder = truth.at(i, "encoder" + std::to_string(j + 1) + "_deg");
      const double arm = truth.at(i, "true_alpha" + std::to_string(j + 1) + "_deg");
      encoder_lo[j] = std::min(encoder_lo[j], encoder);
      encoder_hi[j] = std::max(encoder_hi[j], encoder);
      arm_lo[j] = std::min(arm_lo[j], arm);
      arm_hi[j] = std::max(arm_hi[j], arm);
    }
  }
  const Vec3 encoder_spread = encoder_hi - encoder_lo, arm_spread = arm_hi - arm_lo;
  std::cout << rows << " truth rows while held: encoder spread " << encoder_spread.transpose() << " deg, arm spread "
            << arm_spread.transpose() << " deg\n";
  ASSERT_GT(rows, 500u);
  const Vec3 play(0.15, 0.03, 0.03);
  for (int j = 0; j < 3; ++j) {
    EXPECT_LE(encoder_spread[j], 0.01 + 1e-9) << "joint " << j + 1 << " moved while held";
    // arm = motor -+ half the play; the motor moves within the encoder's spread plus one count
    // (quantisation), the transmission ripple over that is below 1e-4 deg
    EXPECT_LE(arm_spread[j], play[j] + encoder_spread[j] + 0.01 + 1e-4)
        << "arm " << j + 1 << " moved more than its backlash while held";
  }
  std::filesystem::remove_all(server.bench.dir);
}

TEST(HostServe, StopRequestAndSigtermEndRunsAtRestWithTheDrivesOff) {
  Server server("serve_stop");
  ASSERT_EQ(server.ctl("home").exit_code, 0);
  // A stop by request: the run ends at rest, exit 0, outcome stopped.
  auto run = server.start_run(3.0, "stopped.csv");
  ASSERT_TRUE(server.wait_for([](const nlohmann::json& s) { return played(s) > 800; }, 120));
  ASSERT_EQ(server.ctl("stop").exit_code, 0);
  ASSERT_EQ(run->wait(120), 0) << run->err();
  EXPECT_NE(run->err().find("run stopped"), std::string::npos) << run->err();
  EXPECT_EQ(server.status().value("state", ""), "homed");

  // SIGTERM to the controller while it runs: a controlled stop, the drives off, exit 0.
  auto second = server.start_run(3.0, "terminated.csv");
  ASSERT_TRUE(server.wait_for([](const nlohmann::json& s) { return played(s) > 800; }, 120));
  ::kill(server.serve->pid(), SIGTERM);
  const int code = server.serve->wait(60);
  std::cout << server.serve->err();
  EXPECT_EQ(code, 0);
  EXPECT_EQ(second->wait(30), 128 + SIGTERM) << second->err();
  EXPECT_NE(second->out().find("recording: "), std::string::npos) << second->out();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  ASSERT_EQ(server.bench.board->terminate(), 0);

  // Both recordings (the streams' telemetry) end at rest; the truth ends with the drives off.
  for (const std::string name : {"stopped", "terminated"}) {
    const Table out = read_table(server.recorded(name + ".csv"));
    ASSERT_GT(out.rows.size(), 100u) << name;
    EXPECT_EQ(out.at(out.rows.size() - 1, "drives_enabled"), 0) << name << ": the final disable is recorded";
    std::size_t last = out.rows.size() - 1;  // the last frame with the drives on
    while (last > 5 && out.at(last, "drives_enabled") == 0) --last;
    double change = 0.0;
    for (int j = 1; j <= 3; ++j) {
      const std::string column = "alpha" + std::to_string(j) + "_ref_deg";
      change = std::max(change, std::abs(out.at(last, column) - out.at(last - 5, column)));
    }
    std::cout << name << ": reference change over the last 5 ms " << change << " deg\n";
    EXPECT_LT(change, 1e-3) << name;
  }
  const Table truth = read_table(server.bench.truth);
  EXPECT_EQ(truth.at(truth.rows.size() - 1, "drives_enabled"), 0);
  std::filesystem::remove_all(server.bench.dir);
}

TEST(HostServe, BoardVanishingAndComingBackIsReconnectedWithNothingEnabled) {
  Server server("serve_vanish");
  ASSERT_EQ(server.ctl("home").exit_code, 0);
  ASSERT_EQ(server.ctl("enable").exit_code, 0);  // deliberately on, then the board goes away
  server.bench.board->kill_now();
  ASSERT_TRUE(server.wait_for([](const nlohmann::json& s) { return s.value("connection", "") == "disconnected"; }, 30));
  const CommandResult refused = server.ctl("enable");
  EXPECT_EQ(refused.exit_code, 4) << refused.err;
  // The board back at the same path (as after flashing): identified again, not homed, drives off.
  server.bench.board = std::make_unique<VirtualBoardProcess>(
      server.bench.link, std::vector<std::string>{"--weights", kWeights, "--fidelity", "model", "--truth",
                                                  server.bench.dir + "/truth2.csv"});
  ASSERT_NE(server.bench.board->ready_line(60'000).find(server.bench.link), std::string::npos);
  ASSERT_TRUE(server.wait_for([](const nlohmann::json& s) { return s.value("connection", "") == "connected"; }, 30));
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const nlohmann::json status = server.status();
  std::cout << status.dump() << "\n";
  EXPECT_EQ(status.value("state", ""), "idle");  // a fresh board: not homed, nothing enabled
  ::kill(server.serve->pid(), SIGTERM);
  EXPECT_EQ(server.serve->wait(30), 0);
  ASSERT_EQ(server.bench.board->terminate(), 0);
  const Table truth = read_table(server.bench.dir + "/truth2.csv");
  ASSERT_GT(truth.rows.size(), 100u);
  for (std::size_t i = 0; i < truth.rows.size(); ++i) ASSERT_EQ(truth.at(i, "drives_enabled"), 0) << i;
  std::filesystem::remove_all(server.bench.dir);
}

TEST(HostServe, EstopDuringHomingAndRunLatchesForEveryClientUntilAClear) {
  // Powered up 25 deg below the home pose: homing takes seconds, long enough to e-stop it. Under an
  // emulated systemd watchdog of 2 s (as deltactl.service), fed through every homing.
  NotifySocket notify;
  ::setenv("NOTIFY_SOCKET", notify.path().c_str(), 1);
  ::setenv("WATCHDOG_USEC", "2000000", 1);
  Server server("serve_estop", {"--start-angles", "5,5,5"});
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  auto home = std::make_unique<HostProcess>(std::vector<std::string>{"host", "ctl", "--socket", server.socket, "home"},
                                            server.bench.dir + "/home.ctl");
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const CommandResult estop = server.ctl("estop --json");
  std::cout << "estop during homing: " << estop.out << estop.err;
  EXPECT_EQ(estop.exit_code, 0) << estop.err;
  EXPECT_EQ(home->wait(10), 3) << "a stopped homing fails: " << home->out() << home->err();
  EXPECT_NE((home->out() + home->err()).find("stopped"), std::string::npos) << home->out() << home->err();
  nlohmann::json status = server.status();
  EXPECT_EQ(status.value("state", ""), "e-stopped") << status.dump();
  EXPECT_TRUE(status["estop"].value("latched", false)) << status.dump();
  EXPECT_EQ(status["estop"].value("source", ""), "socket") << status.dump();
  ASSERT_TRUE(status["estop"]["board_time_s"].is_number()) << status.dump();
  EXPECT_EQ(status.value("homed_by", ""), "none") << "an e-stopped homing homes nothing: " << status.dump();
  EXPECT_TRUE(status.value("homing_unfinished", false)) << status.dump();
  // `host status` on the port the controller holds: the controller's status, the latch in it.
  const CommandResult held =
      run_deltactl("host status --port " + server.bench.link + " --socket " + server.socket + " --json");
  EXPECT_EQ(held.exit_code, 0) << held.err;
  const nlohmann::json via = nlohmann::json::parse(held.out, nullptr, false);
  EXPECT_TRUE(via.is_object() && via.value("state", "") == "e-stopped") << held.out << held.err;
  const double estopped_at = status["estop"]["board_time_s"].get<double>();

  // Whatever any client asks now, nothing moves: home, enable and run refused, exit 3, naming the e-stop.
  for (const std::string asked : {"home", "enable", "run --trajectory experiment1 --duration 1"}) {
    const CommandResult refused = server.ctl(asked);
    EXPECT_EQ(refused.exit_code, 3) << asked << ": " << refused.out << refused.err;
    EXPECT_NE((refused.out + refused.err).find("e-stopped"), std::string::npos) << asked << ": " << refused.err;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(server.status().value("state", ""), "e-stopped") << "the latch outlives the refused requests";

  // An explicit clear re-arms: homing, then a run, then SIGUSR1 (the signal's e-stop) ends the run and latches again.
  const CommandResult clear = server.ctl("clear-fault");
  EXPECT_EQ(clear.exit_code, 0) << clear.err;
  EXPECT_FALSE(server.status()["estop"].value("latched", true));
  // The clear keeps the e-stopped homing's counts provisional (the board homing again, drives off):
  // not homed, not "hand".
  const nlohmann::json after_clear = server.status();
  EXPECT_EQ(after_clear.value("homed_by", ""), "none") << after_clear.dump();
  EXPECT_TRUE(after_clear.value("homing_unfinished", false)) << after_clear.dump();
  const double cleared_at = server.status().value("board_time_s", 0.0);
  const auto homing_from = std::chrono::steady_clock::now();
  ASSERT_EQ(server.ctl("home").exit_code, 0);
  const auto homing_to = std::chrono::steady_clock::now();
  const double gap = notify.longest_gap(homing_from, homing_to);
  std::cout << "homing took " << std::chrono::duration<double>(homing_to - homing_from).count()
            << " s; longest time without WATCHDOG=1: " << gap << " s\n";
  EXPECT_LT(gap, 1.5) << "systemd (WatchdogSec=2s) would kill the service mid-homing";
  auto run = server.start_run(4.0, "signalled.csv");
  ASSERT_TRUE(server.wait_for([](const nlohmann::json& s) { return played(s) > 500; }, 120));
  ::kill(server.serve->pid(), SIGUSR1);
  EXPECT_EQ(run->wait(30), 3) << run->out() << run->err();
  EXPECT_NE((run->out() + run->err()).find("e-stop"), std::string::npos) << run->out() << run->err();
  status = server.status();
  EXPECT_EQ(status.value("state", ""), "e-stopped") << status.dump();
  EXPECT_EQ(status["estop"].value("source", ""), "signal") << status.dump();
  const double signalled_at = status["estop"]["board_time_s"].get<double>();
  EXPECT_EQ(server.ctl("run --trajectory experiment1 --duration 1").exit_code, 3);
  // The latch outlives the controller: a restarted one (systemd's Restart=) is e-stopped too.
  ::kill(server.serve->pid(), SIGTERM);
  EXPECT_EQ(server.serve->wait(30), 0);
  server.serve = std::make_unique<HostProcess>(
      std::vector<std::string>{"host", "serve", "--port", server.bench.link, "--weights", kWeights, "--socket",
                               server.socket, "--record-folder", server.bench.dir + "/runs"},
      server.bench.dir + "/serve2");
  ASSERT_TRUE(server.wait_for([](const nlohmann::json& s) { return s.value("connection", "") == "connected"; }, 60));
  status = server.status();
  EXPECT_EQ(status.value("state", ""), "e-stopped") << status.dump();
  EXPECT_NE(status["estop"].value("source", "").find("signal"), std::string::npos) << status.dump();
  EXPECT_EQ(server.ctl("home").exit_code, 3);
  ::kill(server.serve->pid(), SIGTERM);
  EXPECT_EQ(server.serve->wait(30), 0);
  ASSERT_EQ(server.bench.board->terminate(), 0);

  // The truth: the drives off within 100 ms of board time of each e-stop, and never on from
  // an e-stop to the clear, nor after the second e-stop.
  const auto intervals = drive_intervals(read_table(server.bench.truth));
  for (const auto& [from, to] : intervals) std::cout << "drives on " << from << " .. " << to << " s\n";
  for (const auto& [from, to] : intervals) {
    if (from <= estopped_at) {
      EXPECT_LT(to, estopped_at + 0.1) << "homing went on after the e-stop";
    } else {
      EXPECT_GT(from, cleared_at) << "the drives came on while latched";
    }
    if (from <= signalled_at && to > signalled_at) {
      EXPECT_LT(to, signalled_at + 0.1) << "the run went on";
    }
    EXPECT_FALSE(from > signalled_at) << "the drives came on after the second e-stop";
  }
  std::filesystem::remove_all(server.bench.dir);
}

}  // namespace
}  // namespace delta::test
