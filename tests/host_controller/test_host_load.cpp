// `deltactl host load` against the virtual board (docs/board_link.md, "The model"): a board started
// with no model (--no-model, both fidelities) reports none in `host status` until a load, then the
// loaded model's CRC; a load with the drives on is refused (exit 3, nothing sent) and the model the
// board had stays; `host run` refuses a board with no model or another model (exit 5, naming
// `host load`), and runs once the model is loaded.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "delta/golden/board_network.hpp"
#include "delta/golden/export.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"
#include "host_bench.hpp"

namespace delta::test {
namespace {

const std::string kDeployed = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";

std::string crc_of(const std::string& weights) {
  return golden::hex_word(weights_crc(golden::read_board_weights(weights).network), 32);
}

// A virtual board started with no model (`--no-model`), not homed.
struct NoModelBench {
  std::string dir, link;
  std::unique_ptr<VirtualBoardProcess> board;
  NoModelBench(const std::string& name, std::vector<std::string> arguments) : dir(temp_dir(name)), link(dir + "/tty") {
    arguments.push_back("--no-model");
    board = std::make_unique<VirtualBoardProcess>(link, arguments);
    const std::string ready = board->ready_line(60'000);
    if (ready.find(link) == std::string::npos) throw std::runtime_error("virtual board not ready: " + ready);
  }
  std::vector<std::string> run_arguments(double duration_s) const {
    return host_run_arguments(link, kWeights, dir + "/out.csv", duration_s);
  }
};

nlohmann::json status_json(const std::string& link) {
  const CommandResult status = run_deltactl("host status --json --port " + link);
  EXPECT_EQ(status.exit_code, 0) << status.err;
  return nlohmann::json::parse(status.out, nullptr, false);
}

// A board with no model: status says none; host load loads it in one line; status says its CRC.
void load_onto_a_board_with_no_model(const std::string& fidelity) {
  NoModelBench bench("load_" + fidelity, {"--fidelity", fidelity});
  const nlohmann::json before = status_json(bench.link);
  ASSERT_TRUE(before.is_object());
  EXPECT_TRUE(before["weights_crc"].is_null()) << before.dump();
  EXPECT_EQ(before["model"], "none") << before.dump();
  const CommandResult text = run_deltactl("host status --port " + bench.link);
  EXPECT_NE(text.out.find("model: no model (deltactl host load --port " + bench.link), std::string::npos) << text.out;

  const CommandResult load = run_deltactl("host load --port " + bench.link + " --weights " + kDeployed);
  std::cout << load.out << load.err;
  ASSERT_EQ(load.exit_code, 0) << load.err;
  EXPECT_EQ(load.out.rfind("load: model " + crc_of(kDeployed) + " (" + kDeployed + ") on ", 0), 0u) << load.out;
  EXPECT_NE(load.out.find(", 185 frames in "), std::string::npos) << load.out;
  EXPECT_EQ(std::count(load.out.begin(), load.out.end(), '\n'), 1) << load.out;

  const nlohmann::json after = status_json(bench.link);
  EXPECT_EQ(after["weights_crc"], crc_of(kDeployed)) << after.dump();
  EXPECT_EQ(after["model"], "loaded") << after.dump();

  const CommandResult json = run_deltactl("host load --json --port " + bench.link + " --weights " + kWeights);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json j = nlohmann::json::parse(json.out, nullptr, false);
  EXPECT_EQ(j["weights_crc"], crc_of(kWeights)) << json.out;
  EXPECT_EQ(j["frames"], 185) << json.out;
  EXPECT_EQ(j["attempts"], 1) << json.out;
  EXPECT_LT(j["seconds"].get<double>(), 10.0) << json.out;
  EXPECT_EQ(status_json(bench.link)["weights_crc"], crc_of(kWeights));
}

TEST(HostLoad, ModelFidelityStatusSaysNoModelThenTheLoadedModelsCrc) { load_onto_a_board_with_no_model("model"); }
TEST(HostLoad, RtlFidelityStatusSaysNoModelThenTheLoadedModelsCrc) { load_onto_a_board_with_no_model("rtl"); }

TEST(HostLoad, ABadWeightsFileIsExitTwoAndNothingIsSent) {
  NoModelBench bench("load_bad", {"--fidelity", "model"});
  const std::string bad = bench.dir + "/bad.json";
  write_text(bad, "{\"version\": 2,\n  \"hidden\": [oops]\n}\n");
  const CommandResult load = run_deltactl("host load --port " + bench.link + " --weights " + bad);
  EXPECT_EQ(load.exit_code, 2) << load.err;
  EXPECT_NE(load.err.find(bad), std::string::npos) << load.err;
  EXPECT_EQ(std::count(load.err.begin(), load.err.end(), '\n'), 1) << load.err;
  EXPECT_EQ(load.out, "");
  EXPECT_EQ(status_json(bench.link)["model"], "none");
}

// Frames written to the board's port beside the host (root is not held off by TIOCEXCL).
class ForeignWriter {
 public:
  explicit ForeignWriter(const std::string& port) : fd_(::open(port.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC)) {}
  ~ForeignWriter() {
    stop_holding();
    if (fd_ >= 0) ::close(fd_);
  }
  bool open() const { return fd_ >= 0; }
  void command(link::Command command) {
    const std::vector<std::uint8_t> bytes = link::encode_frame(link::make_frame(sequence_++, command));
    if (::write(fd_, bytes.data(), bytes.size()) != static_cast<ssize_t>(bytes.size())) ADD_FAILURE() << "write";
  }
  // Enable, then a hold every 10 ms (it feeds the board's watchdog), as `host serve` does after `enable`.
  void enable_and_hold() {
    command(link::Command::kEnable);
    holding_ = true;
    thread_ = std::thread([this] {
      while (holding_) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        command(link::Command::kHold);
      }
    });
  }
  void stop_holding() {
    holding_ = false;
    if (thread_.joinable()) thread_.join();
  }

