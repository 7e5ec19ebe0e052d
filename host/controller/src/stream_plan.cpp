// What host run streams, planned and checked whole (see stream_plan.hpp).
#include "delta/controller/stream_plan.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "delta/board_facts.hpp"
#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/trajectory.hpp"

namespace delta::controller {
namespace {

constexpr double kDt = 1.0 / kStreamRateHz;

std::string fixed_seconds(double seconds) {
  std::ostringstream text;
  text << seconds << " s";
  return text.str();
}

bool is_named(const std::string& name) {
  for (const auto& entry : trajectory_catalogue()) {
    if (entry.first == name) return true;
  }
  return false;
}

}  // namespace

Vec3 Path::at(double tau_s, std::size_t* line) const {
  const double u = std::clamp(tau_s, 0.0, duration_s()) * kStreamRateHz;
  const auto i = std::min(static_cast<std::size_t>(u), samples.size() - 1);
  const std::size_t j = std::min(i + 1, samples.size() - 1);
  const double s = std::clamp(u - static_cast<double>(i), 0.0, 1.0);
  if (line) *line = s > 0.0 ? samples[j].source_line : samples[i].source_line;  // moving towards j
  return (1.0 - s) * samples[i].position_m + s * samples[j].position_m;
}

// "move:X,Y,Z[;X,Y,Z...]": rest-to-rest jerk-limited straight moves through the waypoints (metres),
// the first reached by the plan's approach; waypoint k is "line" k of the source for messages.
Path load_moves(const std::string& spec, const motion::MotionLimits& limits) {
  Path path;
  path.source = spec;
  std::vector<Vec3> points;
  std::stringstream list(spec.substr(5));
  std::string item;
  while (std::getline(list, item, ';')) {
    std::stringstream fields(item);
    std::string field;
    Vec3 p;
    int n = 0;
    while (std::getline(fields, field, ',')) {
      const std::optional<double> parsed = parse_decimal(field);
      const double value = parsed.value_or(NAN);
      if (n >= 3 || !parsed || !std::isfinite(value)) {
        throw InputError(spec, points.size() + 1, "a waypoint is X,Y,Z in metres, finite ('" + item + "')");
      }
      p[n++] = value;
    }
    if (n != 3) throw InputError(spec, points.size() + 1, "a waypoint is X,Y,Z in metres ('" + item + "')");
    points.push_back(p);
  }
  if (points.empty()) throw InputError(spec, 0, "move: needs at least one waypoint X,Y,Z");
  path.samples.push_back({0.0, points.front(), 1});
  for (std::size_t w = 1; w < points.size(); ++w) {
    const Vec3 from = points[w - 1], delta = points[w] - from;
    const double distance = delta.norm();
    if (distance < 1e-9) continue;
    const double t0 = path.samples.back().t_s;
    if (!(t0 + distance / limits.velocity <= kMaxRunSeconds)) {  // at least that long: refused before the profile
      throw InputError(spec, w + 1,
                       "the moves last more than " + fixed_seconds(kMaxRunSeconds) + " (the longest run); split them");
    }
    const motion::JerkLimitedProfile move(distance, limits);
    if (!(t0 + move.duration() <= kMaxRunSeconds)) {  // before anything is allocated for it
      throw InputError(spec, w + 1,
                       "the moves last more than " + fixed_seconds(kMaxRunSeconds) + " (the longest run); split them");
    }
    const auto count = static_cast<std::size_t>(std::ceil(move.duration() * kStreamRateHz));
    for (std::size_t k = 1; k <= count; ++k) {
      const double s = move.at(static_cast<double>(k) * kDt).position / distance;
      path.samples.push_back({t0 + static_cast<double>(k) * kDt, from + s * delta, w + 1});
    }
  }
  path.samples.push_back({path.samples.back().t_s + kDt, path.samples.back().position_m, points.size()});
  return path;
}

Path load_path(const std::string& name_or_file, double duration_s) {
  if (name_or_file.rfind("move:", 0) == 0) return load_moves(name_or_file, StreamLimits{}.approach);
  if (!(duration_s <= kMaxRunSeconds)) {
    throw std::invalid_argument("a run lasts at most " + fixed_seconds(kMaxRunSeconds) + " of trajectory time (asked " +
                                std::to_string(duration_s) + " s)");
  }
  Path path;
  path.source = name_or_file;
  if (is_named(name_or_file)) {
    const Trajectory trajectory = make_trajectory(name_or_file);
    const double length = duration_s > 0.0 ? duration_s : trajectory.samples / trajectory.rate_hz;
    const auto count = static_cast<std::size_t>(std::llround(length * kStreamRateHz)) + 1;
    path.samples.resize(count);
    for (std::size_t k = 0; k < count; ++k) {
      path.samples[k].t_s = static_cast<double>(k) * kDt;
      path.samples[k].position_m = trajectory.position_m(path.samples[k].t_s);
    }
    return path;
  }
  const CsvTable table = read_csv(name_or_file, {"t_s", "x_m", "y_m", "z_m"});
  std::vector<motion::TrajectoryPoint> points;
  const double t0 = table.rows.front()[0];
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    const auto& row = table.rows[i];
    if (i > 0 && row[0] < table.rows[i - 1][0]) {
      throw InputError(name_or_file, table.line_numbers[i],
                       "time goes backwards (" + std::to_string(row[0]) + " s after " +
                           std::to_string(table.rows[i - 1][0]) + " s)");
    }
    if (duration_s > 0.0 && row[0] - t0 > duration_s + 1e-9) break;
    if (!(row[0] - t0 <= kMaxRunSeconds)) {  // before the 1 kHz samples are allocated
      throw InputError(name_or_file, table.line_numbers[i],
                       "the trajectory spans more than " + fixed_seconds(kMaxRunSeconds) +
                           " (t = " + fixed_seconds(row[0]) + " after a start at " + fixed_seconds(t0) +
                           "); a run lasts at most that: cut it with --duration or split the file");
    }
    points.push_back({row[0] - t0, Vec3(row[1], row[2], row[3]), table.line_numbers[i]});
  }
  if (points.size() < 2 || points.back().t_s <= 0.0) {
    throw InputError(name_or_file, 0, "a trajectory needs at least two points spanning some time");
  }
  try {
    path.samples = motion::resample(points, kStreamRateHz);
  } catch (const std::invalid_argument& error) {
    throw InputError(name_or_file, 0, error.what());
  }
  return path;
}

