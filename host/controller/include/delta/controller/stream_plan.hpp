// What `deltactl host run` streams, planned and checked whole before any byte is sent:
// the trajectory (a named one of `deltactl simulate`, or FILE.csv of t_s,x_m,y_m,z_m resampled at
// 1 kHz), entered and left by jerk-limited time scaling (the path's time runs at a rate that rises
// from 0 to 1 and falls back, so the plate starts and ends at rest on the path), preceded by a
// jerk-limited straight move from the pose the encoders report to the path's first point.
//
//   sample k < approach: the straight move (motion::JerkLimitedProfile, rest to rest)
//   then: P(tau_k), tau_{k+1} = tau_k + rate_k / 1 kHz, the rate ramping 0 -> 1 -> 0
//
// A controlled stop (SIGINT, SIGTERM) replaces the rest of the plan by a ramp of the rate to 0
// from where the stream is: the plate slows down along the path, within the checked limits. A feed
// hold is the same ramp, and a resume appends a ramp of the rate from 0 back to 1 from where the
// hold came to rest, then the rest of the path and its final ramp: the plan grows into capacity
// reserved at construction (kHoldReserveSamples), so the streaming thread never allocates.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "delta/geometry.hpp"
#include "delta/motion/motion_profile.hpp"
#include "delta/motion/trajectory_check.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::controller {

constexpr double kStreamRateHz = 1000.0;  // one setpoint per board setpoint period
// Samples reserved for feed holds: each hold and resume lengthens the plan by about the two ramps'
// extra time (~0.3 s), so a run takes about 200 of them.
constexpr std::size_t kHoldReserveSamples = 60'000;
// The longest run: trajectory time (a named trajectory's --duration, a FILE.csv's span, the moves
// of move:) is checked against it before anything is allocated for the plan. The plan and its check
// take about 200 bytes per 1 kHz sample: 600 s is about 120 MB.
constexpr double kMaxRunSeconds = 600.0;

// The limits every streamed sample is checked against (joint angles from the nominal model).
struct StreamLimits {
  double joint_velocity_deg_s = 100.0;
  double joint_acceleration_deg_s2 = 1.0e4;
  // Third differences at 1 kHz: a FILE.csv is interpolated linearly, so its corners count as jerk
  // (a 100 Hz file of experiment 1 peaks at ~4e4 deg/s^3); smooth moves stay far below.
  double joint_jerk_deg_s3 = 1.0e6;
  motion::MotionLimits approach{0.02, 0.2, 4.0};  // the straight move: m/s, m/s^2, m/s^3
  // The rate of path time (1/s and its derivatives): a ramp 0 -> 1 lasts about 0.3 s.
  motion::MotionLimits rate{6.7, 90.0, 1500.0};
};

// The path in trajectory time, 1 kHz samples from tau = 0, each with the source line it came from.
struct Path {
  std::string source;  // NAME or FILE.csv, for messages
  std::vector<motion::TrajectoryPoint> samples;
  double duration_s() const { return samples.empty() ? 0.0 : samples.back().t_s - samples.front().t_s; }
  // Linear interpolation at tau (clamped to the path); `line` gets the source line.
  Vec3 at(double tau_s, std::size_t* line = nullptr) const;
};

// NAME (a trajectory of `deltactl simulate`) sampled at 1 kHz over [0, duration] (duration <= 0:
// its default length), or "move:X,Y,Z[;X,Y,Z...]" (point-to-point: rest-to-rest jerk-limited
// straight moves through the waypoints, metres, at the approach's limits), or FILE.csv read (InputError naming file,
// line, reason: missing columns, non-numeric or non-finite fields, time going back, a span beyond kMaxRunSeconds;
// not a regular file: a FIFO or a device is refused before it is opened), shifted to start at tau = 0, cut
// at `duration_s` (if > 0) and resampled at 1 kHz. A duration_s beyond kMaxRunSeconds (or not a
// number) is std::invalid_argument; moves lasting longer are an InputError.
Path load_path(const std::string& name_or_file, double duration_s);

// The time scaling of the path: the rate of path time, ramped by a jerk-limited profile.
class TimeScaling {
 public:
  explicit TimeScaling(const motion::MotionLimits& rate_limits) : limits_(rate_limits) {}
  void ramp_to(double rate);  // from the present rate
  void set_rate(double rate) {
    rate_ = rate;
    ramp_.reset();
  }
  // Advances by dt; returns the rate for the step just taken.
  double step(double dt_s);
  double rate() const { return rate_; }
  bool ramping() const { return ramp_.has_value(); }
  // Path time a ramp from `rate` to 0 covers (to start the final ramp in time).
  double stopping_distance(double rate) const;

