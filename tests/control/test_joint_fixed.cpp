// Golden fixed-point joint controller: coefficients, rest, rounding dead band, saturation, agreement with double.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "delta/control/joint_controller.hpp"
#include "delta/golden/joint_fixed.hpp"

namespace delta::control {
namespace {

TEST(JointFixed, CoefficientsAreTheDesignValuesRoundedToTheirFormats) {
  const golden::JointControllerParameters p;
  const golden::JointFixedCoefficients c = golden::make_fixed_coefficients(p);
  EXPECT_NEAR(std::ldexp(c.reference_gain, -golden::kReferenceShift), 0.12 / 1.12,
              std::ldexp(0.5, -golden::kReferenceShift));
  EXPECT_NEAR(std::ldexp(c.velocity_encoder_gain, -golden::kVelocityShift), 0.2 / 1.2,
              std::ldexp(0.5, -golden::kVelocityShift));
  EXPECT_NEAR(std::ldexp(c.disturbance_gain, -golden::kDisturbanceShift), 0.2 / 1.2,
              std::ldexp(0.5, -golden::kDisturbanceShift));
  // Kacc: current per count / period^2 = m g_r q / (K Ts^2).
  const double kacc = 1.05e-7 * 66.0 * 0.01 * M_PI / 180.0 / (0.0194 * 1e-8);
  EXPECT_NEAR(std::ldexp(c.law_acceleration_gain, -golden::kLawShift), kacc, std::ldexp(0.5, -golden::kLawShift));
  EXPECT_NEAR(std::ldexp(c.law_velocity_gain, -golden::kLawShift), -kacc * 100.0 * 1e-4,
              std::ldexp(0.5, -golden::kLawShift));
  EXPECT_NEAR(std::ldexp(c.law_position_gain, -golden::kLawShift - 16), -kacc * 1000.0 * 1e-8,
              std::ldexp(0.5, -golden::kLawShift - 16));
  EXPECT_EQ(c.current_limit_code, 16384);
  golden::JointControllerParameters too_fast = p;
  too_fast.velocity_observer_cutoff_rad_s = 20000.0;  // g_v Ts / (1 + g_v Ts) no longer fits Q.25
  EXPECT_THROW(golden::make_fixed_coefficients(too_fast), std::invalid_argument);
}

TEST(JointFixed, RestStaysAtRestWithZeroCurrent) {
  const golden::JointFixedCoefficients c = golden::make_fixed_coefficients(golden::JointControllerParameters{});
  const golden::JointFixedInput input{3000 << golden::kReferenceFraction, 3000};
  golden::JointFixedState state = golden::fixed_rest_state(input);
  for (int k = 0; k < 1000; ++k) {
    golden::JointFixedStatus status;
    ASSERT_EQ(golden::fixed_update(c, state, input, status), 0);
    ASSERT_EQ(status.overflow_count, 0);
  }
  EXPECT_TRUE(state == golden::fixed_rest_state(input));
}

// Rounding (half up) leaves a symmetric dead band of at most 0.5 / gain LSB on every filter
// state; truncation would leave a one-sided bias of up to 1 / gain LSB.
TEST(JointFixed, RoundedFilterStatesDecayToTheRoundingDeadBand) {
  golden::JointControllerParameters p;
  p.disturbance_observer = false;  // isolate the reference filter and the VOB
  const golden::JointFixedCoefficients c = golden::make_fixed_coefficients(p);
  for (const std::int32_t start : {1000000, -1000000}) {
    const golden::JointFixedInput input{0, 0};
    golden::JointFixedState state = golden::fixed_rest_state(input);
    state.reference_velocity = start;
    state.reference_acceleration = -start;
    state.velocity = start;
    for (int k = 0; k < 5000; ++k) {
      golden::JointFixedStatus status;
      golden::fixed_update(c, state, input, status);
    }
    const double reference_band = 0.5 / std::ldexp(c.reference_gain, -golden::kReferenceShift);
    const double velocity_band = 0.5 / std::ldexp(c.velocity_encoder_gain, -golden::kVelocityShift);
    EXPECT_LE(std::abs(state.reference_velocity), reference_band) << start;
    EXPECT_LE(std::abs(state.reference_acceleration), reference_band) << start;
    EXPECT_LE(std::abs(state.velocity), velocity_band + 1) << start;
  }
}

TEST(JointFixed, SaturationIsCountedNeverWrapped) {
  const golden::JointFixedCoefficients c = golden::make_fixed_coefficients(golden::JointControllerParameters{});
  golden::JointFixedState state = golden::fixed_rest_state({0, 0});
  golden::JointFixedStatus status;
  const std::int16_t current = golden::fixed_update(c, state, {INT32_MAX, 0}, status);
  EXPECT_GT(status.overflow_count, 0);
  EXPECT_TRUE(status.limited);
  EXPECT_EQ(current, c.current_limit_code);
  EXPECT_EQ(state.current, c.current_limit_code);  // the DOB sees the applied (limited) current
  EXPECT_EQ(state.reference_velocity, INT32_MAX);  // 2^23 counts/period does not fit Q8.24
  golden::fixed_update(c, state, {INT32_MIN, 0}, status);
  EXPECT_GT(status.overflow_count, 0);
  EXPECT_EQ(state.reference_velocity, INT32_MIN);
  EXPECT_EQ(state.current, -c.current_limit_code);
}

// Open loop on the same random inputs (the double controller sees the reference as quantised to
// Q.8, so that only the arithmetic differs), the fixed-point current follows the double one
// within one output LSB (2^-15 A) while commands span tens of mA. Without a plant
// the DOB is a pure integrator of (i - i_dis) and random-walks on the Q1.15 rounding of the
// applied current, so it is off here; the closed-loop tests cover it.
TEST(JointFixed, CurrentFollowsTheDoubleControllerOnRandomInputs) {
  const std::uint64_t seed = 7;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  golden::JointControllerParameters p;
  p.disturbance_observer = false;
  const golden::JointFixedCoefficients c = golden::make_fixed_coefficients(p);
  JointController reference_controller(p);
  const double amplitude = 2.0 + 3.0 * unit(random), frequency = 0.5 + unit(random);
  const double phase = 6.0 * unit(random);
  auto reference_at = [&](double t) { return 30.0 + amplitude * std::sin(2.0 * M_PI * frequency * t + phase); };
  auto encoder_at = [&](double t) { return std::floor(reference_at(t - 0.002) / 0.01 + 3.0 * std::sin(7.0 * t)); };
  reference_controller.reset({reference_at(0.0), encoder_at(0.0) * 0.01});
  golden::JointFixedState state = golden::fixed_rest_state(
      {golden::reference_code(reference_at(0.0), 0.01), static_cast<std::int16_t>(encoder_at(0.0))});
  double worst = 0.0, largest = 0.0;
  for (int k = 0; k < 50000; ++k) {
    const double t = k * p.period_s;
    const double count = encoder_at(t);
    const std::int32_t reference = golden::reference_code(reference_at(t), 0.01);
    const JointOutput output =
        reference_controller.update({std::ldexp(reference, -golden::kReferenceFraction) * 0.01, count * 0.01});
    golden::JointFixedStatus status;
    const std::int16_t code = golden::fixed_update(c, state, {reference, static_cast<std::int16_t>(count)}, status);
    ASSERT_EQ(status.overflow_count, 0);
    if (k > 100) worst = std::max(worst, std::abs(golden::current_from_code(code) - output.current_a));
    largest = std::max(largest, std::abs(output.current_a));
  }
  std::cout << "largest |i| " << largest << " A, worst fixed - double " << worst << " A\n";
  EXPECT_GT(largest, 0.05);
  EXPECT_LE(worst, std::ldexp(1.0, -golden::kCurrentFraction));
}

}  // namespace
}  // namespace delta::control