 private:
  int fd_;
  std::uint8_t sequence_ = 0x40;
  std::atomic<bool> holding_{false};
  std::thread thread_;
};

TEST(HostLoad, WithTheDrivesOnTheLoadIsRefusedAndTheModelStays) {
  Bench bench("load_drives_on", {"--fidelity", "model"}, false);  // the shipped plain network (kWeights)
  const CommandResult homed = run_deltactl("host home --by-hand --port " + bench.link);
  ASSERT_EQ(homed.exit_code, 0) << homed.err;
  ForeignWriter writer(bench.link);
  ASSERT_TRUE(writer.open());
  writer.enable_and_hold();
  bool on = false;
  for (int i = 0; i < 50 && !on; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    on = status_json(bench.link)["description"].get<std::string>().rfind("drives on", 0) == 0;
  }
  ASSERT_TRUE(on) << "the foreign enable did not turn the drives on";
  const CommandResult load = run_deltactl("host load --port " + bench.link + " --weights " + kDeployed);
  EXPECT_EQ(load.exit_code, 3) << load.err;
  EXPECT_NE(load.err.find("the drives are on: disable first"), std::string::npos) << load.err;
  EXPECT_NE(load.err.find("nothing sent"), std::string::npos) << load.err;
  writer.stop_holding();
  writer.command(link::Command::kDisable);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const nlohmann::json after = status_json(bench.link);
  EXPECT_EQ(after["model"], "loaded") << after.dump();
  EXPECT_EQ(after["weights_crc"], crc_of(kWeights)) << after.dump();  // the model it had
  EXPECT_EQ(after["rejected"], 0) << after.dump();                    // no model frame reached it
}

TEST(HostLoad, RunRefusesNoModelAndAnotherModelNamingHostLoadThenRunsAfterTheLoad) {
  NoModelBench bench("load_run", {"--fidelity", "model"});
  const std::string load_hint = "deltactl host load --port " + bench.link + " --weights " + kWeights;
  const CommandResult none = run_deltactl("host home --quiet --port " + bench.link + " --weights " + kWeights);
  EXPECT_EQ(none.exit_code, 5) << none.err;
  EXPECT_NE(none.err.find("the board has no model"), std::string::npos) << none.err;
  EXPECT_NE(none.err.find(load_hint), std::string::npos) << none.err;
  const CommandResult run_none =
      run_deltactl("host run --port " + bench.link + " --weights " + kWeights +
                   " --trajectory experiment1 --duration 1 --record " + bench.dir + "/a.csv");
  EXPECT_EQ(run_none.exit_code, 5) << run_none.err;
  EXPECT_NE(run_none.err.find(load_hint), std::string::npos) << run_none.err;

  ASSERT_EQ(run_deltactl("host load --port " + bench.link + " --weights " + kDeployed).exit_code, 0);
  const CommandResult other = run_deltactl("host run --port " + bench.link + " --weights " + kWeights +
                                           " --trajectory experiment1 --duration 1 --record " + bench.dir + "/b.csv");
  EXPECT_EQ(other.exit_code, 5) << other.err;
  EXPECT_NE(other.err.find("another model (CRC " + crc_of(kDeployed) + ")"), std::string::npos) << other.err;
  EXPECT_NE(other.err.find(load_hint), std::string::npos) << other.err;

  ASSERT_EQ(run_deltactl("host load --port " + bench.link + " --weights " + kWeights).exit_code, 0);
  const CommandResult home =
      run_deltactl("host home --quiet --port " + bench.link + " --weights " + kWeights + " --link-timeout-ms 2000");
  ASSERT_EQ(home.exit_code, 0) << home.err;
  HostProcess run(bench.run_arguments(1.0), bench.dir + "/run");
  EXPECT_EQ(run.wait(60), 0) << run.err();
}

TEST(HostLoad, ServeLoadsItsConfiguredModelOntoABoardWithNoneAndSaysSoAndCtlLoadsItAgain) {
  NoModelBench bench("load_serve", {"--fidelity", "model"});
  const std::string socket = bench.dir + "/ctl.sock";
  HostProcess serve({"host", "serve", "--port", bench.link, "--weights", kWeights, "--socket", socket,
                     "--record-folder", bench.dir + "/runs", "--link-timeout-ms", "1000"},
                    bench.dir + "/serve");
  nlohmann::json status = nlohmann::json::object();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (status.value("connection", "") != "connected" && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const CommandResult ctl = run_deltactl("host ctl --socket " + socket + " status --json");
    status = ctl.exit_code == 0 ? nlohmann::json::parse(ctl.out, nullptr, false) : nlohmann::json::object();
    if (!status.is_object()) status = nlohmann::json::object();
  }
  ASSERT_EQ(status.value("connection", ""), "connected") << status.dump() << serve.err();
  EXPECT_EQ(status["board"]["model"], "loaded") << status.dump();
  EXPECT_EQ(status["board"]["weights_crc"], crc_of(kWeights)) << status.dump();
  ASSERT_TRUE(status["model_load"].is_string()) << status.dump();
  EXPECT_EQ(
      status["model_load"].get<std::string>().rfind("loaded its model " + crc_of(kWeights) + " (185 frames in ", 0), 0u)
      << status.dump();
  EXPECT_NE(serve.err().find("loaded the model " + kWeights), std::string::npos) << serve.err();
  const CommandResult load = run_deltactl("host ctl --socket " + socket + " load --json");
  EXPECT_EQ(load.exit_code, 0) << load.err;
  const nlohmann::json loaded = nlohmann::json::parse(load.out, nullptr, false);
  EXPECT_EQ(loaded["weights_crc"], crc_of(kWeights)) << load.out;
  EXPECT_EQ(loaded["frames"], 185) << load.out;
  const CommandResult home = run_deltactl("host ctl --socket " + socket + " home");
  EXPECT_EQ(home.exit_code, 0) << home.err;
  ::kill(serve.pid(), SIGTERM);
  EXPECT_EQ(serve.wait(30), 0) << serve.err();
}

}  // namespace
}  // namespace delta::test
