// The trajectory check before motion: resampling, and the first offending sample named with its
// source line for each kind of fault (unreachable, outside the trained range, joint travel, too
// fast, too much acceleration or jerk, time going back, NaN); experiment 1 passes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

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

// A path that leaves the box on two axes (x above, then z below) and comes back: one problem,
// at the first sample outside, naming both axes with how far each goes and the box; every kind
// of problem is listed once (a joint too fast as well).
TEST(TrajectoryCheck, LeavingTheBoxNamesEveryAxisOutsideAndTheBoxInOneLine) {
  TrajectoryLimits limits;
  limits.trained_min_m = Vec3(-0.006, -0.006, -0.082);
  limits.trained_max_m = Vec3(0.006, 0.006, -0.070);
  std::vector<TrajectoryPoint> points = line(kCentre, kCentre + Vec3(0.008, 0.0, 0.0), 1.0);  // x to 8 mm
  for (const auto& p : line(kCentre + Vec3(0.008, 0, 0), kCentre + Vec3(0.0, 0.0, -0.014), 1.0)) {
    points.push_back({p.t_s + 1.01, p.position_m, p.source_line + 101});  // then z down to -85.3 mm
  }
  const auto samples = resample(points, kRate);
  const auto v = first_violation(samples, kRate, Geometry::nominal(), limits);
  ASSERT_TRUE(v);
  std::cout << v->reason << '\n';
  EXPECT_NE(v->reason.find("trained range"), std::string::npos) << v->reason;
  EXPECT_NE(v->reason.find("x reaches 8.000 mm (above 6.000"), std::string::npos) << v->reason;
  EXPECT_NE(v->reason.find("z reaches -85.300 mm (below -82.000"), std::string::npos) << v->reason;
  EXPECT_EQ(v->reason.find("y reaches"), std::string::npos) << v->reason;
  EXPECT_NE(v->reason.find("the box x -6.000 .. 6.000, y -6.000 .. 6.000, z -82.000 .. -70.000 mm"), std::string::npos)
      << v->reason;
  EXPECT_EQ(v->reason.find('\n'), std::string::npos);
  EXPECT_NEAR(v->t_s, 0.75, 1.5e-3);  // x passes 6 mm three quarters of the way out
  const auto all = all_violations(samples, kRate, Geometry::nominal(), limits);
  EXPECT_EQ(all.size(), 1u);
  limits.joint_velocity_deg_s = 2.0;
  const auto more = all_violations(samples, kRate, Geometry::nominal(), limits);
  ASSERT_GE(more.size(), 2u);
  for (std::size_t i = 1; i < more.size(); ++i) EXPECT_LE(more[i - 1].sample, more[i].sample);
  EXPECT_EQ(
      std::count_if(more.begin(), more.end(),
                    [](const TrajectoryViolation& x) { return x.reason.find("trained range") != std::string::npos; }),
      1);
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
