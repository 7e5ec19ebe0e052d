// The lab PC's deployment: the configuration file (malformed and contradictory files are bad input
// naming file, line and reason), `deltactl config check`, `deltactl flash --dry-run`, identify.mem,
// the wake-latency grading, and `deltactl doctor` without a board; the iCE40 UP5K bitstream check;
// configurations the service cannot run (weights it cannot load, limits beyond the board's, files
// that are not configurations) refused by `config check`.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "../support/run_command.hpp"
#include "delta/controller/realtime.hpp"
#include "delta/deploy/bitstream.hpp"
#include "delta/deploy/board_probe.hpp"
#include "delta/deploy/config.hpp"
#include "delta/deploy/doctor.hpp"
#include "delta/input_error.hpp"
#include "delta/temporary_directory.hpp"
#include "support/tree_paths.hpp"

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
  const std::string bitstream = "/usr/share/deltactl/gateware/icebreaker_top.bin";  // deltactl-gateware's
  ASSERT_NE(text.find("bitstream = " + bitstream + "\n"), std::string::npos);
  text.replace(text.find(bitstream), bitstream.size(), "");
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
      {"out of range", header + "[limits]\nfollowing_error_deg = 90\n", 4, "out of range [0.01, 45]"},
      {"zero", header + "[limits]\nvelocity_deg_s = 0\n", 4, "out of range [1, 1279.96]"},
      {"above the board's slew", header + "[limits]\nvelocity_deg_s = 1300\n", 4, "the board's slew limit"},
      {"absurdly slow", header + "[limits]\nvelocity_deg_s = 1e-300\n", 4, "out of range [1, 1279.96]"},
      {"finer than a count", header + "[limits]\nfollowing_error_deg = 1e-300\n", 4, "one encoder count"},
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
  EXPECT_EQ(result.err, "deltactl: error: " + path +
                            ":4: limits.velocity_deg_s: -3 out of range [1, 1279.96] (the board's slew limit is the "
                            "top)\n");
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

TEST(DeployConfigCheck, WeightsTheServiceCannotLoadAreBadInput) {
  TemporaryDirectory dir("deploy_check_weights");
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(dir.path() + "/notweights.json", "{\"hello\": 1}\n");
  write_text(config, valid_text(dir.path() + "/notweights.json"));
  const auto invalid = run_deltactl("config check --config " + config);
  EXPECT_EQ(invalid.exit_code, 2);
  EXPECT_EQ(invalid.out, "");
  EXPECT_NE(invalid.err.find(dir.path() + "/notweights.json"), std::string::npos) << invalid.err;
  // A hybrid model: valid JSON, but not a network the board runs (serve refuses it the same way).
  const std::string hybrid = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_hybrid.json";
  if (test::file_exists(hybrid)) {
    write_text(config, valid_text(hybrid));
    const auto refused = run_deltactl("config check --config " + config);
    EXPECT_EQ(refused.exit_code, 2) << refused.out;
    EXPECT_NE(refused.err.find("hybrid"), std::string::npos) << refused.err;
  }
}

TEST(DeployConfigCheck, WeightsTheServiceUserCannotReadAreBadInput) {
  // The service runs as its own user: a weights file only root can read fails its start. Checked as
  // `nobody` when the test runs as root (setpriv), else as the test's user.
  TemporaryDirectory dir("deploy_check_unreadable");
  ::chmod(dir.path().c_str(), 0755);
  const std::string weights = dir.path() + "/W.json";
  write_text(weights, test::read_text(kWeights));
  ::chmod(weights.c_str(), 0600);
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text(weights));
  ::chmod(config.c_str(), 0644);
  std::string prefix;
  if (::geteuid() == 0) {
    if (std::system("command -v setpriv >/dev/null") != 0) GTEST_SKIP() << "root without setpriv";
    for (const std::string& path : {dir.path(), std::string(DELTACTL_PATH)}) {
      for (std::string folder = path.substr(0, path.rfind('/')); folder.size() > 1;
           folder = folder.substr(0, folder.rfind('/'))) {
        struct stat info {};
        if (::stat(folder.c_str(), &info) == 0 && !(info.st_mode & S_IXOTH)) {
          GTEST_SKIP() << folder << " is closed to nobody";
        }
      }
    }
    prefix = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
  } else {
    ::chmod(weights.c_str(), 0);
  }
  const auto result = run_deltactl("config check --config " + config, prefix);
  EXPECT_EQ(result.exit_code, 2) << result.out;
  EXPECT_NE(result.err.find(weights), std::string::npos) << result.err;
  EXPECT_EQ(result.out, "");
}

