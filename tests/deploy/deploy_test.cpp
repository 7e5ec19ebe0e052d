// The lab PC's deployment: the configuration file (malformed and contradictory files are bad input
// naming file, line and reason), `deltactl config check`, `deltactl flash --dry-run`, identify.mem,
// the wake-latency grading, and `deltactl doctor` without a board.
#include <gtest/gtest.h>

#include <chrono>

#include <fstream>
#include <string>

#include "../support/run_command.hpp"
#include "delta/controller/realtime.hpp"
#include "delta/deploy/board_probe.hpp"
#include "delta/deploy/config.hpp"
#include "delta/deploy/doctor.hpp"
#include "delta/input_error.hpp"
#include "delta/temporary_directory.hpp"

namespace delta {
namespace {

using test::run_deltactl;
using test::write_text;

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";

std::string valid_text(const std::string& weights = kWeights) {
  return "# comment\n[board]\nport = /dev/delta-board\nbaud = 1000000\n\n[network]\nweights = " + weights +
         "\nbitstream =\n[limits]\nfollowing_error_deg = 1.5\nvelocity_deg_s = 200\n[service]\nsocket = "
         "/run/deltactl/deltactl.sock\n";
}

// The InputError of parsing `text` (fails the test if it parses).
InputError parse_error(const std::string& text) {
  try {
    deploy::parse_config(text, "/etc/deltactl/deltactl.conf");
  } catch (const InputError& error) {
    return error;
  }
  ADD_FAILURE() << "parsed:\n" << text;
  return InputError("", 0, "");
}

TEST(DeployConfig, ValidFileGivesEveryValue) {
  const deploy::DeployConfig config = deploy::parse_config(valid_text(), "/etc/deltactl/deltactl.conf");
  EXPECT_EQ(config.port, "/dev/delta-board");
  EXPECT_EQ(config.baud, 1000000);
  EXPECT_EQ(config.weights, kWeights);
  EXPECT_EQ(config.bitstream, "");
  EXPECT_DOUBLE_EQ(config.following_error_deg, 1.5);
  EXPECT_DOUBLE_EQ(config.velocity_deg_s, 200.0);
  EXPECT_EQ(config.socket, "/run/deltactl/deltactl.sock");
}

TEST(DeployConfig, ShippedExampleIsValidOnceItsWeightsExist) {
  std::ifstream in(std::string(DELTA_SOURCE_DIR) + "/host/deploy/conf/deltactl.conf");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string installed = "/usr/share/deltactl/weights/paper_like_deployed.json";
  ASSERT_NE(text.find(installed), std::string::npos);
  text.replace(text.find(installed), installed.size(), kWeights);
  const deploy::DeployConfig config = deploy::parse_config(text, "deltactl.conf");
  EXPECT_EQ(config.port, deploy::kDefaultPort);
  EXPECT_EQ(config.baud, 1000000);
}

struct BadCase {
  const char* what;
  std::string text;
  std::size_t line;
  const char* reason;
};

TEST(DeployConfig, MalformedAndContradictoryFilesNameLineAndReason) {
  const std::string header = "[network]\nweights = " + kWeights + "\n";
  const BadCase cases[] = {
      {"no '='", header + "[board]\nport /dev/ttyUSB1\n", 4, "expected 'key = value'"},
      {"unknown key", header + "[board]\nprot = /dev/ttyUSB1\n", 4, "unknown key 'prot' in [board]"},
      {"unknown section", header + "[boards]\n", 3, "unknown section 'boards'"},
      {"key before section", "port = /dev/ttyUSB1\n" + header, 1, "before any [section]"},
      {"duplicate key", header + "[board]\nport = /dev/a\nport = /dev/b\n", 5, "duplicate key port in [board]"},
      {"duplicate section", header + "[board]\n[network]\n", 4, "section [network] given twice"},
      {"non-numeric", header + "[limits]\nvelocity_deg_s = fast\n", 4, "not a number: 'fast'"},
      {"trailing junk", header + "[limits]\nvelocity_deg_s = 12x\n", 4, "not a number: '12x'"},
      {"out of range", header + "[limits]\nfollowing_error_deg = 90\n", 4, "out of range (0, 45]"},
      {"zero", header + "[limits]\nvelocity_deg_s = 0\n", 4, "out of range (0, 3600]"},
      {"baud not the board's", header + "[board]\nbaud = 115200\n", 4, "differs from the board's link rate 1000000"},
      {"baud fraction", header + "[board]\nbaud = 1000000.5\n", 4, "not a whole number"},
      {"relative port", header + "[board]\nport = ttyUSB1\n", 4, "not an absolute device path"},
      {"missing weights", "[network]\nweights = /nonexistent/W.json\n", 2, "no such file: /nonexistent/W.json"},
      {"missing bitstream", header + "bitstream = /nonexistent/top.bin\n", 3, "no such file: /nonexistent/top.bin"},
      {"bitstream is the weights", header + "bitstream = " + kWeights + "\n", 3, "network.bitstream is the weights"},
      {"no weights at all", "[board]\nport = /dev/delta-board\n", 0, "network.weights missing"},
      {"unclosed section", "[board\n", 1, "section header without ']'"},
  };
  for (const BadCase& bad : cases) {
    const InputError error = parse_error(bad.text);
    EXPECT_EQ(error.file(), "/etc/deltactl/deltactl.conf") << bad.what;
    EXPECT_EQ(error.line(), bad.line) << bad.what << ": " << error.what();
    EXPECT_NE(error.reason().find(bad.reason), std::string::npos) << bad.what << ": " << error.what();
  }
}

TEST(DeployConfig, RelativePathsAreTakenFromTheFilesFolder) {
  TemporaryDirectory dir("deploy_config");
  write_text(dir.path() + "/W.json", "{}");
  write_text(dir.path() + "/deltactl.conf", "[network]\nweights = W.json\n");
  const deploy::DeployConfig config = deploy::read_config(dir.path() + "/deltactl.conf");
  EXPECT_EQ(config.weights, dir.path() + "/W.json");
  EXPECT_EQ(config.port, deploy::kDefaultPort);  // defaults for what is not given
  EXPECT_DOUBLE_EQ(config.following_error_deg, 2.0);
}

TEST(DeployConfigCheck, BadFileExitsTwoWithOneLineNamingFileLineReasonAndNoOutput) {
  TemporaryDirectory dir("deploy_check");
  const std::string path = dir.path() + "/deltactl.conf";
  write_text(path, "[network]\nweights = " + kWeights + "\n[limits]\nvelocity_deg_s = -3\n");
  const auto result = run_deltactl("config check --config " + path);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.out, "");
  EXPECT_EQ(result.err, "deltactl: error: " + path + ":4: limits.velocity_deg_s: -3 out of range (0, 3600]\n");
  const auto missing = run_deltactl("config check --config " + dir.path() + "/none.conf");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("none.conf: cannot open configuration file"), std::string::npos);
}

