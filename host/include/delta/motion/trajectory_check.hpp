// The whole trajectory checked before any motion: resampled at the streaming rate,
// every sample must be reachable, inside the network's trained range (the allowed box) and the
// joints' travel, and the joint motion (finite differences of the inverse kinematics at the rate)
// within the velocity, acceleration and jerk limits. Each offending sample is named with the
// source line it comes from, so the command can say FILE:LINE: reason and send nothing; a path
// that leaves the box is named once, with every axis it leaves it on and the box.
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

// Every problem, in time order: the first sample of each kind (unreachable; outside the box, every
// axis it leaves the box on, with how far it goes and the box, in one reason; each joint's travel,
// velocity, acceleration and jerk). `geometry` is the model the check uses for the joint angles
// (the nominal robot: the network's answers differ by at most about a degree).
// `joint_offsets_deg`, when given (one per sample), is added to each sample's joint angles before
// the travel and the derivatives are checked: what a setpoint shaping adds to the joints.
std::vector<TrajectoryViolation> all_violations(const std::vector<TrajectoryPoint>& samples, double rate_hz,
                                                const Geometry& geometry, const TrajectoryLimits& limits,
                                                const std::vector<Vec3>* joint_offsets_deg = nullptr);

// The first of them (the first sample that breaks a limit), or nothing.
std::optional<TrajectoryViolation> first_violation(const std::vector<TrajectoryPoint>& samples, double rate_hz,
                                                   const Geometry& geometry, const TrajectoryLimits& limits,
                                                   const std::vector<Vec3>* joint_offsets_deg = nullptr);

// The box alone: nothing when every sample is inside [min_m, max_m]; else the first sample outside,
// its reason "`what`: x reaches ... mm (line L), ...; the box x A .. B, y ..., z ... mm".
std::optional<TrajectoryViolation> box_violation(const std::vector<TrajectoryPoint>& samples, const Vec3& min_m,
                                                 const Vec3& max_m, const std::string& what);

// "x -12.000 .. 12.000, y -12.000 .. 12.000, z -83.300 .. -59.300 mm".
std::string box_text(const Vec3& min_m, const Vec3& max_m);

}  // namespace delta::motion
