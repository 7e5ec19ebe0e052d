// Jerk-limited rest-to-rest profile (see motion_profile.hpp).
#include "delta/motion/motion_profile.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace delta::motion {
namespace {

// The state after `dt` of constant jerk from `s` (exact: the integrals of a constant).
PathState advance(const PathState& s, double jerk, double dt) {
  PathState next;
  next.jerk = jerk;
  next.acceleration = s.acceleration + jerk * dt;
  next.velocity = s.velocity + s.acceleration * dt + jerk * dt * dt / 2.0;
  next.position = s.position + s.velocity * dt + s.acceleration * dt * dt / 2.0 + jerk * dt * dt * dt / 6.0;
  return next;
}

}  // namespace

JerkLimitedProfile::JerkLimitedProfile(double distance, const MotionLimits& limits) : distance_(distance) {
  if (!std::isfinite(distance) || distance < 0.0)
    throw std::invalid_argument("motion: distance must be finite and >= 0");
  if (!(limits.velocity > 0.0) || !(limits.acceleration > 0.0) || !(limits.jerk > 0.0) ||
      !std::isfinite(limits.velocity + limits.acceleration + limits.jerk)) {
    throw std::invalid_argument("motion: velocity, acceleration and jerk limits must be finite and > 0");
  }
  const double v = limits.velocity, a = limits.acceleration, j = limits.jerk;
  double tj = 0.0, ta = 0.0, tv = 0.0;  // jerk phase, acceleration phase (jerk phases included), cruise
  if (distance > 0.0) {
    // With cruise at v: acceleration phase reaching v.
    if (v * j >= a * a) {
      tj = a / j;
      ta = tj + v / a;
    } else {
      tj = std::sqrt(v / j);
      ta = 2.0 * tj;
    }
    tv = distance / v - ta;
    if (tv < 0.0) {  // v is not reached: no cruise
      tv = 0.0;
      tj = a / j;
      const double delta = std::pow(a, 4) / (j * j) + 4.0 * distance * a;
      ta = (a * a / j + std::sqrt(delta)) / (2.0 * a);
      if (ta < 2.0 * tj) {  // a is not reached either
        tj = std::cbrt(distance / (2.0 * j));
        ta = 2.0 * tj;
      }
    }
  }
  peak_acceleration_ = j * tj;
  peak_velocity_ = (ta - tj) * peak_acceleration_;
  const std::array<double, 7> durations = {tj, ta - 2.0 * tj, tj, tv, tj, ta - 2.0 * tj, tj};
  jerk_ = {j, 0.0, -j, 0.0, -j, 0.0, j};
  PathState state;
  double time = 0.0;
  for (int phase = 0; phase < 7; ++phase) {
    start_[phase] = state;
    const double duration = std::max(0.0, durations[phase]);
    state = advance(state, jerk_[phase], duration);
    time += duration;
    end_[phase] = time;
  }
}

PathState JerkLimitedProfile::at(double t) const {
  t = std::clamp(t, 0.0, duration());
  int phase = 0;
  while (phase < 6 && t > end_[phase]) ++phase;
  const double phase_start = phase == 0 ? 0.0 : end_[phase - 1];
  PathState state = advance(start_[phase], jerk_[phase], t - phase_start);
  if (t >= duration()) {  // exactly at rest at the goal (no rounding left over)
    state = PathState{};
    state.position = distance_;
  }
  return state;
}

}  // namespace delta::motion