void TimeScaling::ramp_to(double rate) {
  from_ = rate_;
  to_ = rate;
  elapsed_ = 0.0;
  if (std::abs(to_ - from_) < 1e-12) {
    ramp_.reset();
    return;
  }
  ramp_.emplace(std::abs(to_ - from_), limits_);
}

double TimeScaling::step(double dt_s) {
  const double used = rate_;
  if (ramp_) {
    elapsed_ += dt_s;
    const double s = ramp_->at(elapsed_).position / ramp_->distance();
    rate_ = from_ + (to_ - from_) * s;
    if (elapsed_ >= ramp_->duration()) {
      rate_ = to_;
      ramp_.reset();
    }
  }
  return 0.5 * (used + rate_);  // the trapezoid over the step
}

double TimeScaling::stopping_distance(double rate) const {
  if (rate <= 0.0) return 0.0;
  const motion::JerkLimitedProfile ramp(rate, limits_);
  // Symmetric rest-to-rest profile: the rate falls along rate - s(t); its integral is rate * T / 2.
  return rate * ramp.duration() / 2.0;
}

StreamPlan::StreamPlan(const Path& path, const Vec3& start_m, const StreamLimits& limits)
    : path_(path), limits_(limits) {
  if (path.samples.empty()) throw std::invalid_argument("an empty path");
  // The straight move to the path's first point, rest to rest.
  const Vec3 first = path.samples.front().position_m;
  const Vec3 delta = first - start_m;
  const double distance = delta.norm();
  approach_from_ = start_m;
  approach_delta_ = delta;
  if (distance > 1e-9) {
    approach_move_.emplace(distance, limits.approach);
    const motion::JerkLimitedProfile& move = *approach_move_;
    if (!(move.duration() <= kMaxRunSeconds)) {
      throw std::invalid_argument("the move to the start lasts more than " + fixed_seconds(kMaxRunSeconds));
    }
    const auto count = static_cast<std::size_t>(std::ceil(move.duration() * kStreamRateHz));
    for (std::size_t k = 1; k <= count; ++k) {
      position_.push_back(approach_at(static_cast<double>(k) * kDt));
      tau_.push_back(-1.0);
      rate_.push_back(0.0);
      line_.push_back(path.samples.front().source_line);
    }
  }
  approach_samples_ = position_.size();
  append_path(0.0, 0.0);
  capacity_ = position_.size() + kHoldReserveSamples;
  position_.reserve(capacity_);
  tau_.reserve(capacity_);
  rate_.reserve(capacity_);
  line_.reserve(capacity_);
}

