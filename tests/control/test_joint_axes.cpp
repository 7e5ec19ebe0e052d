// joint_axes (the board block): quadrature counting, the 10 kHz tick, the controller on the
// references it is given (Q24.8 counts, from reference_interpolator.sv on the board) and PWM
// output against the golden controller, period by period; the safety latch and its clear.
#include <gtest/gtest.h>

#include <array>
#include <random>

#include "Vjoint_axes.h"
#include "delta/board_facts.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/robot_world.hpp"
#include "verilated.h"

namespace delta::control {
namespace {

// Vjoint_axes is Verilated with its defaults: the board's facts (rtl/board/delta_board_pkg.sv).
constexpr int kClocksPerPeriod = static_cast<int>(board::kClocksPerPeriod);
constexpr int kHomeCount = static_cast<int>(board::kHomeCount);
constexpr int kFirstFullPwmCycle = 1100;  // after the controller's last store of the period

class Board {
 public:
  Board() {
    top_.clk_i = 0;
    top_.rst_ni = 0;
    top_.encoder_a_i = top_.encoder_b_i = 0;
    top_.references_i[0] = top_.references_i[1] = top_.references_i[2] = 0;
    top_.enabled_i = 0;
    top_.frame_valid_i = 0;
    top_.clear_fault_i = 0;
    top_.home_i = 0;
    top_.peek_address_i = 0;
    top_.shift_write_i = 0;  // no play shift written: the controller's shift slots stay equal
    top_.shift_joint_i = 0;
    top_.shift_i = 0;
    top_.eval();
    for (int i = 0; i < 3; ++i) tick();
    top_.rst_ni = 1;
    top_.eval();
  }
  void tick() {
    top_.clk_i = 1;
    top_.eval();
    top_.clk_i = 0;
    top_.eval();
  }
  Vjoint_axes& top() { return top_; }