TEST(DeployConfigCheck, FilesThatAreNotConfigurationsAreRefusedWithoutReadingThem) {
  TemporaryDirectory dir("deploy_check_files");
  const auto zero = run_deltactl("config check --config /dev/zero", "ulimit -v 1000000; ");  // 1 GB: no 2 GB read
  EXPECT_EQ(zero.exit_code, 2);
  EXPECT_EQ(zero.err, "deltactl: error: /dev/zero: not a regular file (a device, FIFO or socket)\n");
  const auto folder = run_deltactl("config check --config " + dir.path());
  EXPECT_EQ(folder.exit_code, 2);
  EXPECT_EQ(folder.err, "deltactl: error: " + dir.path() + ": is a folder, not a configuration file\n");
  const std::string big = dir.path() + "/big.conf";
  write_text(big, valid_text() + std::string(deploy::kMaxConfigBytes, '#'));
  const auto large = run_deltactl("config check --config " + big);
  EXPECT_EQ(large.exit_code, 2);
  EXPECT_EQ(large.err, "deltactl: error: " + big + ": larger than 64 KiB: not a configuration\n");
}

TEST(DeployConfig, TheBoardsSlewLimitComesFromTheBoardPackage) {
  // 2^15 - 1 Q24.8 counts of 0.01 deg per 1 ms setpoint period (docs/board_link.md: 1.28 deg/ms).
  EXPECT_NEAR(deploy::kBoardSlewDegS, 32767.0 / 256.0 * 0.01 * 1000.0, 1e-9);
  const std::string header = "[network]\nweights = " + kWeights + "\n[limits]\n";
  EXPECT_DOUBLE_EQ(deploy::parse_config(header + "velocity_deg_s = 1279.9\n", "c").velocity_deg_s, 1279.9);
  EXPECT_DOUBLE_EQ(deploy::parse_config(header + "following_error_deg = 0.01\n", "c").following_error_deg, 0.01);
}

TEST(DeployHostCtl, NeedsOnlyTheSocketOfTheConfiguration) {
  // `host ctl` talks to the service; the weights are the service's business, not the client's.
  TemporaryDirectory dir("deploy_ctl");
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config,
             "[network]\nweights = " + dir.path() + "/absent.json\n[service]\nsocket = " + dir.path() + "/ctl.sock\n");
  const auto result = run_deltactl("host ctl --config " + config + " status");
  EXPECT_EQ(result.exit_code, 4) << result.err;  // no controller there: the socket was used
  EXPECT_NE(result.err.find(dir.path() + "/ctl.sock: cannot reach the controller"), std::string::npos) << result.err;
}

// A bitstream folder as the fpga flow leaves it: icebreaker_top.bin and the identify.mem of
// `deltactl quantise` for `weights`.
std::string make_bitstream(const TemporaryDirectory& dir, const std::string& weights) {
  const auto quantise = run_deltactl("quantise --weights " + weights + " --out-dir " + dir.path());
  EXPECT_EQ(quantise.exit_code, 0) << quantise.err;
  const std::vector<std::uint8_t> blank = deploy::blank_up5k_bitstream();
  write_text(dir.path() + "/icebreaker_top.bin", std::string(blank.begin(), blank.end()));
  return dir.path() + "/icebreaker_top.bin";
}

