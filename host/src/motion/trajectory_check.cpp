// The whole trajectory checked before any motion (see trajectory_check.hpp).
#include "delta/motion/trajectory_check.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "delta/kinematics.hpp"

namespace delta::motion {
namespace {

std::string where(const TrajectoryPoint& point) {
  return point.source_line ? "line " + std::to_string(point.source_line) : "point at t = " + std::to_string(point.t_s);
}

std::string fixed(double value, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

}  // namespace

std::vector<TrajectoryPoint> resample(const std::vector<TrajectoryPoint>& points, double rate_hz) {
  if (points.size() < 2) throw std::invalid_argument("a trajectory needs at least two points");
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) throw std::invalid_argument("resampling rate must be > 0");
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i].t_s) || !points[i].position_m.allFinite()) {
      throw std::invalid_argument(where(points[i]) + ": not a finite number");
    }
    if (i > 0 && points[i].t_s < points[i - 1].t_s) {
      throw std::invalid_argument(where(points[i]) + ": time goes backwards (" + fixed(points[i].t_s, 6) + " s after " +
                                  fixed(points[i - 1].t_s, 6) + " s)");
    }
  }
  const double start = points.front().t_s, span = points.back().t_s - start;
  const auto count = static_cast<std::size_t>(std::floor(span * rate_hz + 1e-9)) + 1;
  std::vector<TrajectoryPoint> samples(count);
  std::size_t segment = 1;
  for (std::size_t k = 0; k < count; ++k) {
    const double t = start + static_cast<double>(k) / rate_hz;
    while (segment + 1 < points.size() && points[segment].t_s < t) ++segment;
    const TrajectoryPoint& a = points[segment - 1];
    const TrajectoryPoint& b = points[segment];
    const double interval = b.t_s - a.t_s;
    const double s = interval > 0.0 ? std::clamp((t - a.t_s) / interval, 0.0, 1.0) : 1.0;
    samples[k].t_s = t;
    samples[k].position_m = (1.0 - s) * a.position_m + s * b.position_m;
    samples[k].source_line = s <= 0.0 ? a.source_line : b.source_line;
  }
  return samples;
}

std::string box_text(const Vec3& min_m, const Vec3& max_m) {
  const char* axis = "xyz";
  std::string text;
  for (int i = 0; i < 3; ++i) {
    text += std::string(i ? ", " : "") + axis[i] + " " + fixed(min_m[i] * 1e3, 3) + " .. " + fixed(max_m[i] * 1e3, 3);
  }
  return text + " mm";
}

std::optional<TrajectoryViolation> box_violation(const std::vector<TrajectoryPoint>& samples, const Vec3& min_m,
                                                 const Vec3& max_m, const std::string& what) {
  // Per axis and side: the first sample beyond it and the farthest value.
  struct Side {
    std::optional<std::size_t> first;
    double extreme = 0.0;
  };
  Side low[3], high[3];
  std::optional<std::size_t> first;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const Vec3& p = samples[k].position_m;
    for (int i = 0; i < 3; ++i) {
      Side* side = p[i] < min_m[i] ? &low[i] : p[i] > max_m[i] ? &high[i] : nullptr;
      if (side == nullptr) continue;
      if (!side->first) {
        side->first = k;
        side->extreme = p[i];
      }
      side->extreme = side == &low[i] ? std::min(side->extreme, p[i]) : std::max(side->extreme, p[i]);
      if (!first) first = k;
    }
  }
  if (!first) return std::nullopt;
  const char* axis = "xyz";
  std::string reason = what + ":";
  bool any = false;
  for (int i = 0; i < 3; ++i) {
    for (const Side* side : {&low[i], &high[i]}) {
      if (!side->first) continue;
      reason += std::string(any ? "," : "") + " " + axis[i] + " reaches " + fixed(side->extreme * 1e3, 3) + " mm (" +
                (side == &low[i] ? "below " : "above ") + fixed((side == &low[i] ? min_m[i] : max_m[i]) * 1e3, 3) +
                ", from " + where(samples[*side->first]) + ")";
      any = true;
    }
  }
  reason += "; the box " + box_text(min_m, max_m);
  return TrajectoryViolation{*first, samples[*first].t_s, samples[*first].source_line, reason};
}

