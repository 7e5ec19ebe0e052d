// The board core's safety inputs, e-stop command and bench jog (docs/bench.md) through its pins, as
// built (2325 clocks per control period): an input held at the stop level latches its cause and the
// drives are off within BoardInputFilterPeriods + 1 periods; a shorter glitch does not latch; a
// clear-fault is refused while an input still samples at stop, accepted after, and never
// re-enables; CommandEstop latches in every state until a clear; the telemetry bits (fault byte bit
// 7, bits 12-15 of the word at 44 beside the 12-bit refused counter); the jog's current, sign,
// length and ends, its refusals and the setpoints refused while it runs.
#include <gtest/gtest.h>

#include <cstdint>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "Vboard_core.h"
#include "Vboard_core___024root.h"
#include "board_link_bench.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/nn/weights_file.hpp"
#include "rtl_fixture.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

using Bench = LinkBench<Vboard_core>;
using link::Command;
using link::Frame;

constexpr std::int64_t kPeriod = kBoardClocksPerPeriod;
constexpr int kFilter = static_cast<int>(board::kBoardInputFilterPeriods);
constexpr int kCounterMax = (1 << board::kStatusCounterBits) - 1;

golden::QuantisedNetwork shipped_network() {
  return golden::quantise(nn::read_weights_file(std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json").network);
}
std::string export_directory(const golden::QuantisedNetwork& q, const std::string& name) {
  const std::string directory = fresh_directory(name);
  golden::write_export(q, directory);
  return directory;
}

// The raw telemetry fields the board's causes and the jog use.
struct Raw {
  std::vector<std::uint8_t> bytes;
  int fault_byte() const { return bytes.at(board::kTelemetryFaultOffset); }
  int flags() const { return bytes.at(board::kTelemetryFlagsOffset); }
  int word44() const {
    return bytes.at(board::kTelemetryBoardFaultOffset) | bytes.at(board::kTelemetryBoardFaultOffset + 1) << 8;
  }
  int board_causes() const { return word44() >> board::kBoardFaultShift; }
  int refused() const { return word44() & kCounterMax; }
  bool estop() const { return (fault_byte() >> board::kTelemetryEstopBit & 1) != 0; }
  bool fault() const { return (flags() >> board::kFlagFault & 1) != 0; }
  bool drives() const { return (flags() >> board::kFlagDriveEnable & 1) != 0; }
  bool jogging() const { return (bytes.at(board::kTelemetryHomeOffset) >> board::kTelemetryJogBit & 1) != 0; }
  int fill() const { return bytes.at(board::kTelemetryFillOffset) | bytes.at(board::kTelemetryFillOffset + 1) << 8; }
  std::int16_t current(int j) const {
    const int at = static_cast<int>(board::kTelemetryCurrentsOffset) + 2 * j;
    return static_cast<std::int16_t>(bytes.at(at) | bytes.at(at + 1) << 8);
  }
};

Frame command_byte(Bench& bench, int byte) {
  Frame frame = bench.command(Command::kHold);
  frame.payload[0] = static_cast<std::uint8_t>(byte);
  return frame;
}
Raw exchange(Bench& bench, const Frame& frame) {
  bench.exchange(frame);
  return Raw{bench.telemetry_payloads().back()};
}
Raw exchange(Bench& bench, Command command) { return exchange(bench, bench.command(command)); }
Raw next(Bench& bench) {
  bench.next_telemetry();
  return Raw{bench.telemetry_payloads().back()};
}
int jog_byte(int joint, bool negative) {
  return static_cast<int>(board::kCommandJogBase) + 2 * joint + (negative ? 1 : 0);
}

// Input i (BoardFault* bit: 0 the e-stop chain, 1 + j drive j) to level.
void set_input(Bench& bench, int input, bool stop) {
  Vboard_core& core = bench.core();
  if (input == board::kBoardFaultEstopInput) {
    core.estop_open_i = stop ? 1 : 0;
  } else {
    const int bit = 1 << (input - board::kBoardFaultDrive);
    core.drive_fault_i = stop ? (core.drive_fault_i | bit) : (core.drive_fault_i & ~bit);
  }
}

// A board with a model, homed, the drives on.
void enable(Bench& bench) {
  const Raw r = exchange(bench, Command::kEnable);
  ASSERT_TRUE(r.drives()) << "enable refused: flags " << r.flags() << " fault byte " << r.fault_byte();
  ASSERT_EQ(bench.core().drive_enable_o, 1);
}

TEST(BoardSafety, AnInputHeldAtStopLatchesItsCauseAndTheDrivesAreOffWithinTheFilter) {
  const std::uint64_t seed = 4242;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_safety_latch"));
  bench.load_model(q);
  exchange(bench, Command::kSetHome);
  bench.homed();
  int refused = 0;
  for (int input = 0; input < static_cast<int>(board::kBoardFaultBits); ++input) {
    SCOPED_TRACE("input " + std::to_string(input));
    enable(bench);
    bench.run(static_cast<std::int64_t>(random() % kPeriod));  // anywhere in the period
    set_input(bench, input, true);
    const std::int64_t start = bench.cycles();
    ASSERT_TRUE(bench.run_until([&] { return bench.core().drive_enable_o == 0; }, (kFilter + 2) * kPeriod));
    const std::int64_t off_after = bench.cycles() - start;
    EXPECT_LE(off_after, (kFilter + 1) * kPeriod);
    EXPECT_GE(off_after, (kFilter - 1) * kPeriod) << "the filter waits for its samples";
    EXPECT_EQ(bench.core().board_fault_cause_o, 1 << input);
    EXPECT_EQ(bench.core().joint_fault_o, 1);
    EXPECT_EQ(bench.core().joint_fault_cause_o, 0);
    bench.run(2);
    EXPECT_EQ(bench.core().drive_pwm_o, 0);
    EXPECT_EQ(bench.core().drive_dir_o, 0);
    Raw r = next(bench);
    EXPECT_EQ(r.board_causes(), 1 << input);
    EXPECT_TRUE(r.fault());
    EXPECT_FALSE(r.drives());
    EXPECT_FALSE(r.estop());
    EXPECT_EQ(r.fill(), 0);
    EXPECT_EQ(r.refused(), refused);
    // Refused while the input samples at stop, and counted; the cause stays.
    r = exchange(bench, Command::kClearFault);
    EXPECT_EQ(r.refused(), ++refused);
    EXPECT_EQ(r.board_causes(), 1 << input);
    r = exchange(bench, Command::kEnable);
    EXPECT_EQ(r.refused(), ++refused) << "enable with a cause latched";
    EXPECT_FALSE(r.drives());
    // Back at the run level: the next sample is clear, the clear is taken, the drives stay off.
    set_input(bench, input, false);
    bench.run(2 * kPeriod);
    r = exchange(bench, Command::kClearFault);
    EXPECT_EQ(r.refused(), refused);
    EXPECT_EQ(r.board_causes(), 0);
    EXPECT_FALSE(r.fault());
    bench.run(20 * kPeriod);
    EXPECT_EQ(bench.core().drive_enable_o, 0) << "a clear never enables";
    EXPECT_FALSE(next(bench).drives());
  }
  enable(bench);  // and an enable is taken again
}

TEST(BoardSafety, AGlitchShorterThanTheFilterNeverLatchesAndOneLongerAlwaysDoes) {
  const std::uint64_t seed = 99;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  Bench bench(export_directory(shipped_network(), "board_safety_glitch"));
  bench.run(2 * kPeriod);
  for (int trial = 0; trial < 12; ++trial) {
    const int input = trial % static_cast<int>(board::kBoardFaultBits);
    bench.run(static_cast<std::int64_t>(random() % kPeriod));
    // At most kFilter - 1 tick-0 samples fall in a pulse shorter than kFilter - 1 periods.
    set_input(bench, input, true);
    bench.run((kFilter - 1) * kPeriod - 1 - static_cast<std::int64_t>(random() % 8));
    set_input(bench, input, false);
    bench.run(kFilter * kPeriod);
    ASSERT_EQ(bench.core().board_fault_cause_o, 0) << "trial " << trial;
    ASSERT_EQ(bench.core().joint_fault_o, 0) << "trial " << trial;
  }
  const Raw r = next(bench);
  EXPECT_FALSE(r.fault());
  EXPECT_EQ(r.board_causes(), 0);
  // kFilter periods and a clock more always hold kFilter samples.
  for (int input = 0; input < static_cast<int>(board::kBoardFaultBits); ++input) {
    bench.run(static_cast<std::int64_t>(random() % kPeriod));
    set_input(bench, input, true);
    bench.run(kFilter * kPeriod + 1);
    set_input(bench, input, false);
    bench.run(4);
    EXPECT_EQ(bench.core().board_fault_cause_o & (1 << input), 1 << input) << "input " << input;
  }
  bench.run(2 * kPeriod);
  EXPECT_EQ(exchange(bench, Command::kClearFault).board_causes(), 0);
}

TEST(BoardSafety, EstopCommandLatchesInEveryStateAndOnlyAClearEndsIt) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_safety_estop"));
  // Drives off, no model: latched, never counted as refused.
  Raw r = exchange(bench, command_byte(bench, board::kCommandEstop));
  EXPECT_TRUE(r.estop());
  EXPECT_TRUE(r.fault());
  EXPECT_EQ(r.refused(), 0);
  EXPECT_EQ(bench.core().estop_latched_o, 1);
  EXPECT_EQ(bench.core().joint_fault_o, 1);
  bench.run(30 * kPeriod);
  EXPECT_TRUE(next(bench).estop()) << "it stays";
  r = exchange(bench, Command::kClearFault);
  EXPECT_FALSE(r.estop());
  EXPECT_FALSE(r.fault());
  // Faulted already (a safety input latched and still at stop): latched beside it, and the clear
  // is refused until the input is back.
  set_input(bench, 2, true);
  bench.run((kFilter + 1) * kPeriod);
  r = exchange(bench, command_byte(bench, board::kCommandEstop));
  EXPECT_TRUE(r.estop());
  EXPECT_EQ(r.board_causes(), 1 << 2);
  r = exchange(bench, Command::kClearFault);
  EXPECT_TRUE(r.estop());
  EXPECT_EQ(r.refused(), 1);
  set_input(bench, 2, false);
  bench.run(2 * kPeriod);
  r = exchange(bench, Command::kClearFault);
  EXPECT_FALSE(r.estop());
  EXPECT_EQ(r.board_causes(), 0);
  // Homing (drives off): the e-stop ends it.
  r = exchange(bench, Command::kHomeStart);
  ASSERT_TRUE(bench.telemetry().back().has(link::TelemetryFlag::kHoming));
  r = exchange(bench, command_byte(bench, board::kCommandEstop));
  EXPECT_TRUE(r.estop());
  EXPECT_FALSE(bench.telemetry().back().has(link::TelemetryFlag::kHoming));
  exchange(bench, Command::kClearFault);
  // Jogging: ended at once.
  r = exchange(bench, command_byte(bench, jog_byte(0, false)));
  ASSERT_TRUE(r.jogging());
  bench.send(command_byte(bench, board::kCommandEstop));
  bench.run_until_sent();
  ASSERT_TRUE(bench.run_until([&] { return bench.core().estop_latched_o == 1; }, 200));
  bench.run(2);
  EXPECT_EQ(bench.core().drive_enable_o, 0);
  r = next(bench);
  EXPECT_FALSE(r.jogging());
  EXPECT_FALSE(r.drives());
  exchange(bench, Command::kClearFault);
  // Drives on (closed loop): off at once, the buffer flushed.
  bench.load_model(q);
  exchange(bench, Command::kSetHome);
  bench.homed();
  enable(bench);
  link::SetpointPayload setpoint;
  setpoint.sample_index = 0;
  bench.exchange(link::make_frame(bench.next_sequence(), setpoint));
  bench.send(command_byte(bench, board::kCommandEstop));
  bench.run_until_sent();
  ASSERT_TRUE(bench.run_until([&] { return bench.core().estop_latched_o == 1; }, 200));
  const std::int64_t latched = bench.cycles();
  ASSERT_TRUE(bench.run_until([&] { return bench.core().drive_enable_o == 0; }, 10));
  EXPECT_LE(bench.cycles() - latched, 2);
  r = next(bench);
  EXPECT_TRUE(r.estop());
  EXPECT_FALSE(r.drives());
  EXPECT_EQ(r.fill(), 0);
  EXPECT_EQ(exchange(bench, Command::kEnable).refused(), 2) << "enable refused while latched";
  r = exchange(bench, Command::kClearFault);
  EXPECT_FALSE(r.estop());
  EXPECT_FALSE(r.drives()) << "a clear never enables";
  enable(bench);
}

TEST(BoardSafety, TheRefusedCounterStillSaturatesAt4095BesideTheBoardCauses) {
  Bench bench(export_directory(shipped_network(), "board_safety_counter"));
  set_input(bench, 0, true);
  set_input(bench, 3, true);
  bench.run((kFilter + 1) * kPeriod);
  // Clears refused (the inputs at stop) until past the counter's end.
  for (int i = 0; i < kCounterMax + 5; ++i) bench.send(bench.command(Command::kClearFault));
  bench.run_until_sent();
  Raw r = next(bench);
  EXPECT_EQ(r.refused(), kCounterMax);
  EXPECT_EQ(r.board_causes(), 1 << 0 | 1 << 3);
  EXPECT_EQ(r.word44(), kCounterMax | (1 << 0 | 1 << 3) << board::kBoardFaultShift);
  EXPECT_EQ(bench.telemetry().back().rejected & kCounterMax, kCounterMax);
}

// ---- bench jog ----------------------------------------------------------------------------------

TEST(BoardJog, AJogDrivesItsJointAloneWithItsSignForItsPeriodsThenTheDrivesAreOff) {
  Bench bench(export_directory(shipped_network(), "board_jog_length"));  // no model, not homed
  for (const int joint : {2, 1}) {
    const bool negative = joint == 1;  // the second runs its whole length
    SCOPED_TRACE("joint " + std::to_string(joint));
    bench.send(command_byte(bench, jog_byte(joint, negative)));
    bench.run_until_sent();
    ASSERT_TRUE(bench.run_until([&] { return bench.core().drive_enable_o == 1; }, 200));
    const std::int64_t start = bench.cycles();
    // One PWM period: joint j's duty is JogCurrentCode / CurrentLimitCode, the others low.
    std::array<int, 3> high{0, 0, 0};
    int dir_seen = 0;
    for (int c = 0; c < board::kPwmPeriodCycles; ++c) {
      bench.cycle();
      for (int j = 0; j < 3; ++j) high[j] += (bench.core().drive_pwm_o >> j) & 1;
      dir_seen |= bench.core().drive_dir_o;
    }
    EXPECT_EQ(high[joint], board::kJogCurrentCode * board::kPwmPeriodCycles / board::kCurrentLimitCode);
    for (int j = 0; j < 3; ++j) {
      if (j != joint) {
        EXPECT_EQ(high[j], 0);
      }
    }
    EXPECT_EQ(dir_seen, negative ? 1 << joint : 0);
    Raw r = next(bench);
    EXPECT_TRUE(r.jogging());
    EXPECT_TRUE(r.drives());
    for (int j = 0; j < 3; ++j)
      EXPECT_EQ(r.current(j), j == joint ? (negative ? -board::kJogCurrentCode : board::kJogCurrentCode) : 0);
    // Setpoints refused while it runs.
    link::SetpointPayload setpoint;
    setpoint.sample_index = 0;
    const int refused = r.refused();
    r = exchange(bench, link::make_frame(bench.next_sequence(), setpoint));
    EXPECT_EQ(r.refused(), refused + 1);
    EXPECT_EQ(r.fill(), 0);
    if (joint == 2) {  // ended by a disable
      exchange(bench, Command::kDisable);
      EXPECT_EQ(bench.core().drive_enable_o, 0);
      EXPECT_FALSE(next(bench).jogging());
      continue;
    }
    ASSERT_TRUE(bench.run_until([&] { return bench.core().drive_enable_o == 0; }, board::kJogPeriods * kPeriod));
    const std::int64_t length = bench.cycles() - start;
    EXPECT_GT(length, (board::kJogPeriods - 1) * kPeriod);
    EXPECT_LE(length, board::kJogPeriods * kPeriod + 2);
    r = next(bench);
    EXPECT_FALSE(r.jogging());
    EXPECT_FALSE(r.drives());
    EXPECT_FALSE(r.fault());
    EXPECT_EQ(bench.core().drive_pwm_o, 0);
    EXPECT_EQ(bench.core().drive_dir_o, 0);
  }
}

TEST(BoardJog, DisableEstopOrASafetyInputEndsAJogAtOnce) {
  Bench bench(export_directory(shipped_network(), "board_jog_ends"));
  auto start_jog = [&](int joint, bool negative) {
    const Raw r = exchange(bench, command_byte(bench, jog_byte(joint, negative)));
    ASSERT_TRUE(r.jogging());
    ASSERT_EQ(bench.core().drive_enable_o, 1);
  };
  auto until_off = [&](std::int64_t limit) {
    const std::int64_t from = bench.cycles();
    EXPECT_TRUE(bench.run_until([&] { return bench.core().drive_enable_o == 0; }, limit));
    return bench.cycles() - from;
  };
  start_jog(0, true);
  bench.send(bench.command(Command::kDisable));
  bench.run_until_sent();
  EXPECT_LE(until_off(4 * kLinkClocksPerBit + 4), 4 * kLinkClocksPerBit + 4);
  Raw r = next(bench);
  EXPECT_FALSE(r.jogging());
  EXPECT_FALSE(r.fault());
  start_jog(2, false);
  bench.send(command_byte(bench, board::kCommandEstop));
  bench.run_until_sent();
  until_off(4 * kLinkClocksPerBit + 4);
  r = next(bench);
  EXPECT_FALSE(r.jogging());
  EXPECT_TRUE(r.estop());
  exchange(bench, Command::kClearFault);
  start_jog(1, false);
  set_input(bench, 2, true);  // drive 2's fault line
  EXPECT_LE(until_off((kFilter + 2) * kPeriod), (kFilter + 1) * kPeriod);
  r = next(bench);
  EXPECT_FALSE(r.jogging());
  EXPECT_EQ(r.board_causes(), 1 << 2);
  // Refused with a fault latched: counted, nothing moves.
  const int refused = r.refused();
  r = exchange(bench, command_byte(bench, jog_byte(0, false)));
  EXPECT_FALSE(r.jogging());
  EXPECT_EQ(r.refused(), refused + 1);
  EXPECT_EQ(bench.core().drive_enable_o, 0);
}

TEST(BoardJog, AJogIsRefusedWhileHomingWithTheDrivesOnOrJoggingAndAnUnknownByteIsRefused) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_jog_refused"));
  Raw r = exchange(bench, Command::kHomeStart);
  r = exchange(bench, command_byte(bench, jog_byte(0, false)));
  EXPECT_FALSE(r.jogging()) << "homing";
  EXPECT_EQ(r.refused(), 1);
  exchange(bench, Command::kHold);  // ends the homing (refused: drives off)
  r = exchange(bench, command_byte(bench, jog_byte(0, false)));
  ASSERT_TRUE(r.jogging());
  const int refused = r.refused();
  r = exchange(bench, command_byte(bench, jog_byte(1, false)));
  EXPECT_EQ(r.refused(), refused + 1) << "a second jog";
  r = exchange(bench, Command::kSetHome);
  EXPECT_EQ(r.refused(), refused + 2) << "set home while jogging";
  r = exchange(bench, Command::kEnable);
  EXPECT_EQ(r.refused(), refused + 3) << "enable while jogging";
  EXPECT_TRUE(r.jogging());
  exchange(bench, Command::kDisable);
  r = exchange(bench, command_byte(bench, board::kCommandJogBase + 6));
  EXPECT_EQ(r.refused(), refused + 4) << "past the last jog byte";
  EXPECT_FALSE(r.jogging());
  // With the drives on (closed loop).
  bench.load_model(q);
  exchange(bench, Command::kSetHome);
  bench.homed();
  enable(bench);
  r = exchange(bench, command_byte(bench, jog_byte(2, true)));
  EXPECT_EQ(r.refused(), refused + 5) << "drives on";
  EXPECT_FALSE(r.jogging());
  EXPECT_TRUE(r.drives());
}

}  // namespace
}  // namespace delta::test
