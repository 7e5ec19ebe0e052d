// joint_axes (the board block): quadrature counting, the 10 kHz tick, reference conversion and
// PWM output against the golden controller, period by period.
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

class Board {
 public:
  Board() {
    top_.clk_i = 0;
    top_.rst_ni = 0;
    top_.encoder_a_i = top_.encoder_b_i = 0;
    top_.references_i[0] = top_.references_i[1] = top_.references_i[2] = 0;
    top_.reference_valid_i = 0;
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

TEST(JointAxes, EncoderCountsReferencesAndPwmFollowTheGoldenController) {
  const std::uint64_t seed = 11;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  const JointFixedCoefficients coefficients = make_fixed_coefficients(JointControllerParameters{});
  Board board;
  Vjoint_axes& top = board.top();
  std::array<int, 3> position{0, 0, 0};                       // counts moved since reset
  const std::array<double, 3> target_deg{30.5, 29.2, 30.03};  // references sent at period 20
  std::array<JointFixedState, 3> golden;
  bool referenced = false;
  int largest_duty = 0;
  for (int period = 0; period < 300; ++period) {
    std::array<int, 3> moves;
    for (int j = 0; j < 3; ++j) moves[j] = static_cast<int>(random() % 7) - 3;
    // The golden controller sees what joint_axes latches at the period's first edge.
    std::array<std::int16_t, 3> expected_current;
    for (int j = 0; j < 3; ++j) {
      JointFixedInput input;
      input.encoder = static_cast<std::int16_t>(kHomeCount + position[j]);
      const std::int64_t raw = std::llround(target_deg[j] * 16384.0);
      input.reference = referenced ? static_cast<std::int32_t>((25 * raw + 8) >> 4) : input.encoder * 256;
      if (period == 0) golden[j] = fixed_rest_state(input);
      JointFixedStatus status;
      expected_current[j] = fixed_update(coefficients, golden[j], input, status);
    }
    std::array<int, 3> high{0, 0, 0};
    for (int cycle = 0; cycle < kClocksPerPeriod; ++cycle) {
      board.tick();
      // The reference arrives at the first cycle of period 20, while the controller copies its
      // inputs: period 20 must still hold the encoder position (no zero reference for a period).
      if (period == 20 && cycle == 0) {
        for (int j = 0; j < 3; ++j) {
          const std::uint32_t raw = static_cast<std::uint32_t>(std::llround(target_deg[j] * 16384.0)) & 0xFFFFFFu;
          // 72-bit port: joint j at bits [24j +: 24] over three 32-bit words.
          const int bit = 24 * j;
          top.references_i[bit / 32] |= raw << (bit % 32);
          if (bit % 32 > 8) top.references_i[bit / 32 + 1] |= raw >> (32 - bit % 32);
        }
        top.reference_valid_i = 1;
      } else {
        top.reference_valid_i = 0;
      }
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
      if (cycle >= 950 && cycle < 950 + board::kPwmPeriodCycles) {
        for (int j = 0; j < 3; ++j) high[j] += (top.drive_pwm_o >> j) & 1;
      }
      if (cycle == 950) {
        for (int j = 0; j < 3; ++j) {
          ASSERT_EQ((top.drive_dir_o >> j) & 1, expected_current[j] < 0 ? 1 : 0) << "period " << period;
        }
        ASSERT_EQ(top.drive_enable_o, referenced || period == 20 ? 1 : 0) << "period " << period;  // valid at 0
      }
    }
    for (int j = 0; j < 3; ++j) {
      const int duty = std::abs(static_cast<int>(expected_current[j])) >> 4;
      ASSERT_EQ(high[j], duty) << "period " << period << " joint " << j << " current " << expected_current[j];
      largest_duty = std::max(largest_duty, duty);
    }
    if (period == 20) referenced = true;
    ASSERT_EQ(top.encoder_error_o, 0);
    ASSERT_EQ(top.overflow_count_o, 0);
  }
  std::cout << "largest duty " << largest_duty << " / 1024\n";
  EXPECT_GT(largest_duty, 100);  // the PWM was exercised well away from zero
}

// ---- Safety: every fault stops the torque and stays latched ------------------------------------

// joint_axes with its default safety parameters (following error -512..511 counts, WatchdogPeriods
// 500, reference travel -1024..9215 counts), encoders driven by position, references in degrees.
class SafetyBench {
 public:
  void send_reference(const std::array<double, 3>& deg) {
    Vjoint_axes& top = board_.top();
    top.references_i[0] = top.references_i[1] = top.references_i[2] = 0;
    for (int j = 0; j < 3; ++j) {
      const std::uint32_t raw = static_cast<std::uint32_t>(std::llround(deg[j] * 16384.0)) & 0xFFFFFFu;
      const int bit = 24 * j;
      top.references_i[bit / 32] |= raw << (bit % 32);
      if (bit % 32 > 8) top.references_i[bit / 32 + 1] |= raw >> (32 - bit % 32);
    }
    top.reference_valid_i = 1;
    cycle();
    top.reference_valid_i = 0;
  }
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
  void clear_pwm_count() { pwm_high_ = 0; }

 private:
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

TEST(JointAxesSafety, WatchdogStopsTorqueWhenTheReferencesStop) {
  SafetyBench bench;
  for (int i = 0; i < 3; ++i) {  // refreshed every 400 periods: no fault
    bench.send_reference({30.0, 30.0, 30.0});
    bench.periods(400);
  }
  EXPECT_EQ(bench.top().fault_o, 0);
  bench.send_reference({30.0, 30.0, 30.0});
  bench.periods(499);
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

}  // namespace
}  // namespace delta::control