std::vector<TrajectoryViolation> all_violations(const std::vector<TrajectoryPoint>& samples, double rate_hz,
                                                const Geometry& geometry, const TrajectoryLimits& limits,
                                                const std::vector<Vec3>* joint_offsets_deg) {
  // The first violation of each kind, by kind: unreachable, the box, then per joint travel,
  // velocity, acceleration, jerk.
  constexpr int kUnreachable = 0, kBox = 1, kTravel = 2, kDerivatives = 5;  // travel 2..4, then 3 x 3
  std::vector<std::optional<TrajectoryViolation>> first(kDerivatives + 9);
  auto note = [&](int kind, std::size_t k, const std::string& reason) {
    if (!first[static_cast<std::size_t>(kind)]) {
      first[static_cast<std::size_t>(kind)] = TrajectoryViolation{k, samples[k].t_s, samples[k].source_line, reason};
    }
  };
  std::vector<Vec3> alpha(samples.size());
  std::vector<bool> solved(samples.size(), false);
  // Backward differences at the rate: velocity from k-1, acceleration from k-2, jerk from k-3.
  struct Derivative {
    int order;
    double limit;
    const char* name;
    const char* unit;
  };
  const Derivative derivatives[] = {{1, limits.joint_velocity_deg_s, "velocity", "deg/s"},
                                    {2, limits.joint_acceleration_deg_s2, "acceleration", "deg/s^2"},
                                    {3, limits.joint_jerk_deg_s3, "jerk", "deg/s^3"}};
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const Vec3& p = samples[k].position_m;
    if (!p.allFinite()) {
      note(kUnreachable, k, "not a finite position");
      continue;
    }
    IkSolution ik = inverse_kinematics(geometry, p);
    if (!ik.ok()) {
      note(kUnreachable, k, "unreachable: " + ik.reason());
      continue;
    }
    if (joint_offsets_deg != nullptr && k < joint_offsets_deg->size()) ik.alpha_deg += (*joint_offsets_deg)[k];
    for (int j = 0; j < 3; ++j) {
      if (ik.alpha_deg[j] < limits.joint_min_deg || ik.alpha_deg[j] > limits.joint_max_deg) {
        note(kTravel + j, k,
             "joint " + std::to_string(j + 1) + " at " + fixed(ik.alpha_deg[j], 3) + " deg, outside the travel " +
                 fixed(limits.joint_min_deg, 2) + " .. " + fixed(limits.joint_max_deg, 2) + " deg");
      }
    }
    alpha[k] = ik.alpha_deg;
    solved[k] = true;
    for (int d = 0; d < 3; ++d) {
      const Derivative& derivative = derivatives[d];
      const auto order = static_cast<std::size_t>(derivative.order);
      if (k < order) continue;
      bool known = true;
      for (std::size_t back = 1; back <= order; ++back) known = known && solved[k - back];
      if (!known) continue;
      Vec3 difference = alpha[k];
      if (order == 1) difference -= alpha[k - 1];
      if (order == 2) difference += alpha[k - 2] - 2.0 * alpha[k - 1];
      if (order == 3) difference += 3.0 * alpha[k - 2] - 3.0 * alpha[k - 1] - alpha[k - 3];
      const Vec3 value = difference * std::pow(rate_hz, derivative.order);
      for (int j = 0; j < 3; ++j) {
        if (std::abs(value[j]) > derivative.limit) {
          note(kDerivatives + 3 * j + d, k,
               "joint " + std::to_string(j + 1) + " " + derivative.name + " " + fixed(std::abs(value[j]), 1) + " " +
                   derivative.unit + " above the limit " + fixed(derivative.limit, 1) + " " + derivative.unit);
        }
      }
    }
  }
  // The box (a non-finite position compares inside: it is named above).
  first[kBox] = box_violation(samples, limits.trained_min_m, limits.trained_max_m,
                              "outside the network's trained range (the allowed box)");
  std::vector<TrajectoryViolation> out;
  for (const auto& v : first) {
    if (v) out.push_back(*v);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const TrajectoryViolation& a, const TrajectoryViolation& b) { return a.sample < b.sample; });
  return out;
}

std::optional<TrajectoryViolation> first_violation(const std::vector<TrajectoryPoint>& samples, double rate_hz,
                                                   const Geometry& geometry, const TrajectoryLimits& limits,
                                                   const std::vector<Vec3>* joint_offsets_deg) {
  const std::vector<TrajectoryViolation> all = all_violations(samples, rate_hz, geometry, limits, joint_offsets_deg);
  if (all.empty()) return std::nullopt;
  return all.front();
}

}  // namespace delta::motion
