// The trajectory check before motion: resampling, and the first offending sample named with its
// source line for each kind of fault (unreachable, outside the trained range, joint travel, too
// fast, too much acceleration or jerk, time going back, NaN); experiment 1 passes.
#include <gtest/gtest.h>

#include <cmath>

#include "delta/motion/trajectory_check.hpp"
#include "delta/trajectory.hpp"

namespace delta::motion {
namespace {

constexpr double kRate = 1000.0;

// A straight line from a to b over `seconds`, one source point per 10 ms (source lines 2, 3, ...).
std::vector<TrajectoryPoint> line(const Vec3& a, const Vec3& b, double seconds) {
  std::vector<TrajectoryPoint> points;
  const int n = static_cast<int>(seconds / 0.01);
  for (int i = 0; i <= n; ++i) {
    const double s = static_cast<double>(i) / n;
    points.push_back({i * 0.01, (1 - s) * a + s * b, static_cast<std::size_t>(i + 2)});
  }
  return points;
}

const Vec3 kCentre(0.0, 0.0, -0.0713);

TEST(TrajectoryCheck, ResamplesLinearlyAtTheRateAndKeepsSourceLines) {
  const auto samples = resample(line(kCentre, kCentre + Vec3(0.001, 0, 0), 0.1), kRate);
  ASSERT_EQ(samples.size(), 101u);
  EXPECT_NEAR(samples[50].position_m.x(), 0.0005, 1e-15);
  EXPECT_EQ(samples[0].source_line, 2u);
  EXPECT_EQ(samples[15].source_line, 4u);  // between the points of 10 ms (line 3) and 20 ms (line 4)
}

TEST(TrajectoryCheck, ExperimentOnePassesTheDefaultLimits) {
  const Trajectory experiment = make_trajectory("experiment1");
  std::vector<TrajectoryPoint> points;
  for (int i = 0; i <= 500; ++i) points.push_back({i * 0.01, experiment.position_m(i * 0.01), 0});
  TrajectoryLimits limits;
  limits.joint_velocity_deg_s = 100.0;
  limits.joint_acceleration_deg_s2 = 1000.0;
  limits.joint_jerk_deg_s3 = 1e6;  // linear interpolation of 10 ms points: jerk spikes at the corners
  EXPECT_FALSE(first_violation(resample(points, kRate), kRate, Geometry::nominal(), limits).has_value());
}

TEST(TrajectoryCheck, EachFaultNamesTheFirstOffendingSampleAndItsLine) {
  const Geometry geometry = Geometry::nominal();
  TrajectoryLimits limits;
  limits.trained_min_m = Vec3(-0.006, -0.006, -0.082);
  limits.trained_max_m = Vec3(0.006, 0.006, -0.070);
  limits.joint_min_deg = -10.24;
  limits.joint_max_deg = 92.15;
  limits.joint_velocity_deg_s = 100.0;
  limits.joint_acceleration_deg_s2 = 2000.0;
  limits.joint_jerk_deg_s3 = 1e5;

  // Outside the trained range at x = 6 mm: the line reaches it at 0.6 of its way.
  auto v = first_violation(resample(line(kCentre, kCentre + Vec3(0.01, 0, 0), 1.0), kRate), kRate, geometry, limits);
  ASSERT_TRUE(v);
  EXPECT_NE(v->reason.find("trained range"), std::string::npos) << v->reason;
  EXPECT_GE(v->t_s, 0.6 - 1e-9);
  EXPECT_LE(v->t_s, 0.601 + 1e-9);
  EXPECT_EQ(v->source_line,
            2u + static_cast<std::size_t>(std::ceil(v->t_s / 0.01 - 1e-9)));  // the point at or after it

  // Above the base: unreachable (knee-out branch), whatever the trained range says.
  TrajectoryLimits wide = limits;
  wide.trained_min_m = Vec3::Constant(-1.0);
  wide.trained_max_m = Vec3::Constant(1.0);
  wide.joint_velocity_deg_s = wide.joint_acceleration_deg_s2 = wide.joint_jerk_deg_s3 = 1e12;
  v = first_violation(resample(line(kCentre, Vec3(0, 0, 0.05), 1.0), kRate), kRate, geometry, wide);
  ASSERT_TRUE(v);
  wide = limits;
  wide.trained_min_m = Vec3::Constant(-1.0);
  wide.trained_max_m = Vec3::Constant(1.0);
  EXPECT_TRUE(v->reason.find("unreachable") != std::string::npos || v->reason.find("travel") != std::string::npos)
      << v->reason;

  // Too fast: 10 mm in 20 ms.
  v = first_violation(resample(line(kCentre, kCentre + Vec3(0.005, 0, 0), 0.02), kRate), kRate, geometry, wide);
  ASSERT_TRUE(v);
  EXPECT_NE(v->reason.find("velocity"), std::string::npos) << v->reason;
  EXPECT_EQ(v->sample, 1u);

  // A step in speed: the acceleration limit trips first (velocity stays below its limit).
  std::vector<TrajectoryPoint> step = line(kCentre, kCentre, 0.1);
  for (auto& point : step) point.position_m.x() += point.t_s > 0.05 ? (point.t_s - 0.05) * 0.02 : 0.0;
  v = first_violation(resample(step, kRate), kRate, geometry, wide);
  ASSERT_TRUE(v);
  EXPECT_TRUE(v->reason.find("acceleration") != std::string::npos || v->reason.find("jerk") != std::string::npos)
      << v->reason;
}

TEST(TrajectoryCheck, TimeGoingBackAndNanAreRefusedNamingTheLine) {
  auto points = line(kCentre, kCentre + Vec3(0.001, 0, 0), 0.1);
  points[5].t_s = 0.01;
  try {
    resample(points, kRate);
    FAIL();
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("line 7"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("backwards"), std::string::npos) << error.what();
  }
  points = line(kCentre, kCentre + Vec3(0.001, 0, 0), 0.1);
  points[3].position_m.y() = NAN;
  EXPECT_THROW(resample(points, kRate), std::invalid_argument);
  EXPECT_THROW(resample({points[0]}, kRate), std::invalid_argument);
}

}  // namespace
}  // namespace delta::motion