 private:
  motion::MotionLimits limits_;
  double rate_ = 0.0;
  double from_ = 0.0, to_ = 0.0, elapsed_ = 0.0;
  std::optional<motion::JerkLimitedProfile> ramp_;
};

// The samples to stream: positions [m] and the path time of each (-1 during the approach).
class StreamPlan {
 public:
  // Plans the approach from `start_m` to the path's first point, then the path with ramps in and
  // out. Throws std::invalid_argument for an empty path.
  StreamPlan(const Path& path, const Vec3& start_m, const StreamLimits& limits);

  std::size_t size() const { return position_.size(); }
  std::size_t approach_samples() const { return approach_samples_; }
  const Vec3& position(std::size_t k) const { return position_[k]; }
  double tau(std::size_t k) const { return tau_[k]; }
  std::size_t source_line(std::size_t k) const { return line_[k]; }

  // A controlled stop from sample k on (the samples before k are sent): the rate ramps to 0 from
  // where it is at k and the plan ends there; returns the new size. No allocation. In the straight
  // move to the start, the move's own time is ramped to 0 the same way (the plate comes to rest on
  // the line within about 0.3 s; such a plan is not resumable).
  std::size_t stop_from(std::size_t k) { return cut(k, true); }
  // A feed hold from sample k on: as stop_from, but the plan can be resumed (a hold during the
  // straight move lets the move finish at the path's start); returns the new size.
  std::size_t hold_from(std::size_t k) { return cut(k, false); }
  // Resumes a plan that ends at rest (after hold_from): the rate ramps from 0 to 1 from the last
  // sample's path time, then the rest of the path, ending at rest at its end. Returns the new size,
  // or 0 when the reserve is used up or the plan is not at rest on its path (nothing changed).
  std::size_t resume();
  // Samples the plan can hold without allocating (its size after any number of holds is below).
  std::size_t capacity() const { return capacity_; }
  // True when the plan ends at rest short of the path's end (after a hold or a stop).
  bool resumable() const;

  // Every sample as the trajectory check sees it.
  std::vector<motion::TrajectoryPoint> points() const;

 private:
  // Appends the path from tau with the rate ramping from `rate` to 1, then out to rest at the end.
  void append_path(double tau, double rate);
  std::size_t cut(std::size_t k, bool stop_in_approach);
  // The straight move at its own time u (s): where the plate is.
  Vec3 approach_at(double u) const;

  const Path& path_;
  StreamLimits limits_;
  std::size_t capacity_ = 0;
  std::size_t approach_samples_ = 0;
  std::size_t final_ramp_ = ~std::size_t{0};  // the sample where the ramp to the end starts
  Vec3 approach_from_ = Vec3::Zero(), approach_delta_ = Vec3::Zero();
  std::optional<motion::JerkLimitedProfile> approach_move_;
  bool stopped_in_approach_ = false;
  std::vector<Vec3> position_;
  std::vector<double> tau_;
  std::vector<double> rate_;
  std::vector<std::size_t> line_;
};

// The whole-plan check: reachable, inside the trained range (the allowed box), joint travel (the
// board's, joint_travel()), velocity, acceleration and jerk; with `model` (W.json's, a deployed
// model with a joint ripple table) also the setpoints as sent, shaped, inside the trained range,
// and the joints as the shaping moves them (the table's entry on top of each joint) within the
// travel and the velocity, acceleration and jerk limits.
// Every problem (the first sample of each kind, in time order) as "SOURCE:LINE: reason (sample k,
// t = ... s)"; a path outside the box is one problem naming every axis it leaves it on, and the box.
std::vector<std::string> check_plan_all(const StreamPlan& plan, const std::string& source, const Vec3& trained_min_m,
                                        const Vec3& trained_max_m, const StreamLimits& limits,
                                        const nn::WeightsFile* model = nullptr);
// The first of them, or nothing.
std::optional<std::string> check_plan(const StreamPlan& plan, const std::string& source, const Vec3& trained_min_m,
                                      const Vec3& trained_max_m, const StreamLimits& limits,
                                      const nn::WeightsFile* model = nullptr);

// The joints' travel the board allows (its travel blocks: -10.24 .. 92.15 deg), the same for every joint.
struct JointTravel {
  double min_deg = 0.0, max_deg = 0.0;
};
JointTravel joint_travel();

}  // namespace delta::controller