 private:
  VerilatedContext context_;
  Vjoint_axes top_{&context_};
};

// {A, B} Gray sequence counting up: 00 -> 10 -> 11 -> 01 (the world's encoder lines, sim/).
int quadrature_bits(int position) { return quadrature_a(position) << 1 | quadrature_b(position); }

// A reference in degrees as the board's interpolator delivers it: Q24.8 encoder counts of the
// network's Q10.14 code, round_shift(25 raw, 4).
std::int32_t reference_code(double deg) {
  const std::int64_t raw = std::llround(deg * 16384.0);
  return static_cast<std::int32_t>((25 * raw + 8) >> 4);
}

TEST(JointAxes, EncoderCountsReferencesAndPwmFollowTheGoldenController) {
  const std::uint64_t seed = 11;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  const golden::JointFixedCoefficients coefficients =
      golden::make_fixed_coefficients(golden::JointControllerParameters{});
  Board board;
  Vjoint_axes& top = board.top();
  std::array<int, 3> position{0, 0, 0};                       // counts moved since reset
  const std::array<double, 3> target_deg{30.5, 29.2, 30.03};  // references sent at period 20
  std::array<golden::JointFixedState, 3> golden;
  bool referenced = false;      // the drives are enabled from period 20 on
  bool enabled_before = false;  // in the period before this one
  int largest_duty = 0;
  for (int period = 0; period < 300; ++period) {
    std::array<int, 3> moves;
    for (int j = 0; j < 3; ++j) moves[j] = static_cast<int>(random() % 7) - 3;
    // The golden controller sees what joint_axes latches at the period's first edge.
    std::array<std::int16_t, 3> expected_current;
    for (int j = 0; j < 3; ++j) {
      golden::JointFixedInput input;
      input.encoder = static_cast<std::int16_t>(kHomeCount + position[j]);
      input.reference = referenced ? reference_code(target_deg[j]) : input.encoder * 256;
      // What the board's interpolator presents for this period: the reference, or with the
      // drives off the encoder count.
      top.references_i[j] = static_cast<std::uint32_t>(input.reference);
      // With the drives off the controller restarts from rest every period (joint_axes.sv).
      if (period == 0 || !enabled_before) golden[j] = golden::fixed_rest_state(input);
      golden::JointFixedStatus status;
      expected_current[j] = golden::fixed_update(coefficients, golden[j], input, status);
    }
    std::array<int, 3> high{0, 0, 0};
    top.enabled_i = referenced ? 1 : 0;
    for (int cycle = 0; cycle < kClocksPerPeriod; ++cycle) {
      board.tick();
      if (cycle >= 1000 && cycle < 2000 && cycle % 50 == 0) {
        int a = 0, b = 0;
        for (int j = 0; j < 3; ++j) {
          if (moves[j] > 0 && (cycle - 1000) / 50 < moves[j]) ++position[j];
          if (moves[j] < 0 && (cycle - 1000) / 50 < -moves[j]) --position[j];
          const int bits = quadrature_bits(position[j]);
          a |= (bits >> 1) << j;
          b |= (bits & 1) << j;
        }
        top.encoder_a_i = a;
        top.encoder_b_i = b;
      }
      // All three currents are stored by cycle 1073 (1072-cycle latency from tick 1): one PWM period.
      if (cycle >= kFirstFullPwmCycle && cycle < kFirstFullPwmCycle + board::kPwmPeriodCycles) {
        for (int j = 0; j < 3; ++j) high[j] += (top.drive_pwm_o >> j) & 1;
      }
      if (cycle == kFirstFullPwmCycle) {
        for (int j = 0; j < 3; ++j) {
          // The direction is the current's sign while the drives are on, low while they are off.
          ASSERT_EQ((top.drive_dir_o >> j) & 1, referenced && expected_current[j] < 0 ? 1 : 0) << "period " << period;
        }
        ASSERT_EQ(top.drive_enable_o, referenced ? 1 : 0) << "period " << period;
      }
    }
    for (int j = 0; j < 3; ++j) {
      // The controller runs with the drives off too (on the encoder position); its PWM stays low.
      const int duty = referenced ? std::abs(static_cast<int>(expected_current[j])) >> 4 : 0;
      ASSERT_EQ(high[j], duty) << "period " << period << " joint " << j << " current " << expected_current[j];
      largest_duty = std::max(largest_duty, duty);
    }
    enabled_before = referenced;
    if (period == 19) referenced = true;
    ASSERT_EQ(top.encoder_error_o, 0);
    ASSERT_EQ(top.overflow_count_o, 0);
  }
  std::cout << "largest duty " << largest_duty << " / 1024\n";
  EXPECT_GT(largest_duty, 100);  // the PWM was exercised well away from zero
}

// ---- Safety: every fault stops the torque and stays latched ------------------------------------

// joint_axes with its default safety parameters (following error -512..511 counts, WatchdogPeriods
// 2500, reference travel -1024..9215 counts), encoders driven by position, references in degrees.
// Each reference comes with a valid link frame (the watchdog's kick) and the drives enabled.
class SafetyBench {
 public:
  void send_reference(const std::array<double, 3>& deg) {
    Vjoint_axes& top = board_.top();
    for (int j = 0; j < 3; ++j) top.references_i[j] = static_cast<std::uint32_t>(reference_code(deg[j]));
    top.enabled_i = 1;
    pulse(top.frame_valid_i);
  }
  void frame() { pulse(board_.top().frame_valid_i); }
  void clear_fault() { pulse(board_.top().clear_fault_i); }
  void set_home() {  // every joint's count := HomeCount
    board_.top().home_i = 7;
    cycle();
    board_.top().home_i = 0;
  }
  void set_enabled(bool on) { board_.top().enabled_i = on ? 1 : 0; }
  // Moves joint j's encoder by `counts`, one quadrature state every 3 cycles.
  void move(int joint, int counts) {
    for (int k = 0; k < std::abs(counts); ++k) {
      position_[joint] += counts > 0 ? 1 : -1;
      apply_encoders();
      for (int c = 0; c < 3; ++c) cycle();
    }
  }
  // Two quadrature states at once on joint j: a skipped state.
  void skip(int joint) {
    position_[joint] += 2;
    apply_encoders();
    cycle();
  }
  void periods(int count) { cycles(count * kClocksPerPeriod); }
  void cycles(int count) {
    for (int i = 0; i < count; ++i) cycle();
  }
  Vjoint_axes& top() { return board_.top(); }
  int pwm_high_cycles() const { return pwm_high_; }
  int count(int joint) { return static_cast<std::int16_t>(static_cast<std::uint16_t>(top().counts_o >> (16 * joint))); }
  void clear_pwm_count() { pwm_high_ = 0; }

