// The board's facts have one home, rtl/board/delta_board_pkg.sv: the C++ header generated from it
// (delta/board_facts.hpp) must hold exactly the values the Verilated RTL elaborates, and the other
// places that cannot include the package (the .pcf's clock targets, the golden joint model's
// current limit, the PLL settings) must agree with it.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <string>

#include "Vboard_core.h"
#include "delta/board_facts.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "support/tree_paths.hpp"
#include "verilated.h"
#include "verilated_syms.h"

namespace delta::test {
namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The package's public parameters as the Verilated model elaborated them (32-bit signed).
std::map<std::string, long long> verilated_board_facts() {
  auto context = std::make_unique<VerilatedContext>();
  auto core = std::make_unique<Vboard_core>(context.get(), "board");
  std::map<std::string, long long> facts;
  for (const auto& [scope_name, scope] : *context->scopeNameMap()) {
    if (std::string(scope_name).find("delta_board_pkg") == std::string::npos || scope->varsp() == nullptr) continue;
    for (const auto& [name, var] : *scope->varsp()) {
      facts[name] = static_cast<std::int32_t>(*static_cast<const std::uint32_t*>(var.datap()));
    }
  }
  return facts;
}

TEST(BoardFacts, GeneratedHeaderEqualsTheVerilatedPackageFactForFact) {
  const std::map<std::string, long long> rtl = verilated_board_facts();
  ASSERT_FALSE(rtl.empty()) << "no public parameters of delta_board_pkg in the Verilated board core";
  std::size_t compared = 0;
  for (const board::BoardFact& fact : board::kBoardFacts) {
    const auto it = rtl.find(fact.name);
    ASSERT_NE(it, rtl.end()) << fact.name << " is in the C++ header but not in the Verilated package";
    EXPECT_EQ(it->second, fact.value) << fact.name;
    ++compared;
  }
  EXPECT_EQ(compared, rtl.size()) << "the Verilated package has facts the header lacks";
  std::cout << compared << " board facts compared\n";
}

TEST(BoardFacts, DerivedFactsAreConsistent) {
  using namespace board;
  EXPECT_EQ(kBoardClockHz * 2, kNetworkClockHz) << "the board clock is the PLL's GENCLK_HALF";
  EXPECT_EQ(kClocksPerPeriod, kBoardClockHz / kControlRateHz);
  EXPECT_EQ(kBoardClockHz % kControlRateHz, 0) << "the control period must be a whole number of cycles";
  EXPECT_EQ(kLinkClocksPerBit, std::llround(static_cast<double>(kBoardClockHz) / kLinkBaud));
  EXPECT_LT(std::abs(static_cast<double>(kBoardClockHz) / kLinkClocksPerBit / kLinkBaud - 1.0), 0.015)
      << "UART rate error above 1.5 %";
  EXPECT_GE(kLinkBaud, 1'000'000) << "the link must run at 1 Mbaud or more";
  EXPECT_EQ(3'000'000 % kLinkBaud, 0) << "the FT2232H makes 3 MHz / n exactly";
  EXPECT_EQ(kControlRateHz, kSetpointRateHz * kPeriodsPerSetpoint);
  EXPECT_EQ(kPwmPeriodCycles, 1LL << kPwmBits);
  EXPECT_EQ(kFaultCauseBits, 4);
  for (long long bit : {kFaultEncoderSkip, kFaultFollowing, kFaultWatchdog, kFaultTravel}) {
    EXPECT_LT(bit, kFaultCauseBits);
  }
}

// The golden joint controller's limit (from its design parameters) is the board's full scale.
TEST(BoardFacts, CurrentFullScaleIsTheControllersLimit) {
  const golden::JointFixedCoefficients c = golden::make_fixed_coefficients(golden::JointControllerParameters{});
  EXPECT_EQ(c.current_limit_code, board::kCurrentLimitCode);
  EXPECT_DOUBLE_EQ(golden::current_from_code(board::kCurrentLimitCode), board::kCurrentFullScaleMilliamp / 1000.0);
}

// icebreaker.pcf's timing targets and the PLL settings of icebreaker_top.sv make the package's clocks.
TEST(BoardFacts, PcfTargetsAndPllMakeThePackageClocks) {
  const std::string pcf = read_file(std::string(DELTA_SOURCE_DIR) + "/rtl/board/icebreaker.pcf");
  std::map<std::string, double> mhz;
  const std::regex frequency(R"(set_frequency\s+(\S+)\s+([0-9.]+))");
  for (auto it = std::sregex_iterator(pcf.begin(), pcf.end(), frequency); it != std::sregex_iterator(); ++it) {
    mhz[(*it)[1]] = std::stod((*it)[2]);
  }
  ASSERT_EQ(mhz.count("clk_network"), 1u);
  ASSERT_EQ(mhz.count("clk"), 1u);
  EXPECT_EQ(std::llround(mhz["clk_network"] * 1e6), board::kNetworkClockHz);
  EXPECT_EQ(std::llround(mhz["clk"] * 1e6), board::kBoardClockHz);

  const std::string top = read_file(std::string(DELTA_SOURCE_DIR) + "/rtl/board/icebreaker_top.sv");
  auto parameter = [&](const std::string& name) {
    std::smatch match;
    const std::regex pattern(name + R"(\s*=\s*\d+'d(\d+))");
    EXPECT_TRUE(std::regex_search(top, match, pattern)) << name << " not found in icebreaker_top.sv";
    return match.empty() ? 0LL : std::stoll(match[1]);
  };
  const long long divr = parameter("DivR"), divf = parameter("DivF"), divq = parameter("DivQ");
  EXPECT_EQ(12'000'000LL * (divf + 1) / (divr + 1) / (1LL << divq), board::kNetworkClockHz)
      << "12 MHz * (DIVF + 1) / (DIVR + 1) / 2^DIVQ";
}

// icebreaker.pcf against icebreaker_top.sv's ports: every port has exactly one pin (a bus, one per
// bit) and every pin a port; the safety connector's four inputs (PMOD2) are pulled up (a broken wire
// reads high: stop) and nothing else is; the drive enable leaves active low on pin 32.
TEST(BoardFacts, EveryTopPortHasOnePinAndTheSafetyInputsArePulledUp) {
  const std::string pcf = read_file(std::string(DELTA_SOURCE_DIR) + "/rtl/board/icebreaker.pcf");
  const std::string top = read_file(std::string(DELTA_SOURCE_DIR) + "/rtl/board/icebreaker_top.sv");
  std::map<std::string, int> pins;  // pin name (bus bits as name[i]) -> package pin
  std::map<std::string, bool> pulled_up;
  const std::regex set_io(R"(^set_io((?:\s+-\S+(?:\s+(?:yes|no))?)*)\s+(\S+)\s+(\d+)\s*$)");
  std::istringstream lines(pcf);
  std::string line;
  while (std::getline(lines, line)) {
    std::smatch match;
    if (line.rfind("set_io", 0) != 0) continue;
    ASSERT_TRUE(std::regex_match(line, match, set_io)) << "icebreaker.pcf: cannot read '" << line << "'";
    EXPECT_EQ(pins.count(match[2]), 0u) << match[2] << " twice";
    pins[match[2]] = std::stoi(match[3]);
    pulled_up[match[2]] = std::regex_search(std::string(match[1]), std::regex(R"(-pullup\s+yes)"));
  }
  std::map<std::string, int> expected_bits;  // port -> width, from the top's port list
  const std::regex port(R"(\n\s*(input|output)\s+logic\s*(?:\[(\d+):0\])?\s*(\w+)\s*(?:,|//|\)))");
  for (auto it = std::sregex_iterator(top.begin(), top.end(), port); it != std::sregex_iterator(); ++it) {
    expected_bits[(*it)[3]] = (*it)[2].matched ? std::stoi((*it)[2]) + 1 : 1;
  }
  ASSERT_GE(expected_bits.size(), 15u) << "icebreaker_top.sv's ports not found";
  std::size_t bits = 0;
  for (const auto& [name, width] : expected_bits) {
    for (int i = 0; i < width; ++i) {
      const std::string bit = width == 1 ? name : name + "[" + std::to_string(i) + "]";
      EXPECT_EQ(pins.count(bit), 1u) << bit << " has no pin in icebreaker.pcf";
      ++bits;
    }
  }
  EXPECT_EQ(pins.size(), bits) << "icebreaker.pcf names a pin that is no port of icebreaker_top.sv";
  // The design's pins (docs/bench.md).
  const std::map<std::string, int> safety{
      {"estop_open_i", 20}, {"drive_fault_i[0]", 27}, {"drive_fault_i[1]", 25}, {"drive_fault_i[2]", 19}};
  for (const auto& [name, pin] : pins) {
    const auto it = safety.find(name);
    EXPECT_EQ(pulled_up[name], it != safety.end()) << name;
    if (it != safety.end()) {
      EXPECT_EQ(pin, it->second) << name;
    }
  }
  EXPECT_EQ(pins["drive_enable_no"], 32);
  EXPECT_EQ(pins["led_encoder_error_o"], 26);
  EXPECT_EQ(pins["led_joint_fault_o"], 23);
  EXPECT_EQ(pins["led_drive_enable_o"], 21);
  EXPECT_EQ(pins["stage_sync_o"], 18);
  EXPECT_TRUE(std::regex_search(top, std::regex(R"(assign\s+drive_enable_no\s*=\s*!\s*drive_enable\s*;)")))
      << "the enable pin is active low";
}

}  // namespace
}  // namespace delta::test
