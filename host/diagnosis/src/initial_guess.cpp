// Starting values of an added family: backlash from the falling/rising jump, transmission error
// from a periodogram of the residual against the angle.
#include "initial_guess.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

namespace delta::diagnosis {
namespace {

struct SineFit {
  double amplitude = 0.0, phase = 0.0;
  double removed = 0.0;  // the residual sum of squares the sine removes
};

// Least squares of A sin(2 pi angle / period + phase) to `residual`
// (A sin(w + phi) = A cos(phi) sin(w) + A sin(phi) cos(w)).
SineFit fit_sine(const std::vector<double>& angle, const std::vector<double>& residual, double period) {
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Vector2d right = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < angle.size(); ++i) {
    const double w = 2.0 * kPi * angle[i] / period;
    const Eigen::Vector2d basis(std::cos(w), std::sin(w));
    normal += basis * basis.transpose();
    right += residual[i] * basis;
  }
  const Eigen::Vector2d c = normal.ldlt().solve(right);
  return {std::hypot(c[0], c[1]), std::atan2(c[0], c[1]), c.dot(right)};
}

}  // namespace

Parameters initial_guess(Family family, const Parameters& theta, const std::vector<Sample>& rows,
                         const std::vector<Vec3>& predicted, bool long_period) {
  Parameters start = theta;
  if (family == Family::backlash) {
    for (int j = 0; j < 3; ++j) {
      double rising = 0.0, falling = 0.0;
      std::size_t rising_count = 0, falling_count = 0;
      for (std::size_t i = 1; i < rows.size(); ++i) {
        const double motion = predicted[i][j] - predicted[i - 1][j];
        const double residual = rows[i].alpha_deg[j] - predicted[i][j];
        if (motion > 1e-6) {
          rising += residual;
          ++rising_count;
        } else if (motion < -1e-6) {
          falling += residual;
          ++falling_count;
        }
      }
      double width = 0.0;
      if (rising_count && falling_count) width = falling / falling_count - rising / rising_count;
      start[slot::backlash + j] = std::max(width, 0.0);
    }
  } else if (family == Family::transmission_error) {
    const std::size_t stride = std::max<std::size_t>(1, rows.size() / 3000);
    for (int j = 0; j < 3; ++j) {
      std::vector<double> angle, residual;
      double low = 1e9, high = -1e9;
      for (std::size_t i = 0; i < rows.size(); i += stride) {
        angle.push_back(predicted[i][j]);
        residual.push_back(rows[i].alpha_deg[j] - predicted[i][j]);
        low = std::min(low, predicted[i][j]);
        high = std::max(high, predicted[i][j]);
      }
      const double range = std::max(high - low, 1e-3);
      const double centre = 0.5 * (high + low);
      const int m = static_cast<int>(angle.size());
      const std::vector<double> raw = residual;
      // Remove a quadratic trend in the angle once (what offsets, scales and geometry leave).
      Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
      Eigen::Vector3d right = Eigen::Vector3d::Zero();
      for (int i = 0; i < m; ++i) {
        const double u = (angle[i] - centre) / range;
        const Eigen::Vector3d basis(1.0, u, u * u);
        normal += basis * basis.transpose();
        right += residual[i] * basis;
      }
      const Eigen::Vector3d trend = normal.ldlt().solve(right);
      for (int i = 0; i < m; ++i) {
        const double u = (angle[i] - centre) / range;
        residual[i] -= trend.dot(Eigen::Vector3d(1.0, u, u * u));
      }
      // Spatial frequencies from a quarter cycle over the range to periods of 0.1 deg, spaced a
      // quarter cycle over the range apart (neighbours differ in phase by at most 90 deg).
      double best_power = -1.0, best_period = 360.0, best_amplitude = 0.0, best_phase = 0.0;
      for (double cycles = 0.25; cycles <= range / 0.1; cycles += 0.25) {
        const double period = range / cycles;
        const SineFit sine = fit_sine(angle, residual, period);
        if (sine.removed > best_power) {
          best_power = sine.removed;
          best_period = period;
          best_amplitude = sine.amplitude;
          best_phase = sine.phase;
        }
      }
      // Periods much longer than the range look like a trend and vanish with it: the long-period
      // start fits them to the residual as it is (a once-per-revolution ripple, P = 360 deg).
      double total = 0.0;
      for (int i = 0; i < m; ++i) total += raw[i] * raw[i];
      double best_sse = 1e300;
      for (double period : {2.0 * range, 4.0 * range, 8.0 * range, 90.0, 180.0, 360.0}) {
        if (!long_period) break;
        const SineFit sine = fit_sine(angle, raw, period);
        const double sse = total - sine.removed;
        if (sse < best_sse) {
          best_sse = sse;
          best_period = period;
          best_amplitude = sine.amplitude;
          best_phase = sine.phase;
        }
      }
      start[slot::amplitude + j] = best_amplitude;
      start[slot::period + j] = best_period;
      start[slot::phase + j] = best_phase;
    }
  }
  return start;
}

Parameters ripple_start_at(const Parameters& theta, const std::vector<Sample>& rows, const std::vector<Vec3>& predicted,
                           const Vec3& period_deg) {
  Parameters start = theta;
  const std::size_t stride = std::max<std::size_t>(1, rows.size() / 3000);
  for (int j = 0; j < 3; ++j) {
    std::vector<double> angle, residual;
    for (std::size_t i = 0; i < rows.size(); i += stride) {
      angle.push_back(predicted[i][j]);
      residual.push_back(rows[i].alpha_deg[j] - predicted[i][j]);
    }
    const SineFit sine = fit_sine(angle, residual, period_deg[j]);
    start[slot::amplitude + j] = sine.amplitude;
    start[slot::period + j] = period_deg[j];
    start[slot::phase + j] = sine.phase;
  }
  return start;
}

}  // namespace delta::diagnosis