void StreamPlan::append_path(double tau, double rate) {
  // The path, the rate ramping in and out so that it ends at rest at the end.
  TimeScaling scaling(limits_.rate);
  const double end = path_.duration_s();
  // Full speed if the ramps in and out fit in what is left of the path, else a lower top rate.
  double top = 1.0;
  while (top > 1e-3 && 2.0 * scaling.stopping_distance(top) > end - tau) top *= 0.8;
  scaling.set_rate(rate);
  scaling.ramp_to(top);
  const double stop_at = end - scaling.stopping_distance(top);
  final_ramp_ = ~std::size_t{0};
  bool stopping = false;
  for (;;) {
    std::size_t line = 0;
    position_.push_back(path_.at(tau, &line));
    tau_.push_back(tau);
    rate_.push_back(scaling.rate());
    line_.push_back(line);
    if (stopping && !scaling.ramping()) break;
    if (!stopping && tau >= stop_at && !scaling.ramping()) {
      final_ramp_ = position_.size();
      scaling.ramp_to(0.0);
      stopping = true;
    }
    tau = std::min(tau + scaling.step(kDt) * kDt, end);
    if (position_.size() > 100'000'000) throw std::invalid_argument("a plan beyond 1e8 samples");
  }
}

Vec3 StreamPlan::approach_at(double u) const {
  if (!approach_move_) return approach_from_;
  const double s = approach_move_->at(std::min(u, approach_move_->duration())).position / approach_move_->distance();
  return approach_from_ + s * approach_delta_;
}

bool StreamPlan::resumable() const {
  if (stopped_in_approach_) return false;
  if (position_.size() <= approach_samples_) return true;  // held at the path's start
  return rate_.back() == 0.0 && tau_.back() < path_.duration_s() - 1e-9;
}

std::size_t StreamPlan::resume() {
  if (!resumable()) return 0;
  const double tau = position_.size() <= approach_samples_ ? 0.0 : tau_.back();
  // Worst case: the rest of the path at the rate of the ramps' mean, plus both ramps.
  const TimeScaling probe(limits_.rate);
  const double ramp_s = 2.0 * probe.stopping_distance(1.0) + 1.0;
  const auto needed = static_cast<std::size_t>(std::ceil((path_.duration_s() - tau + 2.0 * ramp_s) * kStreamRateHz));
  if (position_.size() + needed > capacity_) return 0;
  if (position_.size() > approach_samples_) {
    // The last sample is the rest point; the resumed path starts from it (not repeated).
    position_.pop_back();
    tau_.pop_back();
    rate_.pop_back();
    line_.pop_back();
  }
  append_path(tau, 0.0);
  return position_.size();
}

std::size_t StreamPlan::cut(std::size_t k, bool stop_in_approach) {
  if (k >= position_.size()) return position_.size();
  if (k < approach_samples_ && stop_in_approach) {
    // The move's own time (sample j is at u = (j + 1) dt) ramps to rest from full rate.
    TimeScaling scaling(limits_.rate);
    scaling.set_rate(1.0);
    scaling.ramp_to(0.0);
    double u = static_cast<double>(k + 1) * kDt;
    std::size_t i = k;
    while (i < approach_samples_) {
      position_[i] = approach_at(u);
      ++i;
      if (!scaling.ramping()) break;
      u += scaling.step(kDt) * kDt;
    }
    position_.resize(i);
    tau_.resize(i);
    rate_.resize(i);
    line_.resize(i);
    final_ramp_ = ~std::size_t{0};
    stopped_in_approach_ = true;
    return i;
  }
  if (k < approach_samples_) {
    // In the straight move: finish it (rest to rest, already checked) and end there.
    position_.resize(approach_samples_);  // shrinking: no allocation
    tau_.resize(approach_samples_);
    rate_.resize(approach_samples_);
    line_.resize(approach_samples_);
    final_ramp_ = ~std::size_t{0};
    return position_.size();
  }
  if (k >= final_ramp_) return position_.size();  // already slowing down to the end
  // From the rate at k (a stop during the ramp in restarts the ramp from rest in its slope).
  TimeScaling scaling(limits_.rate);
  scaling.set_rate(rate_[k]);
  scaling.ramp_to(0.0);
  double tau = tau_[k];
  std::size_t i = k;
  const double end = path_.duration_s();
  while (i < position_.size()) {
    std::size_t line = 0;
    position_[i] = path_.at(tau, &line);
    tau_[i] = tau;
    rate_[i] = scaling.rate();
    line_[i] = line;
    ++i;
    if (!scaling.ramping()) break;
    tau = std::min(tau + scaling.step(kDt) * kDt, end);
  }
  position_.resize(i);
  tau_.resize(i);
  rate_.resize(i);
  line_.resize(i);
  return i;
}