TEST(DeployConfigCheck, ValidFilePrintsTheResolvedValues) {
  TemporaryDirectory dir("deploy_check_ok");
  const std::string path = dir.path() + "/deltactl.conf";
  write_text(path, valid_text());
  const auto result = run_deltactl("config check --config " + path);
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find(path + ": valid"), std::string::npos);
  EXPECT_NE(result.out.find("weights = " + kWeights), std::string::npos);
  EXPECT_NE(result.out.find("velocity_deg_s = 200"), std::string::npos);
}

// A bitstream folder as the fpga flow leaves it: icebreaker_top.bin and the identify.mem of
// `deltactl quantise` for `weights`.
std::string make_bitstream(const TemporaryDirectory& dir, const std::string& weights) {
  const auto quantise = run_deltactl("quantise --weights " + weights + " --out-dir " + dir.path());
  EXPECT_EQ(quantise.exit_code, 0) << quantise.err;
  write_text(dir.path() + "/icebreaker_top.bin", std::string(104090, '\xff'));
  return dir.path() + "/icebreaker_top.bin";
}

TEST(DeployFlash, DryRunPrintsTheProgrammerCommandAndTheVerification) {
  TemporaryDirectory dir("deploy_flash");
  const std::string bitstream = make_bitstream(dir, kWeights);
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const std::uint32_t crc = deploy::weights_file_crc(kWeights);
  const link::IdentifyPayload identify = deploy::read_identify_mem(dir.path() + "/identify.mem");
  EXPECT_EQ(identify.weights_crc, crc);

  const auto iceprog = run_deltactl("flash --dry-run --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(iceprog.exit_code, 0) << iceprog.err;
  EXPECT_NE(iceprog.out.find("\ncommand: iceprog " + bitstream + "\n"), std::string::npos) << iceprog.out;
  EXPECT_NE(iceprog.out.find("verify: wait up to 10 s for /dev/delta-board to come back, send an identify request "
                             "(1000000 baud, 1 s timeout), expect gateware build id " +
                             deploy::hex32(identify.build_id) + " and weights CRC-32 " + deploy::hex32(crc)),
            std::string::npos)
      << iceprog.out;
  EXPECT_NE(iceprog.out.find("dry run: nothing written"), std::string::npos);

  const auto loader =
      run_deltactl("flash --dry-run --programmer openFPGALoader --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(loader.exit_code, 0) << loader.err;
  EXPECT_NE(loader.out.find("\ncommand: openFPGALoader -b ice40_generic -f " + bitstream + "\n"), std::string::npos);
}

TEST(DeployFlash, RefusesABitstreamOfOtherWeightsUnlessForced) {
  TemporaryDirectory dir("deploy_flash_other");
  const std::string other = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_hybrid.json";
  if (!test::file_exists(other)) GTEST_SKIP() << "no second weights file";
  const auto probe = run_deltactl("quantise --weights " + other + " --out-dir " + dir.path());
  if (probe.exit_code != 0) GTEST_SKIP() << other << " cannot be quantised: " << probe.err;
  const std::string bitstream = make_bitstream(dir, other);
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const auto refused = run_deltactl("flash --dry-run --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_EQ(refused.out.find("command:"), std::string::npos);  // no programmer command printed
  EXPECT_NE(refused.err.find("identify.mem: the bitstream holds weights CRC-32"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("or --force"), std::string::npos);
  const auto forced = run_deltactl("flash --dry-run --force --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_NE(forced.out.find("warning: the bitstream was built from other weights"), std::string::npos);
}

TEST(DeployFlash, BitstreamWithoutIdentifyMemIsRefused) {
  TemporaryDirectory dir("deploy_flash_bare");
  write_text(dir.path() + "/top.bin", "x");
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const auto result = run_deltactl("flash --dry-run --config " + config + " --bitstream " + dir.path() + "/top.bin");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("no identify.mem beside the bitstream"), std::string::npos) << result.err;
}

TEST(DeployDoctor, LatencyIsJudgedAgainstTheStreamingBudget) {
  EXPECT_EQ(deploy::latency_band(715), "good (< 1 ms, the loop's period)");
  EXPECT_EQ(deploy::latency_verdict(715), deploy::Verdict::kOk);  // a stock kernel's worst: no failure
  EXPECT_EQ(deploy::latency_band(20'000), "acceptable (< 1/4 of the 200 ms streaming budget)");
  EXPECT_EQ(deploy::latency_verdict(49'999), deploy::Verdict::kOk);
  EXPECT_EQ(deploy::latency_band(60'000), "poor (< 1/2 of the 200 ms streaming budget)");
  EXPECT_EQ(deploy::latency_verdict(60'000), deploy::Verdict::kWarn);
  EXPECT_EQ(deploy::latency_band(100'000), "not acceptable (>= 1/2 of the 200 ms streaming budget)");
  EXPECT_EQ(deploy::latency_verdict(100'000), deploy::Verdict::kFail);
}

TEST(DeployDoctor, WakeLatencyProbeWakesAtOneKilohertz) {
  const auto start = std::chrono::steady_clock::now();
  const controller::WakeLatencyProbe probe = controller::measure_wake_latency(0.2, 0);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(probe.latency.count(), 200u);
  EXPECT_EQ(probe.realtime_note, "not asked");
  EXPECT_GE(probe.latency.max_us(), probe.latency.percentile_us(50) - 1.0);  // bins are 1 us wide
  EXPECT_GE(wall_s, 0.2);  // absolute deadlines: 200 periods of 1 ms at least
}

TEST(DeployDoctor, WithoutABoardEveryCheckHasAVerdictAndHardwareChecksSaySo) {
  TemporaryDirectory dir("deploy_doctor");
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const auto result =
      run_deltactl("doctor --json --latency-seconds 0.2 --config " + config + " --port " + dir.path() + "/no-board");
  EXPECT_EQ(result.exit_code, 1) << result.err;  // the device check fails
  for (const char* check :
       {"\"config\"", "\"board device\"", "\"latency timer\"", "\"ModemManager\"", "\"RT priority\"", "\"memlock\"",
        "\"kernel\"", "\"wake latency\"", "\"board identify\"", "\"service\""}) {
    EXPECT_NE(result.out.find(check), std::string::npos) << check << "\n" << result.out;
  }
  EXPECT_NE(result.out.find("needs the board: " + dir.path() + "/no-board not present"), std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("1 kHz"), std::string::npos);
  const auto bad = run_deltactl("doctor --config " + dir.path() + "/none.conf");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.out, "");
}

}  // namespace
}  // namespace delta
