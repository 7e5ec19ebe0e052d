// Merging a run with the measuring stage's log: clocks aligned from the data (see merge.hpp).
#include "delta/diagnosis/merge.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Dense>

#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"

namespace delta::diagnosis {
namespace {

constexpr double kCoarseBinS = 0.5;
constexpr double kFineBinS = 0.05;
constexpr double kBlockS = 2.0;             // residual blocks for the covariance
constexpr std::size_t kMaxFitRows = 40000;  // rows of the fine fit (evenly thinned)
constexpr int kMonomials = 20;              // 1, x, y, z, their products up to the third degree
constexpr double kMonomialScaleM = 0.01;    // the monomials' unit: 10 mm
constexpr double kKnotDeg = 1.25;           // the joint splines' knot spacing
constexpr double kPlayMarginDeg = 1.0;      // the largest play taken out of a reading
constexpr double kMinCorrelation = 0.9;
constexpr double kPeakTie = 0.01;  // correlation peaks this close are told apart by their overlap
constexpr double kMaxResidualM = 0.2e-3;
constexpr double kMaxResidualOfMotion = 0.2;
constexpr double kRestM = 5e-6;    // stage motion RMS below this: at rest
constexpr double kRestDeg = 0.05;  // every joint's span below this: at rest
constexpr double kMinOverlapS = 10.0;

// Plate positions averaged on absolute bins [k dt, (k + 1) dt).
struct Binned {
  std::int64_t first = 0;  // index of bin 0
  std::vector<Vec3> mean;
  std::vector<int> count;
  std::size_t valid = 0;
};

Binned bin(const std::vector<double>& t, const std::vector<Vec3>& p, double dt) {
  Binned b;
  b.first = static_cast<std::int64_t>(std::floor(t.front() / dt));
  const auto last = static_cast<std::int64_t>(std::floor(t.back() / dt));
  b.mean.assign(static_cast<std::size_t>(last - b.first + 1), Vec3::Zero());
  b.count.assign(b.mean.size(), 0);
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(p[i][0])) continue;
    const auto k = static_cast<std::size_t>(static_cast<std::int64_t>(std::floor(t[i] / dt)) - b.first);
    b.mean[k] += p[i];
    ++b.count[k];
  }
  for (std::size_t k = 0; k < b.mean.size(); ++k) {
    if (b.count[k] > 0) {
      b.mean[k] /= b.count[k];
      ++b.valid;
    }
  }
  return b;
}

struct Correlation {
  double r = -2.0;
  std::size_t n = 0;
};

// Pearson correlation of the run's bins against the stage's bins lag bins later (tau = t + lag dt),
// the three axes pooled, over the run's bins in [from, to).
Correlation correlate(const Binned& run, const Binned& stage, std::int64_t lag, std::size_t from, std::size_t to) {
  double n = 0;
  Vec3 sx = Vec3::Zero(), sy = Vec3::Zero(), sxx = Vec3::Zero(), syy = Vec3::Zero(), sxy = Vec3::Zero();
  const std::int64_t shift = run.first + lag - stage.first;
  const std::int64_t k0 = std::max<std::int64_t>(static_cast<std::int64_t>(from), -shift);
  const std::int64_t k1 =
      std::min<std::int64_t>(static_cast<std::int64_t>(to), static_cast<std::int64_t>(stage.mean.size()) - shift);
  for (std::int64_t k = k0; k < k1; ++k) {
    const auto kr = static_cast<std::size_t>(k);
    const auto ks = static_cast<std::size_t>(k + shift);
    if (run.count[kr] == 0 || stage.count[ks] == 0) continue;
    const Vec3& x = run.mean[kr];
    const Vec3& y = stage.mean[ks];
    n += 1;
    sx += x;
    sy += y;
    sxx += x.cwiseProduct(x);
    syy += y.cwiseProduct(y);
    sxy += x.cwiseProduct(y);
  }
  Correlation c;
  c.n = static_cast<std::size_t>(n);
  if (n < 3) return c;
  const double cov = (sxy - sx.cwiseProduct(sy) / n).sum();
  const double vx = (sxx - sx.cwiseProduct(sx) / n).sum();
  const double vy = (syy - sy.cwiseProduct(sy) / n).sum();
  c.r = vx > 0 && vy > 0 ? cov / std::sqrt(vx * vy) : -2.0;
  return c;
}