TEST(DeployFlash, DryRunPrintsTheProgrammerCommandAndTheVerification) {
  TemporaryDirectory dir("deploy_flash");
  const std::string bitstream = make_bitstream(dir, kWeights);
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const link::IdentifyPayload identify = deploy::read_identify_mem(dir.path() + "/identify.mem");
  EXPECT_EQ(identify.weights_crc, 0u);  // the gateware holds no model: the host loads it

  const auto iceprog = run_deltactl("flash --dry-run --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(iceprog.exit_code, 0) << iceprog.err;
  EXPECT_NE(iceprog.out.find("\ncommand: iceprog " + bitstream + "\n"), std::string::npos) << iceprog.out;
  EXPECT_NE(iceprog.out.find("verify: wait up to 10 s for /dev/delta-board to come back, send an identify request "
                             "(1000000 baud, 1 s timeout), expect gateware build id " +
                             deploy::hex32(identify.build_id) +
                             "\nthen: deltactl host load --port /dev/delta-board "
                             "--weights " +
                             kWeights),
            std::string::npos)
      << iceprog.out;
  EXPECT_EQ(iceprog.out.find("weights CRC"), std::string::npos) << iceprog.out;
  EXPECT_NE(iceprog.out.find("dry run: nothing written"), std::string::npos);

  const auto loader =
      run_deltactl("flash --dry-run --programmer openFPGALoader --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(loader.exit_code, 0) << loader.err;
  EXPECT_NE(loader.out.find("\ncommand: openFPGALoader -b ice40_generic -f " + bitstream + "\n"), std::string::npos);
}

TEST(DeployFlash, ABitstreamIsNotTiedToAModel) {
  // One gateware for every model: a bitstream folder quantised from other weights than the
  // configured ones flashes as it is, without a warning (the model is loaded after, by host load;
  // another gateware is refused: ABitstreamOfAnotherGatewareIsRefusedUnlessForced).
  TemporaryDirectory dir("deploy_flash_other");
  const std::string other = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
  ASSERT_NE(deploy::weights_file_crc(other), deploy::weights_file_crc(kWeights));
  const std::string bitstream = make_bitstream(dir, other);
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const auto taken = run_deltactl("flash --dry-run --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(taken.exit_code, 0) << taken.err;
  EXPECT_EQ(taken.out.find("warning"), std::string::npos) << taken.out;
  EXPECT_NE(taken.out.find("dry run: nothing written"), std::string::npos) << taken.out;
}

TEST(DeployFlash, BitstreamWithoutIdentifyMemIsRefused) {
  TemporaryDirectory dir("deploy_flash_bare");
  const std::vector<std::uint8_t> blank = deploy::blank_up5k_bitstream();
  write_text(dir.path() + "/top.bin", std::string(blank.begin(), blank.end()));
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const auto result = run_deltactl("flash --dry-run --config " + config + " --bitstream " + dir.path() + "/top.bin");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("no identify.mem beside the bitstream"), std::string::npos) << result.err;
}

TEST(DeployFlash, ARandomFileIsNotABitstream) {
  TemporaryDirectory dir("deploy_flash_random");
  make_bitstream(dir, kWeights);  // identify.mem of the configured weights beside it
  std::string random(4096, '\0');
  std::uint32_t state = 12345;  // seed 12345 (LCG)
  for (char& byte : random) byte = static_cast<char>((state = state * 1664525u + 1013904223u) >> 24);
  write_text(dir.path() + "/random.bin", random);
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const auto result = run_deltactl("flash --dry-run --config " + config + " --bitstream " + dir.path() + "/random.bin");
  EXPECT_EQ(result.exit_code, 2) << result.out;
  EXPECT_EQ(result.out.find("command:"), std::string::npos);
  EXPECT_NE(result.err.find("random.bin: not an iCE40 UP5K bitstream: no sync word 7EAA997E"), std::string::npos)
      << result.err;
}

TEST(DeployFlash, ABitstreamOfAnotherGatewareIsRefusedUnlessForced) {
  TemporaryDirectory dir("deploy_flash_gateware");
  const std::string bitstream = make_bitstream(dir, kWeights);
  // identify.mem's words 2 and 3 are the gateware build id (IdentifyBuildIdOffset 4): another one.
  const std::string mem_path = dir.path() + "/identify.mem";
  std::vector<std::string> lines;
  {
    std::ifstream in(mem_path);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  std::size_t word = 0;
  for (std::string& line : lines) {
    if (line.rfind("//", 0) == 0 || line.empty()) continue;
    if (word == 2) line = line == "dead" ? "beef" : "dead";
    ++word;
  }
  {
    std::ofstream out(mem_path);
    for (const std::string& line : lines) out << line << '\n';
  }
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text());
  const auto refused = run_deltactl("flash --dry-run --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(refused.exit_code, 2) << refused.out;
  EXPECT_EQ(refused.out.find("command:"), std::string::npos);
  EXPECT_NE(refused.err.find("identify.mem: the bitstream's gateware build id"), std::string::npos) << refused.err;
  const auto forced = run_deltactl("flash --dry-run --force --config " + config + " --bitstream " + bitstream);
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_NE(forced.out.find("warning: the bitstream's gateware build id differs"), std::string::npos) << forced.out;
}

TEST(DeployBitstream, TheBlankUp5kBitstreamPassesAndEveryDamageIsNamed) {
  const std::vector<std::uint8_t> blank = deploy::blank_up5k_bitstream();
  EXPECT_EQ(blank.size(), 104090u);  // icepack's size for a UP5K
  const deploy::BitstreamSummary summary = deploy::check_up5k_bitstream(blank, "blank.bin");
  EXPECT_EQ(summary.cram_bits, 692u * 1024u);
  EXPECT_EQ(summary.bram_bits, 2u * (160u + 80u) * 256u);
  auto reason = [](const std::vector<std::uint8_t>& bytes) {
    try {
      deploy::check_up5k_bitstream(bytes, "b.bin");
    } catch (const InputError& error) {
      return error.reason();
    }
    return std::string("accepted");
  };
  std::vector<std::uint8_t> flipped = blank;
  flipped[50000] ^= 0x10;  // one configuration bit
  EXPECT_NE(reason(flipped).find("CRC mismatch"), std::string::npos) << reason(flipped);
  const std::vector<std::uint8_t> cut(blank.begin(), blank.begin() + 60000);
  EXPECT_NE(reason(cut).find("past the end of the file"), std::string::npos) << reason(cut);
  std::vector<std::uint8_t> hx = blank;  // a bank width of another device (set bank width: 0x62, width - 1)
  hx[16] = 0x01;
  hx[17] = 0x4b;
  EXPECT_NE(reason(hx).find("another iCE40 device"), std::string::npos) << reason(hx);
  std::vector<std::uint8_t> tail = blank;
  tail.push_back(0x42);
  EXPECT_NE(reason(tail).find("data after the wake-up"), std::string::npos) << reason(tail);
  EXPECT_NE(reason({0x7e, 0xaa, 0x99}).find("no sync word"), std::string::npos);
}

TEST(DeployBitstream, TheBuildsBitstreamPassesWhenItWasBuilt) {
  // cmake --build build --target bitstream (yosys, nextpnr-ice40, icepack): not in the default build.
  const std::string built = std::string(DELTA_BINARY_DIR) + "/rtl/board/fpga/icebreaker_top.bin";
  if (!test::file_exists(built)) GTEST_SKIP() << "no " << built << " (cmake --build build --target bitstream)";
  const deploy::BitstreamSummary summary = deploy::check_up5k_bitstream_file(built);
  EXPECT_EQ(summary.cram_bits, 692u * 1024u);
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
}

TEST(DeployDoctor, ABadConfigurationIsAFailedCheckAndTheOthersStillRun) {
  TemporaryDirectory dir("deploy_doctor_bad");
  const std::string config = dir.path() + "/deltactl.conf";
  write_text(config, valid_text(dir.path() + "/missing.json"));
  const auto result =
      run_deltactl("doctor --latency-seconds 0.1 --config " + config + " --port " + dir.path() + "/no-board");
  EXPECT_EQ(result.exit_code, 1) << result.err;
  const std::size_t at = result.out.find("\nconfig ");
  ASSERT_NE(at, std::string::npos) << result.out;
  const std::string config_line = result.out.substr(at, result.out.find('\n', at + 1) - at);
  EXPECT_NE(config_line.find(" FAIL "), std::string::npos) << result.out;
  EXPECT_NE(config_line.find(config + ":7: network.weights: no such file"), std::string::npos) << result.out;
  for (const char* check : {"board device", "RT priority", "wake latency", "board identify", "service"}) {
    EXPECT_NE(result.out.find(std::string("\n") + check), std::string::npos) << check << "\n" << result.out;
  }
  const auto none = run_deltactl("doctor --latency-seconds 0.1 --config " + dir.path() + "/none.conf");
  EXPECT_EQ(none.exit_code, 1) << none.err;
  EXPECT_NE(none.out.find("none.conf: cannot open configuration file"), std::string::npos) << none.out;
}

TEST(DeployDoctor, ALatencyDurationThatIsNotAFiniteNumberIsRefused) {
  for (const char* value : {"nan", "inf", "-1", "0", "1e9"}) {
    const auto result = run_deltactl(std::string("doctor --latency-seconds ") + value);
    EXPECT_EQ(result.exit_code, 2) << value << ": " << result.out;
    EXPECT_EQ(result.out, "") << value;
    EXPECT_NE(result.err.find("--latency-seconds"), std::string::npos) << value << ": " << result.err;
  }
}

}  // namespace
}  // namespace delta
