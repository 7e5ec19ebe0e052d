// Point-to-point motion profiles behind one interface (Debian has no Ruckig): a scalar path
// s(t) from 0 to a distance, rest to rest; the host controller moves along a straight line in
// Cartesian space with it. JerkLimitedProfile is the double-S (seven constant-jerk phases) that
// reaches the distance in the least time allowed by the velocity, acceleration and jerk limits
// when it starts and ends at rest (Biagiotti & Melchiorri, "Trajectory Planning for Automatic
// Machines and Robots", 3.4).
#pragma once

#include <array>

namespace delta::motion {

struct PathState {
  double position = 0.0;      // along the path [m]
  double velocity = 0.0;      // [m/s]
  double acceleration = 0.0;  // [m/s^2]
  double jerk = 0.0;          // [m/s^3]
};

struct MotionLimits {
  double velocity = 0.0;      // [m/s] > 0
  double acceleration = 0.0;  // [m/s^2] > 0
  double jerk = 0.0;          // [m/s^3] > 0
};

class MotionProfile {
 public:
  virtual ~MotionProfile() = default;
  virtual double duration() const = 0;
  virtual double distance() const = 0;
  // The state at time t (clamped to [0, duration]).
  virtual PathState at(double t) const = 0;
};

class JerkLimitedProfile : public MotionProfile {
 public:
  // Throws std::invalid_argument for a negative or non-finite distance or non-positive limits.
  JerkLimitedProfile(double distance, const MotionLimits& limits);
  double duration() const override { return end_[6]; }
  double distance() const override { return distance_; }
  PathState at(double t) const override;
  double peak_velocity() const { return peak_velocity_; }
  double peak_acceleration() const { return peak_acceleration_; }

 private:
  double distance_;
  double peak_velocity_ = 0.0;
  double peak_acceleration_ = 0.0;
  std::array<double, 7> jerk_{};      // constant jerk of each phase
  std::array<double, 7> end_{};       // end time of each phase
  std::array<PathState, 7> start_{};  // state at the start of each phase
};

}  // namespace delta::motion