// The best lag in [lo, hi] with at least min_n overlapping bins; its sub-bin refinement (a parabola
// through the neighbours) in *fraction. prefer_overlap: of the peaks within kPeakTie of the best
// correlation, the one that overlaps most. A trajectory that repeats itself (the validation run:
// x and y repeat every 133 s, z a slow ramp that the unknown geometry's offset hides) correlates
// almost as well one period off, over a shorter overlap; the logs' ends (the rest before the drag)
// tell the periods apart.
Correlation best_lag(const Binned& run, const Binned& stage, std::int64_t lo, std::int64_t hi, std::size_t from,
                     std::size_t to, std::size_t min_n, std::int64_t* lag, double* fraction,
                     bool prefer_overlap = false) {
  Correlation best;
  std::vector<double> r(static_cast<std::size_t>(hi - lo + 1), -2.0);
  std::vector<std::size_t> overlap(r.size(), 0);
  for (std::int64_t l = lo; l <= hi; ++l) {
    const Correlation c = correlate(run, stage, l, from, to);
    if (c.n < min_n) continue;
    r[static_cast<std::size_t>(l - lo)] = c.r;
    overlap[static_cast<std::size_t>(l - lo)] = c.n;
    if (c.r > best.r) {
      best = c;
      *lag = l;
    }
  }
  if (prefer_overlap && best.r > -2.0) {
    for (std::size_t k = 0; k < r.size(); ++k) {
      const bool peak = (k == 0 || r[k] >= r[k - 1]) && (k + 1 == r.size() || r[k] >= r[k + 1]);
      if (peak && r[k] >= best.r - kPeakTie && overlap[k] > best.n) {
        best.r = r[k];
        best.n = overlap[k];
        *lag = lo + static_cast<std::int64_t>(k);
      }
    }
  }
  *fraction = 0.0;
  if (best.r > -2.0 && *lag > lo && *lag < hi) {
    const double a = r[static_cast<std::size_t>(*lag - lo - 1)], b = best.r,
                 c = r[static_cast<std::size_t>(*lag - lo + 1)];
    const double d = a - 2 * b + c;
    if (a > -2.0 && c > -2.0 && d < 0) *fraction = std::clamp(0.5 * (a - c) / d, -0.5, 0.5);
  }
  return best;
}

// The stage log, interpolated (cubic Hermite, Catmull-Rom slopes) where its samples are no further
// apart than 3 x their median spacing.
class StageCurve {
 public:
  StageCurve(const std::vector<double>& t, const std::vector<Vec3>& p) : t_(t), p_(p) {
    std::vector<double> gaps(t.size() - 1);
    for (std::size_t i = 0; i + 1 < t.size(); ++i) gaps[i] = t[i + 1] - t[i];
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    max_gap_ = 3.0 * gaps[gaps.size() / 2];
  }
  double first() const { return t_.front(); }
  double last() const { return t_.back(); }
  // False outside the log or across a gap.
  bool at(double tau, Vec3* position, Vec3* velocity) const {
    if (!(tau >= t_.front() && tau <= t_.back())) return false;
    std::size_t k = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), tau) - t_.begin());
    k = k == 0 ? 0 : k - 1;
    if (k + 1 >= t_.size()) k = t_.size() - 2;
    const double h = t_[k + 1] - t_[k];
    if (h > max_gap_) return false;
    const Vec3 m0 = slope(k), m1 = slope(k + 1);
    const double s = (tau - t_[k]) / h, s2 = s * s, s3 = s2 * s;
    *position = (2 * s3 - 3 * s2 + 1) * p_[k] + (s3 - 2 * s2 + s) * h * m0 + (-2 * s3 + 3 * s2) * p_[k + 1] +
                (s3 - s2) * h * m1;
    if (velocity) {
      *velocity = ((6 * s2 - 6 * s) * p_[k] + (-6 * s2 + 6 * s) * p_[k + 1]) / h + (3 * s2 - 4 * s + 1) * m0 +
                  (3 * s2 - 2 * s) * m1;
    }
    return true;
  }

 private:
  Vec3 slope(std::size_t k) const {
    const std::size_t a = k == 0 ? 0 : k - 1, b = std::min(k + 1, t_.size() - 1);
    return (p_[b] - p_[a]) / (t_[b] - t_[a]);
  }
  const std::vector<double>& t_;
  const std::vector<Vec3>& p_;
  double max_gap_ = 0.0;
};

