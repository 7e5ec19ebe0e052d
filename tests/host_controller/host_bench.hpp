// What the host controller's tests share: a temporary folder, a CSV read as columns, deltactl run
// as a child with a wall-clock bound, and a virtual board homed through `deltactl host home`.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../support/run_command.hpp"
#include "../support/virtual_board_process.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {

inline const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";

inline std::string temp_dir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "host_" + name + "_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A CSV with a header (comment lines skipped) as columns of numbers.
struct Table {
  std::map<std::string, std::size_t> column;
  std::vector<std::vector<double>> rows;
  double at(std::size_t row, const std::string& name) const { return rows[row][column.at(name)]; }
};
inline Table read_table(const std::string& path) {
  Table table;
  std::istringstream lines(read_text(path));
  std::string line;
  bool header = true;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string field;
    std::vector<double> row;
    for (std::size_t k = 0; std::getline(fields, field, ','); ++k) {
      if (header) {
        table.column[field] = k;
      } else {
        row.push_back(std::strtod(field.c_str(), nullptr));
      }
    }
    if (!header) table.rows.push_back(row);
    header = false;
  }
  return table;
}

// deltactl with stdout and stderr to files; waits with a wall-clock bound.
class HostProcess {
 public:
  HostProcess(const std::vector<std::string>& arguments, const std::string& stem) : stem_(stem) {
    std::vector<std::string> words = {DELTACTL_PATH};
    words.insert(words.end(), arguments.begin(), arguments.end());
    pid_ = ::fork();
    if (pid_ == 0) {
      const int out = ::open((stem + ".out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      const int err = ::open((stem + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(out, 1);
      ::dup2(err, 2);
      std::vector<char*> argv;
      for (std::string& word : words) argv.push_back(word.data());
      argv.push_back(nullptr);
      ::execv(DELTACTL_PATH, argv.data());
      ::_exit(127);
    }
  }
  ~HostProcess() {
    if (!exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  pid_t pid() const { return pid_; }
  // The exit code (128 + N for signal N; -1: still running after timeout_s).
  int wait(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      ::usleep(1000);
    }
    return -1;
  }
  std::string out() const { return read_text(stem_ + ".out"); }
  std::string err() const { return read_text(stem_ + ".err"); }

 private:
  std::string stem_;
  pid_t pid_ = -1;
  bool exited_ = false;
};

// The plate's error on the path: the truth (board time, 1 ms; as the stage sees it) against the
// reference due at the same tick in a `host run` recording, over path time from_tau_s <= tau <=
// to_tau_s with the drives on.
struct PlateError {
  double rms_m = 0.0, max_m = 0.0;
  std::size_t samples = 0;
};
inline PlateError plate_error_on_path(const Table& out, const Table& truth, double from_tau_s, double to_tau_s = 1e9) {
  std::map<long, std::size_t> truth_at;
  for (std::size_t i = 0; i < truth.rows.size(); ++i) truth_at[std::lround(truth.at(i, "t_s") * 1e3)] = i;
  PlateError e;
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < out.rows.size(); ++i) {
    const double tau = out.at(i, "tau_s");
    if (tau < from_tau_s || tau > to_tau_s || out.at(i, "drives_enabled") == 0) continue;
    const auto found = truth_at.find(std::lround(out.at(i, "t_s") * 1e3));
    if (found == truth_at.end()) continue;
    const std::size_t r = found->second;
    const double dx = truth.at(r, "x_m") - out.at(i, "x_ref_m"), dy = truth.at(r, "y_m") - out.at(i, "y_ref_m"),
                 dz = truth.at(r, "z_m") - out.at(i, "z_ref_m");
    const double d_sq = dx * dx + dy * dy + dz * dz;
    sum_sq += d_sq;
    e.max_m = std::max(e.max_m, std::sqrt(d_sq));
    ++e.samples;
  }
  if (e.samples > 0) e.rms_m = std::sqrt(sum_sq / static_cast<double>(e.samples));
  return e;
}

// `deltactl host run` of experiment 1 on PORT with WEIGHTS for DURATION_S, recorded to RECORD.
inline std::vector<std::string> host_run_arguments(const std::string& port, const std::string& weights,
                                                   const std::string& record, double duration_s) {
  return {"host",
          "run",
          "--port",
          port,
          "--weights",
          weights,
          "--trajectory",
          "experiment1",
          "--duration",
          std::to_string(duration_s),
          "--record",
          record,
          "--link-timeout-ms",
          "1000"};
}

// A virtual board, homed at its references through `deltactl host home` unless told not to.
struct Bench {
  std::string dir, link, truth, weights;
  std::unique_ptr<VirtualBoardProcess> board;
  // `weights`: what both the virtual board and the host run (the plain shipped network unless told).
  Bench(const std::string& name, std::vector<std::string> extra = {}, bool home_it = true,
        std::string weights_path = kWeights)
      : dir(temp_dir(name)), weights(std::move(weights_path)) {
    link = dir + "/tty";
    truth = dir + "/truth.csv";
    std::vector<std::string> arguments = {"--weights", weights, "--truth", truth};
    arguments.insert(arguments.end(), extra.begin(), extra.end());
    board = std::make_unique<VirtualBoardProcess>(link, arguments);
    std::string ready = board->ready_line(60'000);
    // With --stage, the stage's line comes first.
    if (ready.rfind("virtual-board: stage", 0) == 0) ready = board->ready_line(60'000);
    if (ready.find(link) == std::string::npos) throw std::runtime_error("virtual board not ready: " + ready);
    if (!home_it) return;
    const CommandResult home =
        run_deltactl("host home --port " + link + " --weights " + weights + " --link-timeout-ms 2000 --quiet");
    if (home.exit_code != 0) throw std::runtime_error("host home: " + home.err);
  }
  std::vector<std::string> run_arguments(const std::string& port, double duration_s) const {
    return host_run_arguments(port, weights, dir + "/out.csv", duration_s);
  }
};

inline std::vector<std::string> with_model_fidelity(std::vector<std::string> extra) {
  extra.insert(extra.begin(), {"--fidelity", "model"});
  return extra;
}

// `deltactl host serve` on a model-fidelity virtual board (not homed), its control socket, and
// `host ctl` against it.
struct Server {
  Bench bench;
  std::string socket;
  std::unique_ptr<HostProcess> serve;
  explicit Server(const std::string& name, std::vector<std::string> board_extra = {})
      : bench(name, with_model_fidelity(std::move(board_extra)), false) {
    socket = bench.dir + "/ctl.sock";
    serve = std::make_unique<HostProcess>(
        std::vector<std::string>{"host", "serve", "--port", bench.link, "--weights", kWeights, "--socket", socket,
                                 "--record-folder", bench.dir + "/runs", "--link-timeout-ms", "1000"},
        bench.dir + "/serve");
    // Connected: the board identified with the right gateware and weights.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (status().value("connection", "") != "connected") {
      if (std::chrono::steady_clock::now() > deadline)
        throw std::runtime_error("serve never connected: " + serve->err());
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  CommandResult ctl(const std::string& arguments) const {
    return run_deltactl("host ctl --socket " + socket + " " + arguments);
  }
  nlohmann::json status() const {
    const CommandResult result = ctl("status --json");
    if (result.exit_code != 0) return nlohmann::json::object();
    return nlohmann::json::parse(result.out);
  }
  // Polls status until `done` or timeout; false on timeout.
  template <typename Done>
  bool wait_for(Done&& done, double timeout_s) const {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      if (done(status())) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
  // `record`: a name in the controller's recordings folder (recorded(record) is its path).
  std::unique_ptr<HostProcess> start_run(double duration_s, const std::string& record) const {
    return std::make_unique<HostProcess>(
        std::vector<std::string>{"host", "ctl", "--socket", socket, "run", "--trajectory", "experiment1", "--duration",
                                 std::to_string(duration_s), "--record", record},
        bench.dir + "/" + record + ".ctl");
  }
  std::string recorded(const std::string& record) const { return bench.dir + "/runs/" + record; }
};

}  // namespace delta::test