 private:
  void pulse(CData& signal) {
    signal = 1;
    cycle();
    signal = 0;
  }
  void cycle() {
    board_.tick();
    pwm_high_ += __builtin_popcount(board_.top().drive_pwm_o);
  }
  void apply_encoders() {
    int a = 0, b = 0;
    for (int j = 0; j < 3; ++j) {
      const int bits = quadrature_bits(position_[j]);
      a |= (bits >> 1) << j;
      b |= (bits & 1) << j;
    }
    board_.top().encoder_a_i = a;
    board_.top().encoder_b_i = b;
  }
  Board board_;
  std::array<int, 3> position_{0, 0, 0};
  int pwm_high_ = 0;
};

// Fault cause bits, named in the board's package.
constexpr int kEncoderSkip = 1 << board::kFaultEncoderSkip, kFollowing = 1 << board::kFaultFollowing,
              kWatchdog = 1 << board::kFaultWatchdog, kTravel = 1 << board::kFaultTravel;

// Torque off: enable low and no PWM pulse over two whole periods, whatever the controller computes.
void expect_torque_off(SafetyBench& bench, int cause) {
  EXPECT_EQ(bench.top().fault_o, 1);
  EXPECT_EQ(bench.top().fault_cause_o, cause);
  bench.clear_pwm_count();
  bench.periods(2);
  EXPECT_EQ(bench.top().drive_enable_o, 0);
  EXPECT_EQ(bench.pwm_high_cycles(), 0);
  EXPECT_EQ(bench.top().fault_o, 1);  // latched
}

TEST(JointAxesSafety, EncoderSkipStopsTorqueWithinACycle) {
  SafetyBench bench;
  bench.send_reference({30.2, 29.9, 30.05});  // 20, -10 and 5 counts from home: currents flow
  bench.periods(5);
  EXPECT_EQ(bench.top().drive_enable_o, 1);
  EXPECT_EQ(bench.top().fault_o, 0);
  bench.clear_pwm_count();
  bench.periods(1);
  EXPECT_GT(bench.pwm_high_cycles(), 0);  // torque before the fault
  bench.skip(1);
  bench.cycles(3);  // the counter's input register, its decision, the output register
  EXPECT_EQ(bench.top().drive_enable_o, 0);
  bench.send_reference({30.2, 29.9, 30.05});  // a new reference does not revive the drives
  expect_torque_off(bench, kEncoderSkip);
}

TEST(JointAxesSafety, FollowingErrorWithinTheLimitKeepsTorque) {
  SafetyBench within;
  within.send_reference({34.9, 30.0, 30.0});  // 490 counts: inside the 511-count limit
  within.periods(20);
  EXPECT_EQ(within.top().fault_o, 0);
  EXPECT_EQ(within.top().drive_enable_o, 1);
}

TEST(JointAxesSafety, FollowingErrorBeyondTheLimitStopsTorque) {
  SafetyBench beyond;
  beyond.send_reference({30.0, 30.0, 24.88});  // 512 counts below: the limit, allowed
  beyond.periods(1);
  EXPECT_EQ(beyond.top().fault_o, 0);
  beyond.send_reference({30.0, 30.0, 24.87});  // 513 counts below
  beyond.periods(1);
  beyond.cycles(3);  // decided two cycles after the period's tick
  expect_torque_off(beyond, kFollowing);
}

TEST(JointAxesSafety, WatchdogStopsTorqueWhenTheFramesStop) {
  SafetyBench bench;
  for (int i = 0; i < 3; ++i) {  // a valid frame every 400 periods: no fault
    bench.send_reference({30.0, 30.0, 30.0});
    bench.periods(400);
  }
  EXPECT_EQ(bench.top().fault_o, 0);
  bench.send_reference({30.0, 30.0, 30.0});
  bench.periods(board::kWatchdogPeriods - 1);
  EXPECT_EQ(bench.top().fault_o, 0);
  EXPECT_EQ(bench.top().drive_enable_o, 1);
  bench.periods(3);
  expect_torque_off(bench, kWatchdog);
}

// One Verilated bench per test: two alive at once in one thread hang in eval().
TEST(JointAxesSafety, ReferenceOutsideTheTravelStopsTorque) {
  SafetyBench outside;
  outside.move(0, 9150 - kHomeCount);           // 91.50 deg, inside the travel
  outside.send_reference({92.15, 30.0, 30.0});  // 9215 counts: the travel's end, allowed
  outside.periods(2);
  EXPECT_EQ(outside.top().fault_o, 0);
  outside.send_reference({92.17, 30.0, 30.0});  // 9217 counts, past the end
  outside.periods(1);
  outside.cycles(3);  // decided two cycles after the period's tick
  expect_torque_off(outside, kTravel);
}

TEST(JointAxesSafety, ClearFaultWorksOnlyOnceTheCauseIsGoneAndDoesNotEnable) {
  SafetyBench bench;
  bench.send_reference({30.0, 30.0, 36.0});  // 600 counts ahead of the encoder: following error
  bench.periods(1);
  bench.cycles(3);
  EXPECT_EQ(bench.top().fault_o, 1);
  EXPECT_EQ(bench.top().fault_active_o, 1);  // the condition persists: the board refuses a clear
  bench.send_reference({30.0, 30.0, 30.0});  // back on the encoder
  bench.periods(1);
  bench.cycles(3);
  EXPECT_EQ(bench.top().fault_active_o, 0);
  EXPECT_EQ(bench.top().fault_o, 1);  // still latched: nothing clears it but a clear
  bench.set_enabled(false);           // the board drops its enable on a fault
  bench.clear_fault();
  EXPECT_EQ(bench.top().fault_o, 0);
  EXPECT_EQ(bench.top().fault_cause_o, 0);
  bench.clear_pwm_count();
  bench.periods(3);
  EXPECT_EQ(bench.top().drive_enable_o, 0);  // cleared, not enabled
  EXPECT_EQ(bench.pwm_high_cycles(), 0);
  bench.send_reference({30.0, 30.0, 30.0});  // an explicit enable brings the torque back
  bench.periods(2);
  EXPECT_EQ(bench.top().drive_enable_o, 1);
}

TEST(JointAxesSafety, SetHomeLoadsTheHomeCountAndTheEncodersKeepCounting) {
  SafetyBench bench;
  bench.move(0, 37);
  bench.move(2, -12);
  EXPECT_EQ(bench.count(0), kHomeCount + 37);
  EXPECT_EQ(bench.count(2), kHomeCount - 12);
  bench.set_home();
  EXPECT_EQ(bench.count(0), kHomeCount);
  EXPECT_EQ(bench.count(1), kHomeCount);
  EXPECT_EQ(bench.count(2), kHomeCount);
  bench.move(1, 5);  // counting goes on from the home count, drives off
  EXPECT_EQ(bench.count(1), kHomeCount + 5);
  EXPECT_EQ(bench.top().drive_enable_o, 0);
}

TEST(JointAxesSafety, WatchdogIsDisarmedWithTheDrivesOff) {
  SafetyBench bench;
  bench.periods(board::kWatchdogPeriods + 100);  // no frame beyond the bound, drives never enabled
  EXPECT_EQ(bench.top().fault_o, 0);
  bench.send_reference({30.0, 30.0, 30.0});
  bench.set_enabled(false);
  bench.periods(board::kWatchdogPeriods + 100);
  EXPECT_EQ(bench.top().fault_o, 0);
}

}  // namespace
}  // namespace delta::control