std::vector<motion::TrajectoryPoint> StreamPlan::points() const {
  std::vector<motion::TrajectoryPoint> points(position_.size());
  for (std::size_t k = 0; k < position_.size(); ++k) {
    points[k] = {static_cast<double>(k) * kDt, position_[k], line_[k]};
  }
  return points;
}

std::vector<std::string> check_plan_all(const StreamPlan& plan, const std::string& source, const Vec3& trained_min_m,
                                        const Vec3& trained_max_m, const StreamLimits& limits,
                                        const nn::WeightsFile* model) {
  motion::TrajectoryLimits check;
  check.trained_min_m = trained_min_m;
  check.trained_max_m = trained_max_m;
  const JointTravel travel = joint_travel();
  check.joint_min_deg = travel.min_deg;
  check.joint_max_deg = travel.max_deg;
  check.joint_velocity_deg_s = limits.joint_velocity_deg_s;
  check.joint_acceleration_deg_s2 = limits.joint_acceleration_deg_s2;
  check.joint_jerk_deg_s3 = limits.joint_jerk_deg_s3;
  const std::vector<motion::TrajectoryPoint> points = plan.points();
  std::vector<motion::TrajectoryViolation> violations =
      motion::all_violations(points, kStreamRateHz, Geometry::nominal(), check);
  if (model != nullptr) {
    // What the network is asked: the setpoints as sent, shaped by a joint ripple table.
    std::vector<motion::TrajectoryPoint> shaped = points;
    bool any = false;
    for (auto& point : shaped) {
      const Vec3 sent = nn::shape_setpoint(*model, point.position_m);
      any = any || sent != point.position_m;
      point.position_m = sent;
    }
    if (any) {
      if (auto v = motion::box_violation(shaped, trained_min_m, trained_max_m,
                                         "the shaped setpoints (the model's joint ripple table) outside the "
                                         "network's trained range")) {
        violations.push_back(*v);
        std::stable_sort(violations.begin(), violations.end(),
                         [](const auto& a, const auto& b) { return a.sample < b.sample; });
      }
    }
    // The joints as the shaping moves them: the network's answer plus the table's entry at it
    // (N(shaped) = N(p) + r(N(p))), on top of the path's joints; checked when the path passes.
    if (violations.empty() && model->deployed() && !model->joint_ripple.empty()) {
      std::vector<Vec3> offsets(points.size(), Vec3::Zero());
      for (std::size_t k = 0; k < points.size(); ++k) {
        if (points[k].position_m.allFinite()) {
          offsets[k] = model->joint_ripple.at(model->network.evaluate(points[k].position_m));
        }
      }
      for (motion::TrajectoryViolation v :
           motion::all_violations(points, kStreamRateHz, Geometry::nominal(), check, &offsets)) {
        v.reason += " with the setpoints shaped by the model's joint ripple table";
        violations.push_back(v);
      }
    }
  }
  std::vector<std::string> out;
  for (const motion::TrajectoryViolation& violation : violations) {
    const std::size_t k = violation.sample;
    std::string where = source + (violation.source_line ? ":" + std::to_string(violation.source_line) : "") + ": ";
    std::string when = k < plan.approach_samples()
                           ? " (the move from the present pose to the start, sample " + std::to_string(k) + ")"
                           : " (path time " + std::to_string(plan.tau(k)) + " s, sample " + std::to_string(k) + ")";
    out.push_back(where + violation.reason + when);
  }
  return out;
}

std::optional<std::string> check_plan(const StreamPlan& plan, const std::string& source, const Vec3& trained_min_m,
                                      const Vec3& trained_max_m, const StreamLimits& limits,
                                      const nn::WeightsFile* model) {
  const std::vector<std::string> all = check_plan_all(plan, source, trained_min_m, trained_max_m, limits, model);
  if (all.empty()) return std::nullopt;
  return all.front();
}

JointTravel joint_travel() {
  const double count_deg = board::kEncoderCountDeg;
  return {static_cast<double>(board::kMinTravelBlock * 1024) * count_deg,
          static_cast<double>((board::kMaxTravelBlock + 1) * 1024 - 1) * count_deg};
}

}  // namespace delta::controller
