// The whole trajectory checked before any motion: resampled at the streaming rate,
// every sample must be reachable, inside the network's trained range and the joints' travel, and
// the joint motion (finite differences of the inverse kinematics at the rate) within the
// velocity, acceleration and jerk limits. The first offending sample is named with the source
// line it comes from, so the command can say FILE:LINE: reason and send nothing.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "delta/geometry.hpp"

namespace delta::motion {

struct TrajectoryPoint {
  double t_s = 0.0;
  Vec3 position_m = Vec3::Zero();
  std::size_t source_line = 0;  // where it came from (0: generated)
};

struct TrajectoryLimits {
  Vec3 trained_min_m = Vec3::Constant(-1e9);  // the network's input range (W.json)
  Vec3 trained_max_m = Vec3::Constant(1e9);
  double joint_min_deg = -90.0;
  double joint_max_deg = 90.0;
  double joint_velocity_deg_s = 1e9;
  double joint_acceleration_deg_s2 = 1e9;
  double joint_jerk_deg_s3 = 1e18;
};

struct TrajectoryViolation {
  std::size_t sample = 0;  // index in the resampled trajectory
  double t_s = 0.0;
  std::size_t source_line = 0;  // the source point at or after the sample
  std::string reason;
};

// Linear interpolation at `rate_hz` from the first point's time to the last's. Throws
// std::invalid_argument (naming the line) for fewer than two points, time going backwards or a
// non-finite value.
std::vector<TrajectoryPoint> resample(const std::vector<TrajectoryPoint>& points, double rate_hz);

// The first sample that breaks a limit, or nothing. `geometry` is the model the check uses for the
// joint angles (the nominal robot: the network's answers differ by at most about a degree).
std::optional<TrajectoryViolation> first_violation(const std::vector<TrajectoryPoint>& samples, double rate_hz,
                                                   const Geometry& geometry, const TrajectoryLimits& limits);

}  // namespace delta::motion
