// The jerk-limited point-to-point profile: rest to rest, every limit held, the distance reached,
// continuous acceleration, and the least time among the three limiting cases.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "delta/motion/motion_profile.hpp"

namespace delta::motion {
namespace {

// Samples the profile at 10 kHz and checks limits, continuity and the end state.
void check_profile(const JerkLimitedProfile& profile, const MotionLimits& limits, const std::string& what) {
  const double dt = 1e-4;
  PathState previous = profile.at(0.0);
  EXPECT_DOUBLE_EQ(previous.position, 0.0) << what;
  EXPECT_DOUBLE_EQ(previous.velocity, 0.0) << what;
  const int steps = static_cast<int>(std::ceil(profile.duration() / dt));
  for (int k = 1; k <= steps; ++k) {
    const PathState state = profile.at(k * dt);
    ASSERT_LE(std::abs(state.velocity), limits.velocity * (1 + 1e-9)) << what << " t " << k * dt;
    ASSERT_LE(std::abs(state.acceleration), limits.acceleration * (1 + 1e-9)) << what;
    ASSERT_LE(std::abs(state.jerk), limits.jerk * (1 + 1e-9)) << what;
    ASSERT_GE(state.position, previous.position - 1e-12) << what << ": moves back";
    // Acceleration is continuous: it changes by at most jerk * dt per step.
    ASSERT_LE(std::abs(state.acceleration - previous.acceleration), limits.jerk * dt * (1 + 1e-6) + 1e-12) << what;
    previous = state;
  }
  const PathState end = profile.at(profile.duration());
  EXPECT_NEAR(end.position, profile.distance(), 1e-12) << what;
  EXPECT_EQ(end.velocity, 0.0) << what;
  EXPECT_EQ(end.acceleration, 0.0) << what;
  // Just before the end the state is already within one step of rest (no jump at the end).
  const PathState before = profile.at(profile.duration() - 1e-6);
  EXPECT_NEAR(before.position, profile.distance(), 1e-9) << what;
  EXPECT_NEAR(before.velocity, 0.0, 1e-5) << what;
}

TEST(MotionProfile, CruiseCaseReachesTheVelocityLimitAndTheDistance) {
  const MotionLimits limits{0.05, 1.0, 50.0};  // 50 mm/s, 1 m/s^2, 50 m/s^3
  const JerkLimitedProfile profile(0.01, limits);
  EXPECT_NEAR(profile.peak_velocity(), 0.05, 1e-12);
  EXPECT_NEAR(profile.peak_acceleration(), 1.0, 1e-12);
  // Ta = a/j + v/a = 0.07 s, Tv = L/v - Ta = 0.13 s: T = 2 Ta + Tv = 0.27 s.
  EXPECT_NEAR(profile.duration(), 0.27, 1e-12);
  check_profile(profile, limits, "cruise");
}

TEST(MotionProfile, ShortMovesNeverReachTheLimitsTheyDoNotNeed) {
  const MotionLimits limits{0.05, 1.0, 50.0};
  const JerkLimitedProfile no_cruise(0.002, limits);  // accelerates to its peak, then brakes
  EXPECT_LT(no_cruise.peak_velocity(), 0.05);
  EXPECT_NEAR(no_cruise.peak_acceleration(), 1.0, 1e-12);
  check_profile(no_cruise, limits, "no cruise");
  const JerkLimitedProfile jerk_only(1e-5, limits);  // not even the acceleration limit
  EXPECT_LT(jerk_only.peak_acceleration(), 1.0);
  // Four jerk phases only: L = 2 j Tj^3, T = 4 Tj.
  EXPECT_NEAR(jerk_only.duration(), 4.0 * std::cbrt(1e-5 / (2.0 * 50.0)), 1e-12);
  check_profile(jerk_only, limits, "jerk only");
  const JerkLimitedProfile zero(0.0, limits);
  EXPECT_EQ(zero.duration(), 0.0);
}

TEST(MotionProfile, RandomDistancesAndLimitsHoldEveryLimit) {
  const std::uint64_t seed = 5;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const MotionLimits limits{0.005 + 0.1 * unit(random), 0.05 + 5.0 * unit(random), 1.0 + 500.0 * unit(random)};
    const double distance = 0.02 * unit(random) * unit(random);
    check_profile(JerkLimitedProfile(distance, limits), limits, "trial " + std::to_string(trial));
  }
}

TEST(MotionProfile, BadArgumentsAreRefused) {
  EXPECT_THROW(JerkLimitedProfile(-1.0, {1, 1, 1}), std::invalid_argument);
  EXPECT_THROW(JerkLimitedProfile(NAN, {1, 1, 1}), std::invalid_argument);
  EXPECT_THROW(JerkLimitedProfile(1.0, {0, 1, 1}), std::invalid_argument);
  EXPECT_THROW(JerkLimitedProfile(1.0, {1, INFINITY, 1}), std::invalid_argument);
}

}  // namespace
}  // namespace delta::motion