// Rows where a joint may sit inside its play, its reading telling nothing of the plate's motion:
// from a reversal of the joint's true motion until the encoder follows again. Seen from the
// encoders, a hold (the reading unchanged) that the joint does not enter and leave moving the same
// way: a reversal, the hold before the first move, the hold at the end. Left in, the play's dead
// band reads as a lag (the encoders stand still while the stage moves on) and biases the clock
// offset by tens of milliseconds. Nothing is marked when that would leave less than a third of the
// rows (a closed loop dithering by a count: every hold is a reversal).
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

[[noreturn]] void refuse(const std::string& path, const std::string& reason) { throw InputError(path, 0, reason); }

std::string fixed3(double value) {
  char text[64];
  std::snprintf(text, sizeof text, "%.3f", value);
  return text;
}

}  // namespace

MergeResult merge_logs(const std::string& run_path, const std::vector<double>& run_t,
                       const std::vector<Vec3>& run_alpha_deg, const std::string& stage_path,
                       const std::vector<double>& stage_t, const std::vector<Vec3>& stage_m) {
  MergeResult out;
  out.run_rows = run_t.size();
  out.stage_rows = stage_t.size();
  if (run_t.size() < 100) refuse(run_path, "has " + std::to_string(run_t.size()) + " rows; a merge needs at least 100");
  if (stage_t.size() < 100) {
    refuse(stage_path, "has " + std::to_string(stage_t.size()) + " rows; a merge needs at least 100");
  }
  // ---- at rest? ----
  {
    Vec3 lo = run_alpha_deg.front(), hi = lo;
    for (const Vec3& a : run_alpha_deg) {
      lo = lo.cwiseMin(a);
      hi = hi.cwiseMax(a);
    }
    if ((hi - lo).maxCoeff() < kRestDeg) {
      refuse(run_path, "the robot is at rest (every joint within " + fixed3(kRestDeg) +
                           " deg): a merge needs motion to align the clocks");
    }
    Vec3 mean = Vec3::Zero();
    for (const Vec3& p : stage_m) mean += p;
    mean /= static_cast<double>(stage_m.size());
    double ss = 0;
    for (const Vec3& p : stage_m) ss += (p - mean).squaredNorm();
    if (std::sqrt(ss / (3.0 * stage_m.size())) < kRestM) {
      refuse(stage_path, "the plate is at rest (motion below 5 um RMS): a merge needs motion to align the clocks");
    }
  }
  // ---- the encoders' plate (nominal FK), its Jacobian and each joint's direction of play ----
  const Geometry nominal = Geometry::nominal();
  const std::size_t n = run_t.size();
  std::vector<Vec3> p_enc(n);
  for (std::size_t i = 0; i < n; ++i) {
    const FkSolution fk = forward_kinematics(nominal, run_alpha_deg[i]);
    p_enc[i] = fk.ok() ? fk.position_m : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  }

  // ---- coarse alignment: 0.5 s bins over every lag, then 50 ms bins ----
  const Binned run_c = bin(run_t, p_enc, kCoarseBinS), stage_c = bin(stage_t, stage_m, kCoarseBinS);
  const std::size_t min_c = std::max<std::size_t>(static_cast<std::size_t>(kMinOverlapS / kCoarseBinS),
                                                  std::min(run_c.valid, stage_c.valid) / 2);
  const std::int64_t lo_c = stage_c.first - run_c.first - static_cast<std::int64_t>(run_c.mean.size());
  const std::int64_t hi_c = stage_c.first + static_cast<std::int64_t>(stage_c.mean.size()) - run_c.first;
  std::int64_t lag_c = 0;
  double frac = 0.0;
  const Correlation coarse = best_lag(run_c, stage_c, lo_c, hi_c, 0, run_c.mean.size(), min_c, &lag_c, &frac, true);
  if (coarse.r <= -2.0) {
    refuse(stage_path, "does not overlap " + run_path + " by " + fixed3(min_c * kCoarseBinS) +
                           " s at any clock offset (the logs must share at least half the shorter one)");
  }
  out.correlation = coarse.r;
  if (coarse.r < kMinCorrelation) {
    refuse(stage_path, "no clock offset makes its plate path agree with " + run_path + "'s (correlation at most " +
                           fixed3(coarse.r) + ", below " + fixed3(kMinCorrelation) +
                           "): the logs do not overlap, or do not belong together");
  }
  const Binned run_f = bin(run_t, p_enc, kFineBinS), stage_f = bin(stage_t, stage_m, kFineBinS);
  const double ratio = kCoarseBinS / kFineBinS;
  const auto centre_f = static_cast<std::int64_t>(std::llround(lag_c * ratio));
  const std::int64_t span_f = static_cast<std::int64_t>(2 * ratio);
  const std::size_t min_f = min_c * static_cast<std::size_t>(ratio) / 2;
  std::int64_t lag_f = centre_f;
  best_lag(run_f, stage_f, centre_f - span_f, centre_f + span_f, 0, run_f.mean.size(), min_f, &lag_f, &frac);
  double offset = (static_cast<double>(lag_f) + frac) * kFineBinS;  // tau - t
  double rate = 0.0;
  {  // the first and last thirds: a first rate
    const std::size_t third = run_f.mean.size() / 3;
    double lag[2], when[2];
    bool ok = third > 40;
    for (int part = 0; part < 2 && ok; ++part) {
      const std::size_t from = part == 0 ? 0 : run_f.mean.size() - third, to = from + third;
      std::int64_t l = lag_f;
      double fr = 0.0;
      const Correlation c = best_lag(run_f, stage_f, lag_f - 12, lag_f + 12, from, to, third / 2, &l, &fr);
      ok = c.r >= kMinCorrelation;
      lag[part] = (static_cast<double>(l) + fr) * kFineBinS;
      when[part] = (static_cast<double>(run_f.first) + 0.5 * static_cast<double>(from + to)) * kFineBinS;
    }
    if (ok) {
      rate = (lag[1] - lag[0]) / (when[1] - when[0]);
      if (std::abs(rate) > 2e-3) rate = 0.0;
      offset = 0.5 * (lag[0] + lag[1]) - rate * 0.5 * (when[0] + when[1]);
    }
  }

  // ---- fine: Gauss-Newton on the rows ----
  const StageCurve curve(stage_t, stage_m);
  std::vector<std::array<double, 3>> play(n);  // direction of each joint's last move
  {
    std::array<double, 3> d{0, 0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      if (i > 0) {
        for (int j = 0; j < 3; ++j) {
          const double step = run_alpha_deg[i][j] - run_alpha_deg[i - 1][j];
          if (step != 0.0) d[j] = step > 0 ? 1.0 : -1.0;
        }
      }
      play[i] = d;
    }
  }
  std::vector<std::size_t> rows;
  {
    const std::vector<bool> play_band = in_play(run_alpha_deg);
    auto usable = [&](std::size_t i) {
      const double tau = offset + (1 + rate) * run_t[i];
      return !play_band[i] && std::isfinite(p_enc[i][0]) && tau > curve.first() + 1.0 && tau < curve.last() - 1.0;
    };
    std::size_t covered = 0;
    for (std::size_t i = 0; i < n; ++i) covered += usable(i) ? 1 : 0;
    const std::size_t stride = std::max<std::size_t>(1, (covered + kMaxFitRows - 1) / kMaxFitRows);
    std::size_t seen = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (usable(i) && seen++ % stride == 0) rows.push_back(i);
    }
  }
  if (rows.size() < 100 || run_t[rows.back()] - run_t[rows.front()] < kMinOverlapS) {
    refuse(stage_path, "overlaps " + run_path + " by too little (at least " + fixed3(kMinOverlapS) + " s)");
  }
  // Jacobian columns of the nominal FK (numerical, 1e-4 deg).
  std::vector<std::array<Vec3, 3>> jacobian(rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (int j = 0; j < 3; ++j) {
      Vec3 a = run_alpha_deg[rows[r]];
      a[j] += 1e-4;
      const FkSolution fk = forward_kinematics(nominal, a);
      jacobian[r][j] = fk.ok() ? Vec3((fk.position_m - p_enc[rows[r]]) / 1e-4) : Vec3(Vec3::Zero());
    }
  }
  double t_mean = 0.0;
  Vec3 p_mean = Vec3::Zero(), alpha_lo = run_alpha_deg[rows.front()], alpha_hi = alpha_lo;
  for (std::size_t i : rows) {
    t_mean += run_t[i];
    p_mean += p_enc[i];
    alpha_lo = alpha_lo.cwiseMin(run_alpha_deg[i]);
    alpha_hi = alpha_hi.cwiseMax(run_alpha_deg[i]);
  }
  t_mean /= static_cast<double>(rows.size());
  p_mean /= static_cast<double>(rows.size());
  alpha_lo -= Vec3::Constant(kPlayMarginDeg);  // the readings with their play taken out lie within
  alpha_hi += Vec3::Constant(kPlayMarginDeg);
  // The nuisance functions are evaluated at the readings with the play found so far taken out
  // (alpha + play d): at the readings themselves, both directions of a joint would see a function
  // at points b apart, a difference that follows the direction of motion and reads as a lag.
  Vec3 play_deg = Vec3::Zero();
  std::vector<Vec3> alpha_fit(rows.size()), p_fit(rows.size());
  auto take_out_play = [&] {
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const std::size_t i = rows[r];
      Vec3 a = run_alpha_deg[i];
      for (int j = 0; j < 3; ++j) a[j] += play_deg[j] * play[i][j];
      alpha_fit[r] = a;
      const FkSolution fk = forward_kinematics(nominal, a);
      p_fit[r] = fk.ok() ? fk.position_m : p_enc[i];
    }
  };
  take_out_play();
  // The columns: 0 the centre, 1 the rate; the nuisance (the robot's unknown effects, smooth in
  // position and joint angle, so that none of them reads as a lag): per axis the encoders' plate in
  // the 20 monomials up to the third degree of its offset from the mean (frame, lengths, radii,
  // chain angles); along each joint's column of the Jacobian its play (the direction of its last
  // move) and a cubic B-spline of its reading, knots every kKnotDeg (offset, scale, transmission
  // error).
  std::array<int, 3> knots{}, spline_first{};
  int columns = 2 + 3 * kMonomials + 3;
  for (int j = 0; j < 3; ++j) {
    knots[j] = std::max(1, static_cast<int>(std::ceil((alpha_hi[j] - alpha_lo[j]) / kKnotDeg)));
    spline_first[j] = columns;
    columns += knots[j] + 3;
  }
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  // The design rows of run row r (one per axis) at the stage velocity v, the nuisance columns
  // negated: x theta = -stage.
  auto design = [&](std::size_t r, const Vec3& velocity, RowMatrix* x, Eigen::Index at) {
    const std::size_t i = rows[r];
    const Vec3 q = (p_fit[r] - p_mean) / kMonomialScaleM;
    const double m[kMonomials] = {1.0,
                                  q[0],
                                  q[1],
                                  q[2],
                                  q[0] * q[0],
                                  q[0] * q[1],
                                  q[0] * q[2],
                                  q[1] * q[1],
                                  q[1] * q[2],
                                  q[2] * q[2],
                                  q[0] * q[0] * q[0],
                                  q[0] * q[0] * q[1],
                                  q[0] * q[0] * q[2],
                                  q[0] * q[1] * q[1],
                                  q[0] * q[1] * q[2],
                                  q[0] * q[2] * q[2],
                                  q[1] * q[1] * q[1],
                                  q[1] * q[1] * q[2],
                                  q[1] * q[2] * q[2],
                                  q[2] * q[2] * q[2]};
    std::array<int, 3> first{};
    std::array<std::array<double, 4>, 3> weight{};
    for (int j = 0; j < 3; ++j) {
      const double u = (alpha_fit[r][j] - alpha_lo[j]) / kKnotDeg;
      const int k = std::clamp(static_cast<int>(std::floor(u)), 0, knots[j] - 1);
      const double s = u - k, s2 = s * s, s3 = s2 * s;
      first[j] = spline_first[j] + k;
      weight[j] = {(1 - s) * (1 - s) * (1 - s) / 6, (3 * s3 - 6 * s2 + 4) / 6, (-3 * s3 + 3 * s2 + 3 * s + 1) / 6,
                   s3 / 6};
    }
    for (int axis = 0; axis < 3; ++axis) {
      auto row = x->row(at + axis);
      row.setZero();
      row[0] = velocity[axis];
      row[1] = velocity[axis] * (run_t[i] - t_mean);
      for (int k = 0; k < kMonomials; ++k) row[2 + kMonomials * axis + k] = -m[k];
      for (int j = 0; j < 3; ++j) {
        const double column = jacobian[r][j][axis];
        row[2 + 3 * kMonomials + j] = -column * play[i][j];
        for (int b = 0; b < 4; ++b) row[first[j] + b] = -column * weight[j][static_cast<std::size_t>(b)];
      }
    }
  };
  double centre = offset + (1 + rate) * t_mean;  // tau at t_mean
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(columns);
  Eigen::MatrixXd h(columns, columns);
  constexpr Eigen::Index kChunkRows = 3 * 1024;
  RowMatrix x(kChunkRows, columns);
  Eigen::VectorXd y(kChunkRows);
  // Solves the normal equations with a ridge of 1e-9 of the diagonal on the nuisance (the monomials
  // and the splines overlap: offsets, scales).
  auto solve = [&](const Eigen::VectorXd& g) {
    Eigen::MatrixXd regularised = h.selfadjointView<Eigen::Lower>();
    for (Eigen::Index k = 2; k < columns; ++k) regularised(k, k) += 1e-9 * regularised(k, k) + 1e-300;
    return Eigen::VectorXd(regularised.ldlt().solve(g));
  };
  bool converged = false;
  for (int iteration = 0; iteration < 20 && !converged; ++iteration) {
    h.setZero();
    Eigen::VectorXd g = Eigen::VectorXd::Zero(columns);
    std::size_t used = 0;
    Eigen::Index filled = 0;
    auto flush = [&] {
      h.selfadjointView<Eigen::Lower>().rankUpdate(x.topRows(filled).transpose());
      g.noalias() += x.topRows(filled).transpose() * y.head(filled);
      filled = 0;
    };
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const double tau = centre + (1 + rate) * (run_t[rows[r]] - t_mean);
      Vec3 s, v;
      if (!curve.at(tau, &s, &v)) continue;
      ++used;
      design(r, v, &x, filled);
      y.segment<3>(filled) = -s;
      filled += 3;
      if (filled == kChunkRows) flush();
    }
    if (filled > 0) flush();
    if (used < rows.size() / 2) {
      refuse(stage_path, "overlaps " + run_path + " by too little once aligned (" + std::to_string(used) + " rows)");
    }
    theta = solve(g);
    const double d_centre = theta[0], d_rate = theta[1];
    centre += d_centre;
    rate += d_rate;
    if (std::abs(centre - (offset + (1 + rate) * t_mean)) > 5.0 || std::abs(rate) > 5e-3) {
      refuse(stage_path, "does not belong with " + run_path + ": the clock alignment does not converge");
    }
    const Vec3 d_play = theta.segment<3>(2 + 3 * kMonomials);
    converged = std::abs(d_centre) < 1e-7 && std::abs(d_rate) < 1e-10 && d_play.cwiseAbs().maxCoeff() < 1e-4;
    if (!converged && iteration < 19) {
      play_deg = (play_deg + d_play).cwiseMax(-kPlayMarginDeg).cwiseMin(kPlayMarginDeg);
      take_out_play();
    }
  }
  // Residuals (at the final alignment, theta's nuisance part), the sandwich covariance over blocks.
  // (h stays the last iteration's: the alignment moved by less than its convergence step since.)
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(columns, columns);
  double ss = 0.0, motion = 0.0;
  Vec3 mean = Vec3::Zero();
  std::size_t used = 0;
  {
    theta[0] = theta[1] = 0.0;  // the last step's, already applied
    Eigen::VectorXd block = Eigen::VectorXd::Zero(columns);
    double block_start = run_t[rows.front()];
    std::vector<Vec3> positions;
    positions.reserve(rows.size());
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const double t = run_t[rows[r]];
      const double tau = centre + (1 + rate) * (t - t_mean);
      Vec3 s, v;
      if (!curve.at(tau, &s, &v)) continue;
      if (t - block_start >= kBlockS) {
        meat.noalias() += block * block.transpose();
        block.setZero();
        block_start = t;
      }
      ++used;
      positions.push_back(s);
      design(r, v, &x, 0);
      const Eigen::Vector3d e = x.topRows(3) * theta + s;  // stage - model
      ss += e.squaredNorm();
      block.noalias() += x.topRows(3).transpose() * e;
    }
    meat.noalias() += block * block.transpose();
    for (const Vec3& p : positions) mean += p;
    mean /= static_cast<double>(positions.size());
    for (const Vec3& p : positions) motion += (p - mean).squaredNorm();
  }
  out.fit_rows = used;
  out.residual_rms_m = std::sqrt(ss / (3.0 * used));
  out.motion_rms_m = std::sqrt(motion / (3.0 * used));
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(columns, 2);
  unit(0, 0) = unit(1, 1) = 1.0;
  Eigen::MatrixXd z(columns, 2);
  z.col(0) = solve(unit.col(0));
  z.col(1) = solve(unit.col(1));
  const Eigen::Matrix2d covariance = z.transpose() * meat * z;
  out.rate_ppm = rate * 1e6;
  out.offset_s = centre - (1 + rate) * t_mean;
  out.rate_sd_ppm = std::sqrt(std::max(0.0, covariance(1, 1))) * 1e6;
  out.offset_sd_s =
      std::sqrt(std::max(0.0, covariance(0, 0) + t_mean * t_mean * covariance(1, 1) - 2 * t_mean * covariance(0, 1)));
  if (out.residual_rms_m > kMaxResidualM || out.residual_rms_m > kMaxResidualOfMotion * out.motion_rms_m) {
    refuse(stage_path,
           "does not belong with " + run_path + ": aligned, the stage and the encoders' plate still differ by " +
               fixed3(out.residual_rms_m * 1e6) + " um RMS (motion " + fixed3(out.motion_rms_m * 1e6) + " um RMS)");
  }
  // ---- the stage at every run row it covers ----
  for (std::size_t i = 0; i < n; ++i) {
    const double tau = out.offset_s + (1 + rate) * run_t[i];
    Vec3 s;
    if (!curve.at(tau, &s, nullptr)) continue;
    out.t_s.push_back(run_t[i]);
    out.run_row.push_back(i);
    out.position_m.push_back(s);
  }
  out.merged_rows = out.t_s.size();
  out.overlap_s = out.t_s.empty() ? 0.0 : out.t_s.back() - out.t_s.front();
  return out;
}

}  // namespace delta::diagnosis
