// The whole trajectory checked before any motion (see trajectory_check.hpp).
#include "delta/motion/trajectory_check.hpp"

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

std::optional<TrajectoryViolation> first_violation(const std::vector<TrajectoryPoint>& samples, double rate_hz,
                                                   const Geometry& geometry, const TrajectoryLimits& limits) {
  std::vector<Vec3> alpha(samples.size());
  auto violation = [&](std::size_t k, const std::string& reason) {
    return TrajectoryViolation{k, samples[k].t_s, samples[k].source_line, reason};
  };
  const char* axis = "xyz";
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
    if (!p.allFinite()) return violation(k, "not a finite position");
    const IkSolution ik = inverse_kinematics(geometry, p);
    if (!ik.ok()) return violation(k, "unreachable: " + ik.reason());
    for (int i = 0; i < 3; ++i) {
      if (p[i] < limits.trained_min_m[i] || p[i] > limits.trained_max_m[i]) {
        return violation(k, std::string("outside the network's trained range: ") + axis[i] + " = " +
                                fixed(p[i] * 1e3, 3) + " mm, trained " + fixed(limits.trained_min_m[i] * 1e3, 3) +
                                " .. " + fixed(limits.trained_max_m[i] * 1e3, 3) + " mm");
      }
    }
    for (int j = 0; j < 3; ++j) {
      if (ik.alpha_deg[j] < limits.joint_min_deg || ik.alpha_deg[j] > limits.joint_max_deg) {
        return violation(k, "joint " + std::to_string(j + 1) + " at " + fixed(ik.alpha_deg[j], 3) +
                                " deg, outside the travel " + fixed(limits.joint_min_deg, 2) + " .. " +
                                fixed(limits.joint_max_deg, 2) + " deg");
      }
    }
    alpha[k] = ik.alpha_deg;
    for (const Derivative& d : derivatives) {
      if (k < static_cast<std::size_t>(d.order)) continue;
      Vec3 difference = alpha[k];
      if (d.order == 1) difference -= alpha[k - 1];
      if (d.order == 2) difference += alpha[k - 2] - 2.0 * alpha[k - 1];
      if (d.order == 3) difference += 3.0 * alpha[k - 2] - 3.0 * alpha[k - 1] - alpha[k - 3];
      const Vec3 value = difference * std::pow(rate_hz, d.order);
      for (int j = 0; j < 3; ++j) {
        if (std::abs(value[j]) > d.limit) {
          return violation(k, "joint " + std::to_string(j + 1) + " " + d.name + " " + fixed(std::abs(value[j]), 1) +
                                  " " + d.unit + " above the limit " + fixed(d.limit, 1) + " " + d.unit);
        }
      }
    }
  }
  return std::nullopt;
}

}  // namespace delta::motion
