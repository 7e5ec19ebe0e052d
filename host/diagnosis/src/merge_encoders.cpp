// Merging, the encoders' plate (merge_phases.hpp): the angles behind the readings, their nominal
// plate, each joint's direction of play and the rows where a joint may sit inside its play.
#include <algorithm>
#include <cmath>
#include <limits>

#include "delta/board_facts.hpp"
#include "delta/kinematics.hpp"

#include "closed_loop.hpp"
#include "merge_phases.hpp"

namespace delta::diagnosis::merging {

namespace {
constexpr double kTurnedCounts = 0.1;  // of a count, an arm falling back inside its play
}  // namespace

EncoderPlate encoder_plate(const std::vector<double>& run_t, const std::vector<Vec3>& run_alpha_deg,
                           const Geometry& nominal) {
  EncoderPlate plate;
  const std::size_t n = run_t.size();
  // Closed-loop telemetry: the angle behind each reading is the reading less the lead the
  // controller holds it at (closed_loop.hpp), not one interpolated between crossings.
  const closed_loop::Readings readings = closed_loop::read_closed_loop(run_t, run_alpha_deg, kEncoderResolutionDeg);
  plate.closed_loop = readings.closed_loop;
  plate.alpha_deg = readings.closed_loop ? readings.angle_deg : dequantise(run_t, run_alpha_deg);
  plate.position_m.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const FkSolution fk = forward_kinematics(nominal, plate.alpha_deg[i]);
    plate.position_m[i] = fk.ok() ? fk.position_m : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  plate.direction.resize(n);
  std::array<double, 3> d{0, 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) {
      for (int j = 0; j < 3; ++j) {
        const double step = run_alpha_deg[i][j] - run_alpha_deg[i - 1][j];
        if (step != 0.0) d[j] = step > 0 ? 1.0 : -1.0;
      }
    }
    plate.direction[i] = d;
  }
  plate.play_band = in_play(run_alpha_deg);
  return plate;
}

std::vector<Vec3> dequantise(const std::vector<double>& t, const std::vector<Vec3>& alpha_deg) {
  std::vector<Vec3> out = alpha_deg;
  const std::size_t n = t.size();
  for (int j = 0; j < 3; ++j) {
    std::size_t previous = 0;  // the sample after the previous crossing (0: none yet)
    for (std::size_t i = 1; i <= n; ++i) {
      if (i < n && alpha_deg[i][j] == alpha_deg[i - 1][j]) continue;
      // A crossing between samples i - 1 and i (or the end): the samples [previous, i) hold.
      if (previous > 0 && i < n) {
        const double t0 = 0.5 * (t[previous - 1] + t[previous]), t1 = 0.5 * (t[i - 1] + t[i]);
        const double v0 = 0.5 * (alpha_deg[previous - 1][j] + alpha_deg[previous][j]);
        const double v1 = 0.5 * (alpha_deg[i - 1][j] + alpha_deg[i][j]);
        const double held = alpha_deg[previous][j];
        const bool same_way = (held - alpha_deg[previous - 1][j] > 0) == (alpha_deg[i][j] - held > 0);
        for (std::size_t k = previous; k < i; ++k) {
          out[k][j] = same_way && t1 > t0 ? v0 + (v1 - v0) * (t[k] - t0) / (t1 - t0) : 0.5 * (v0 + held);
        }
      }
      previous = i;
    }
  }
  return out;
}

std::vector<bool> in_play(const std::vector<Vec3>& alpha_deg) {
  const std::size_t n = alpha_deg.size();
  std::vector<bool> marked(n, false);
  for (int j = 0; j < 3; ++j) {
    std::size_t start = 0;  // the hold's first row
    double before = 0.0;    // the direction of the move into it (0: none yet)
    for (std::size_t i = 1; i < n; ++i) {
      const double step = alpha_deg[i][j] - alpha_deg[i - 1][j];
      if (step == 0.0) continue;
      const double after = step > 0 ? 1.0 : -1.0;
      if (before != after)
        std::fill(marked.begin() + static_cast<std::ptrdiff_t>(start), marked.begin() + static_cast<std::ptrdiff_t>(i),
                  true);
      before = after;
      start = i;
    }
    std::fill(marked.begin() + static_cast<std::ptrdiff_t>(start), marked.end(), true);
  }
  if (static_cast<std::size_t>(std::count(marked.begin(), marked.end(), false)) < n / 3) marked.assign(n, false);
  return marked;
}

bool StageCurve::at(double tau, Vec3* position, Vec3* velocity) const {
  if (!(tau >= t_.front() && tau <= t_.back())) return false;
  std::size_t k = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), tau) - t_.begin());
  k = k == 0 ? 0 : k - 1;
  if (k + 1 >= t_.size()) k = t_.size() - 2;
  const double h = t_[k + 1] - t_[k];
  if (h > max_gap_) return false;
  const Vec3 m0 = slope(k), m1 = slope(k + 1);
  const double s = (tau - t_[k]) / h, s2 = s * s, s3 = s2 * s;
  *position =
      (2 * s3 - 3 * s2 + 1) * p_[k] + (s3 - 2 * s2 + s) * h * m0 + (-2 * s3 + 3 * s2) * p_[k + 1] + (s3 - s2) * h * m1;
  if (velocity) {
    *velocity = ((6 * s2 - 6 * s) * p_[k] + (-6 * s2 + 6 * s) * p_[k + 1]) / h + (3 * s2 - 4 * s + 1) * m0 +
                (3 * s2 - 2 * s) * m1;
  }
  return true;
}

std::vector<bool> turned_inside_play(const std::vector<double>& t, const std::vector<Vec3>& alpha_deg,
                                     const StageCurve& curve, double offset, double rate, const Affine& affine,
                                     const Geometry& geometry) {
  const std::size_t n = t.size();
  std::vector<bool> marked(n, false);
  const Eigen::Matrix3d back = affine.a.inverse();
  if (!back.allFinite()) return marked;
  std::vector<Vec3> arm(n, Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 s;
    if (!curve.at(offset + (1 + rate) * t[i], &s, nullptr)) continue;
    const IkSolution ik = inverse_kinematics(geometry, Vec3(affine.run_mean + back * (s - affine.b)));
    if (ik.ok()) arm[i] = ik.alpha_deg;
  }
  for (int j = 0; j < 3; ++j) {
    const double tolerance = kTurnedCounts * kEncoderResolutionDeg;
    std::size_t start = 0;  // the hold's first row
    double way = 0.0, furthest = std::numeric_limits<double>::quiet_NaN();
    bool turned = false;
    auto close = [&](std::size_t end) {
      if (turned) {
        std::fill(marked.begin() + static_cast<std::ptrdiff_t>(start),
                  marked.begin() + static_cast<std::ptrdiff_t>(end), true);
      }
    };
    for (std::size_t i = 0; i < n; ++i) {
      const double step = i > 0 ? alpha_deg[i][j] - alpha_deg[i - 1][j] : 0.0;
      if (step != 0.0) {
        close(i);
        start = i;
        turned = false;
        way = step > 0 ? 1.0 : -1.0;
        furthest = way * arm[i][j];
        continue;
      }
      if (way == 0.0 || !std::isfinite(arm[i][j])) continue;
      const double along = way * arm[i][j];
      if (!std::isfinite(furthest) || along > furthest) furthest = along;
      if (furthest - along > tolerance) turned = true;
    }
    close(n);
  }
  return marked;
}

}  // namespace delta::diagnosis::merging
