// Merging a run with the measuring stage's log: clocks aligned from the data (see merge.hpp).
#include "delta/diagnosis/merge.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Dense>

#include "delta/board_facts.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"

#include "closed_loop.hpp"
#include "sync_alignment.hpp"

namespace delta::diagnosis {
namespace {

constexpr double kCoarseBinS = 0.5;
constexpr double kFineBinS = 0.05;
constexpr double kRateWindowS = 30.0;       // windows of the first rate (2 to 8 of them)
constexpr std::int64_t kRateSpanBins = 12;  // lags searched on each window, each way
constexpr double kBlockS = 2.0;             // residual blocks for the covariance
constexpr std::size_t kMaxFitRows = 20000;  // rows of the fine fit (evenly thinned)
constexpr int kMonomials = 20;              // 1, x, y, z, their products up to the third degree
constexpr double kMonomialScaleM = 0.01;    // the monomials' unit: 10 mm
constexpr double kKnotDeg = 0.5;            // the joint splines' knot spacing
constexpr double kPlayMarginDeg = 1.0;      // the largest play taken out of a reading
constexpr double kRidge = 1e-9;             // on the nuisance, of its scaled diagonal
constexpr int kPasses = 6;                  // of the fine fit, each dropping outliers anew
constexpr int kIterations = 20;             // of Gauss-Newton in a pass
constexpr double kStepS = 1e-6;             // Gauss-Newton stops when a step moves the alignment less
constexpr double kRobustSigma = 1.4826;     // standard deviations per median absolute deviation
constexpr double kOutlier = 5.0;            // robust deviations of a row's residual
constexpr double kBehind = 3.0;             // robust deviations of a joint behind its reading
constexpr double kBehindCounts = 0.75;      // or this many of its counts
constexpr double kMinCorrelation = 0.9;
constexpr double kPeakTie = 0.01;  // correlation peaks this close are told apart by their overlap
constexpr double kMaxResidualM = 0.2e-3;
constexpr double kMaxResidualOfMotion = 0.2;
constexpr double kRestM = 5e-6;    // stage motion RMS below this: at rest
constexpr double kRestDeg = 0.05;  // every joint's span below this: at rest
constexpr double kMinOverlapS = 10.0;
// A sync whose clocks leave the positions' residual more than this much above the data's own (and
// by more than the slack) does not belong with them.
constexpr double kSyncResidualRatio = 4.0;
constexpr double kSyncResidualSlackM = 0.05e-6;
constexpr double kMinFitSpanS = 5.0;  // of the fine fit's rows (a 10 s closed-loop run keeps 9.4 s)

// Plate positions averaged on absolute bins [k dt, (k + 1) dt).
struct Binned {
  std::int64_t first = 0;  // index of bin 0
  std::vector<Vec3> mean;
  std::vector<int> count;
  std::size_t valid = 0;
  std::vector<std::array<Vec3, 3>> play;  // the run's: each joint's Jacobian column times its mean direction
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

// The run on bins as above, from the rows where no joint may sit inside its play, with each joint's
// play regressor (its Jacobian column at the bin's mean reading times the mean direction of its
// last move).
Binned bin_run(const std::vector<double>& t, const std::vector<Vec3>& alpha_deg, const std::vector<Vec3>& p,
               const std::vector<std::array<double, 3>>& direction, const std::vector<bool>& play_band,
               const Geometry& geometry, double dt) {
  Binned b;
  b.first = static_cast<std::int64_t>(std::floor(t.front() / dt));
  const auto last = static_cast<std::int64_t>(std::floor(t.back() / dt));
  const auto size = static_cast<std::size_t>(last - b.first + 1);
  b.mean.assign(size, Vec3::Zero());
  b.count.assign(size, 0);
  std::vector<Vec3> alpha(size, Vec3::Zero()), d(size, Vec3::Zero());
  std::vector<std::size_t> spoilt(size, 0), rows(size, 0);
  for (std::size_t i = 0; i < t.size(); ++i) {
    const auto k = static_cast<std::size_t>(static_cast<std::int64_t>(std::floor(t[i] / dt)) - b.first);
    ++rows[k];
    if (play_band[i] || !std::isfinite(p[i][0])) {
      ++spoilt[k];
      continue;
    }
    b.mean[k] += p[i];
    alpha[k] += alpha_deg[i];
    d[k] += Vec3(direction[i][0], direction[i][1], direction[i][2]);
    ++b.count[k];
  }
  // A bin with any row inside a play is left out, unless that leaves fewer than half the bins: a
  // closed-loop run's controller dithers the readings by a count, and the reversals of the dither
  // mark rows all along the run; then a bin counts when at least half its rows are clear (their
  // mean).
  std::size_t occupied = 0, clean = 0;
  for (std::size_t k = 0; k < size; ++k) {
    occupied += rows[k] > 0 ? 1 : 0;
    clean += rows[k] > 0 && spoilt[k] == 0 ? 1 : 0;
  }
  const bool lenient = 2 * clean < occupied;
  b.play.assign(size, {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
  for (std::size_t k = 0; k < size; ++k) {
    if (lenient ? 2 * spoilt[k] > rows[k] : spoilt[k] > 0) b.count[k] = 0;
    if (b.count[k] == 0) continue;
    b.mean[k] /= b.count[k];
    alpha[k] /= b.count[k];
    d[k] /= b.count[k];
    const FkSolution at = forward_kinematics(geometry, alpha[k]);
    for (int j = 0; j < 3; ++j) {
      Vec3 a = alpha[k];
      a[j] += 1e-4;
      const FkSolution fk = forward_kinematics(geometry, a);
      if (at.ok() && fk.ok()) b.play[k][static_cast<std::size_t>(j)] = (fk.position_m - at.position_m) / 1e-4 * d[k][j];
    }
    ++b.valid;
  }
  return b;
}

struct LagCorrelation {
  double r = -2.0;
  std::size_t n = 0;
};

// Pearson correlation of the run's bins against the stage's bins lag bins later (tau = t + lag dt),
// the three axes pooled, over the run's bins in [from, to).
LagCorrelation correlate(const Binned& run, const Binned& stage, std::int64_t lag, std::size_t from, std::size_t to) {
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
  LagCorrelation c;
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
LagCorrelation best_lag(const Binned& run, const Binned& stage, std::int64_t lo, std::int64_t hi, std::size_t from,
                        std::size_t to, std::size_t min_n, std::int64_t* lag, double* fraction,
                        bool prefer_overlap = false) {
  LagCorrelation best;
  std::vector<double> r(static_cast<std::size_t>(hi - lo + 1), -2.0);
  std::vector<std::size_t> overlap(r.size(), 0);
  for (std::int64_t l = lo; l <= hi; ++l) {
    const LagCorrelation c = correlate(run, stage, l, from, to);
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

// An affine map between binned plate paths with each joint's play:
// stage = a (run - run_mean) + b + sum_j play_j a0 c_j (c_j the bin's play regressor, a0 the
// affine map fitted without the play).
struct Affine {
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity(), a0 = Eigen::Matrix3d::Identity();
  Vec3 b = Vec3::Zero(), run_mean = Vec3::Zero(), play = Vec3::Zero();
  Vec3 operator()(const Binned& run, std::size_t k) const {
    Vec3 p = b + a * (run.mean[k] - run_mean);
    for (std::size_t j = 0; j < 3; ++j) p += play[static_cast<Eigen::Index>(j)] * (a0 * run.play[k][j]);
    return p;
  }
};

struct LagFit {
  bool ok = false;
  double lag = 0.0;  // in bins, refined between them
  Affine affine;
};

// The lag in [lo, hi] (stage bins lag bins after the run's, over the run's bins [from, to)) whose
// residual after the map above (fitted at each lag; or `fixed`) is least, at least min_n bins
// overlapping; refined by a parabola through its neighbours.
LagFit best_affine_lag(const Binned& run, const Binned& stage, std::int64_t lo, std::int64_t hi, std::size_t from,
                       std::size_t to, std::size_t min_n, const Affine* fixed) {
  LagFit best;
  std::vector<double> cost(static_cast<std::size_t>(hi - lo + 1), -1.0);
  double least = std::numeric_limits<double>::infinity();
  std::int64_t at = lo;
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::int64_t l = lo; l <= hi; ++l) {
    const std::int64_t shift = run.first + l - stage.first;
    pairs.clear();
    for (std::size_t k = from; k < to; ++k) {
      const std::int64_t ks = static_cast<std::int64_t>(k) + shift;
      if (run.count[k] == 0 || ks < 0 || ks >= static_cast<std::int64_t>(stage.mean.size()) ||
          stage.count[static_cast<std::size_t>(ks)] == 0) {
        continue;
      }
      pairs.emplace_back(k, static_cast<std::size_t>(ks));
    }
    if (pairs.size() < std::max<std::size_t>(min_n, 16)) continue;
    Affine affine;
    if (fixed) {
      affine = *fixed;
    } else {
      Vec3 rm = Vec3::Zero(), sm = Vec3::Zero();
      for (const auto& [kr, ks] : pairs) {
        rm += run.mean[kr];
        sm += stage.mean[ks];
      }
      rm /= static_cast<double>(pairs.size());
      sm /= static_cast<double>(pairs.size());
      Eigen::Matrix3d xx = Eigen::Matrix3d::Zero(), xy = Eigen::Matrix3d::Zero();
      for (const auto& [kr, ks] : pairs) {
        const Vec3 u = run.mean[kr] - rm, v = stage.mean[ks] - sm;
        xx += u * u.transpose();
        xy += u * v.transpose();
      }
      affine.a0 = xx.ldlt().solve(xy).transpose();
      affine.run_mean = rm;
      // With the play: a (9), b (3), the play (3).
      Eigen::Matrix<double, 15, 15> nn = Eigen::Matrix<double, 15, 15>::Zero();
      Eigen::Matrix<double, 15, 1> ny = Eigen::Matrix<double, 15, 1>::Zero();
      for (const auto& [kr, ks] : pairs) {
        const Vec3 u = (run.mean[kr] - rm) / kMonomialScaleM;
        std::array<Vec3, 3> c;
        for (std::size_t j = 0; j < 3; ++j) c[j] = affine.a0 * run.play[kr][j] / kMonomialScaleM;
        for (int axis = 0; axis < 3; ++axis) {
          Eigen::Matrix<double, 15, 1> row = Eigen::Matrix<double, 15, 1>::Zero();
          row.segment<3>(3 * axis) = u;
          row[9 + axis] = 1.0;
          for (std::size_t j = 0; j < 3; ++j) row[12 + static_cast<Eigen::Index>(j)] = c[j][axis];
          nn.noalias() += row * row.transpose();
          ny += row * ((stage.mean[ks][axis] - sm[axis]) / kMonomialScaleM);
        }
      }
      for (int k = 12; k < 15; ++k) nn(k, k) += 1e-9 * nn(k, k) + 1e-30;
      const Eigen::Matrix<double, 15, 1> solution = nn.ldlt().solve(ny);
      for (int axis = 0; axis < 3; ++axis) affine.a.row(axis) = solution.segment<3>(3 * axis).transpose();
      affine.b = sm + solution.segment<3>(9) * kMonomialScaleM;
      affine.play = solution.segment<3>(12);
    }
    double ss = 0.0;
    for (const auto& [kr, ks] : pairs) ss += (stage.mean[ks] - affine(run, kr)).squaredNorm();
    cost[static_cast<std::size_t>(l - lo)] = ss / static_cast<double>(pairs.size());
    if (cost[static_cast<std::size_t>(l - lo)] < least) {
      least = cost[static_cast<std::size_t>(l - lo)];
      at = l;
      best.affine = affine;
    }
  }
  if (!std::isfinite(least)) return best;
  best.ok = true;
  best.lag = static_cast<double>(at);
  if (at > lo && at < hi) {
    const double a = cost[static_cast<std::size_t>(at - lo - 1)], b = least,
                 c = cost[static_cast<std::size_t>(at - lo + 1)];
    const double d = a - 2 * b + c;
    if (a >= 0 && c >= 0 && d > 0) best.lag += std::clamp(0.5 * (a - c) / d, -0.5, 0.5);
  }
  return best;
}

// The stage log, interpolated (cubic Hermite, Catmull-Rom slopes) where its samples are no further
// apart than max_stage_gap.
class StageCurve {
 public:
  StageCurve(const std::vector<double>& t, const std::vector<Vec3>& p) : t_(t), p_(p), max_gap_(max_stage_gap(t)) {}
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

// The holds of a drag's readings in which a joint turned back inside its play and came out the same
// way (the reading held, the hold entered and left moving the same way: in_play does not see it)
// while the plate moved: the stage, mapped back to the encoders' plate (the inverse of the first
// affine map) and through the nominal inverse kinematics, gives each arm's motion within the hold;
// an arm that falls back from the furthest it reached since the hold began (the reading's step,
// the arm at the edge of its play pushing) by more than kTurnedCounts of a count has left that
// edge. Every row of such a hold: the arm inside its play says nothing of the reading, and the
// reading between its counts (interpolated in time over the hold) is off where the joint stood
// still. A joint barely moving on a sweep (its range a few degrees over ten minutes) turns inside
// its play for most of the drag; left in, those rows bias the clock offset by milliseconds.
constexpr double kTurnedCounts = 0.1;
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

// One row of the fine fit's design (an axis of a run row): its nonzero columns, in increasing
// order.
constexpr int kRowNonzeros = 2 + kMonomials + 3 + 3 * 4;
struct SparseRow {
  int size = 0;
  std::array<int, kRowNonzeros> column{};
  std::array<double, kRowNonzeros> value{};
  void add(int c, double v) {
    column[static_cast<std::size_t>(size)] = c;
    value[static_cast<std::size_t>(size++)] = v;
  }
  double dot(const Eigen::VectorXd& theta) const {
    double sum = 0.0;
    for (int k = 0; k < size; ++k)
      sum += value[static_cast<std::size_t>(k)] * theta[column[static_cast<std::size_t>(k)]];
    return sum;
  }
  // h (upper triangle) += row' row, g += row' y.
  void accumulate(double y, Eigen::MatrixXd* h, Eigen::VectorXd* g) const {
    for (int a = 0; a < size; ++a) {
      const double va = value[static_cast<std::size_t>(a)];
      const int ca = column[static_cast<std::size_t>(a)];
      (*g)[ca] += va * y;
      double* col = h->col(ca).data();
      for (int b = 0; b <= a; ++b) col[column[static_cast<std::size_t>(b)]] += va * value[static_cast<std::size_t>(b)];
    }
  }
};

// The 20 monomials up to the third degree of q.
std::array<double, kMonomials> monomials(const Vec3& q) {
  return {1.0,
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
}

// The median of values (reordered), 0 for none.
double median(std::vector<double>* values) {
  if (values->empty()) return 0.0;
  const auto middle = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  std::nth_element(values->begin(), middle, values->end());
  return *middle;
}

// The readings between their counts: a reading changes when the angle crosses the boundary between
// two counts, halfway between the two readings, at about halfway between the two samples; between
// two crossings in the same direction the angle is interpolated linearly in time (within the count
// it holds, by construction). Between two crossings of the same boundary (the joint turned within
// a count) it is taken halfway between the boundary and the reading; before the first crossing and
// after the last, the reading.
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

[[noreturn]] void refuse(const std::string& path, const std::string& reason) { throw InputError(path, 0, reason); }

std::string fixed3(double value) {
  char text[64];
  std::snprintf(text, sizeof text, "%.3f", value);
  return text;
}

}  // namespace

MergeResult merge_logs(const std::string& run_path, const std::vector<double>& run_t,
                       const std::vector<Vec3>& run_alpha_deg, const std::string& stage_path,
                       const std::vector<double>& stage_t, const std::vector<Vec3>& stage_m,
                       const std::vector<int>& stage_sync) {
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
  // ---- the encoders' plate (nominal FK of the readings between their counts), each joint's
  // direction of play and the rows where a joint may sit inside its play ----
  const Geometry nominal = Geometry::nominal();
  const std::size_t n = run_t.size();
  // Closed-loop telemetry: the angle behind each reading is the reading less the lead the
  // controller holds it at (closed_loop.hpp), not one interpolated between crossings.
  const closed_loop::Readings readings = closed_loop::read_closed_loop(run_t, run_alpha_deg, kEncoderResolutionDeg);
  const std::vector<Vec3> alpha = readings.closed_loop ? readings.angle_deg : dequantise(run_t, run_alpha_deg);
  std::vector<Vec3> p_enc(n);
  for (std::size_t i = 0; i < n; ++i) {
    const FkSolution fk = forward_kinematics(nominal, alpha[i]);
    p_enc[i] = fk.ok() ? fk.position_m : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  }
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
  const std::vector<bool> play_band = in_play(run_alpha_deg);

  // ---- coarse alignment: 0.5 s bins over every lag ----
  const Binned run_c = bin(run_t, p_enc, kCoarseBinS), stage_c = bin(stage_t, stage_m, kCoarseBinS);
  const std::size_t min_c = std::max<std::size_t>(static_cast<std::size_t>(kMinOverlapS / kCoarseBinS),
                                                  std::min(run_c.valid, stage_c.valid) / 2);
  const std::int64_t lo_c = stage_c.first - run_c.first - static_cast<std::int64_t>(run_c.mean.size());
  const std::int64_t hi_c = stage_c.first + static_cast<std::int64_t>(stage_c.mean.size()) - run_c.first;
  std::int64_t lag_c = 0;
  double frac = 0.0;
  const LagCorrelation coarse = best_lag(run_c, stage_c, lo_c, hi_c, 0, run_c.mean.size(), min_c, &lag_c, &frac, true);
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
  // ---- then 50 ms bins near that lag, each lag judged by the residual of an affine map with the
  // play; the same on windows of the run with that map held: a line through their lags ----
  const Binned run_f = bin_run(run_t, alpha, p_enc, play, play_band, nominal, kFineBinS),
               stage_f = bin(stage_t, stage_m, kFineBinS);
  const double ratio = kCoarseBinS / kFineBinS;
  const auto centre_f = static_cast<std::int64_t>(std::llround(lag_c * ratio));
  const auto span_f = static_cast<std::int64_t>(2 * ratio);
  const std::size_t min_f = std::max<std::size_t>(20, min_c * static_cast<std::size_t>(ratio) / 2);
  const LagFit whole =
      best_affine_lag(run_f, stage_f, centre_f - span_f, centre_f + span_f, 0, run_f.mean.size(), min_f, nullptr);
  if (!whole.ok) {
    refuse(stage_path, "overlaps " + run_path + " by too little (at least " + fixed3(kMinOverlapS) + " s)");
  }
  double offset = whole.lag * kFineBinS;  // tau - t
  double rate = 0.0;
  {
    const double span_s = static_cast<double>(run_f.mean.size()) * kFineBinS;
    const int windows = std::clamp(static_cast<int>(span_s / kRateWindowS), 2, 8);
    const std::size_t size = run_f.mean.size() / static_cast<std::size_t>(windows);
    const auto lag0 = static_cast<std::int64_t>(std::llround(whole.lag));
    std::vector<double> when, lag;
    for (int w = 0; w < windows; ++w) {
      const std::size_t from = static_cast<std::size_t>(w) * size, to = from + size;
      const LagFit fit = best_affine_lag(run_f, stage_f, lag0 - kRateSpanBins, lag0 + kRateSpanBins, from, to, size / 2,
                                         &whole.affine);
      if (!fit.ok) continue;
      when.push_back((static_cast<double>(run_f.first) + 0.5 * static_cast<double>(from + to)) * kFineBinS);
      lag.push_back(fit.lag * kFineBinS);
    }
    if (when.size() >= 2) {
      double tw = 0, lw = 0;
      for (std::size_t k = 0; k < when.size(); ++k) {
        tw += when[k];
        lw += lag[k];
      }
      tw /= static_cast<double>(when.size());
      lw /= static_cast<double>(when.size());
      double stt = 0, stl = 0;
      for (std::size_t k = 0; k < when.size(); ++k) {
        stt += (when[k] - tw) * (when[k] - tw);
        stl += (when[k] - tw) * (lag[k] - lw);
      }
      rate = stl / stt;
      if (std::abs(rate) > 2e-3) rate = 0.0;
      offset = lw - rate * tw;
    }
  }

  // ---- fine: the fit rows (evenly thinned), their Jacobians ----
  const StageCurve curve(stage_t, stage_m);
  const std::vector<bool> turned =
      readings.closed_loop ? std::vector<bool>(n, false)
                           : turned_inside_play(run_t, run_alpha_deg, curve, offset, rate, whole.affine, nominal);
  std::vector<std::size_t> rows;
  {
    auto usable = [&](std::size_t i) {
      const double tau = offset + (1 + rate) * run_t[i];
      return !play_band[i] && !turned[i] && std::isfinite(p_enc[i][0]) && tau > curve.first() + 1.0 &&
             tau < curve.last() - 1.0;
    };
    std::size_t covered = 0;
    for (std::size_t i = 0; i < n; ++i) covered += usable(i) ? 1 : 0;
    const std::size_t stride = std::max<std::size_t>(1, (covered + kMaxFitRows - 1) / kMaxFitRows);
    std::size_t seen = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (usable(i) && seen++ % stride == 0) rows.push_back(i);
    }
  }
  if (rows.size() < 100 || run_t[rows.back()] - run_t[rows.front()] < kMinFitSpanS) {
    refuse(stage_path, "overlaps " + run_path + " by too little (at least " + fixed3(kMinFitSpanS) +
                           " s of rows where no joint sits inside its play)");
  }
  const std::size_t m = rows.size();
  std::vector<std::array<Vec3, 3>> jacobian(m);  // of the nominal FK (numerical, 1e-4 deg)
  for (std::size_t r = 0; r < m; ++r) {
    for (int j = 0; j < 3; ++j) {
      Vec3 a = alpha[rows[r]];
      a[j] += 1e-4;
      const FkSolution fk = forward_kinematics(nominal, a);
      jacobian[r][j] = fk.ok() ? Vec3((fk.position_m - p_enc[rows[r]]) / 1e-4) : Vec3(Vec3::Zero());
    }
  }
  double t_mean = 0.0;
  Vec3 p_mean = Vec3::Zero(), alpha_lo = alpha[rows.front()], alpha_hi = alpha_lo;
  for (std::size_t i : rows) {
    t_mean += run_t[i];
    p_mean += p_enc[i];
    alpha_lo = alpha_lo.cwiseMin(alpha[i]);
    alpha_hi = alpha_hi.cwiseMax(alpha[i]);
  }
  t_mean /= static_cast<double>(m);
  p_mean /= static_cast<double>(m);
  alpha_lo -= Vec3::Constant(kPlayMarginDeg);  // the readings with their play taken out lie within
  alpha_hi += Vec3::Constant(kPlayMarginDeg);
  const double half_span = 0.5 * (run_t[rows.back()] - run_t[rows.front()]);
  // Each joint's resolution: the median of its steps.
  Vec3 count_deg = Vec3::Constant(kEncoderResolutionDeg);
  for (int j = 0; j < 3; ++j) {
    std::vector<double> steps;
    for (std::size_t i = 1; i < n; ++i) {
      const double step = std::abs(run_alpha_deg[i][j] - run_alpha_deg[i - 1][j]);
      if (step > 0) steps.push_back(step);
    }
    if (steps.empty()) continue;
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
    count_deg[j] = steps[steps.size() / 2];
  }

  // ---- the model: the nuisance functions are evaluated at the readings with the play found so
  // far taken out (alpha + play d): at the readings themselves, both directions of a joint would
  // see a function at points b apart, a difference that follows the direction of motion and reads
  // as a lag. The affine map from the encoders' plate to the stage's is taken out of the stage
  // (the nuisance then fits what is left, small, and keeps its precision) and its matrix maps each
  // joint's Jacobian column into the stage's frame (a rotated stage sees the play and the joints'
  // reading errors rotated) ----
  Vec3 play_deg = whole.affine.play.cwiseMax(-kPlayMarginDeg).cwiseMin(kPlayMarginDeg);
  Eigen::Matrix3d to_stage = Eigen::Matrix3d::Identity();
  Vec3 stage_at_mean = p_mean;
  std::vector<Vec3> alpha_fit(m), p_fit(m);
  std::vector<std::array<Vec3, 3>> column(m);  // each joint's Jacobian column in the stage's frame
  auto take_out_play = [&] {
    for (std::size_t r = 0; r < m; ++r) {
      const std::size_t i = rows[r];
      Vec3 a = alpha[i];
      for (int j = 0; j < 3; ++j) a[j] += play_deg[j] * play[i][j];
      alpha_fit[r] = a;
      const FkSolution fk = forward_kinematics(nominal, a);
      p_fit[r] = fk.ok() ? fk.position_m : p_enc[i];
      for (std::size_t j = 0; j < 3; ++j) column[r][j] = to_stage * jacobian[r][j];
    }
  };
  auto beyond_affine = [&](std::size_t r, const Vec3& s) -> Vec3 {
    return s - stage_at_mean - to_stage * (p_fit[r] - p_mean);
  };
  // The columns: 0 the centre, 1 the rate; the nuisance (the robot's unknown effects, smooth in
  // position and joint angle, so that none of them reads as a lag): per axis the encoders' plate in
  // the 20 monomials up to the third degree of its offset from the mean (frame, lengths, radii,
  // chain angles); along each joint's column its play (the direction of its last move) and a cubic
  // B-spline of its reading, knots every kKnotDeg (offset, scale, transmission error).
  std::array<int, 3> knots{}, spline_first{};
  int columns = 2 + 3 * kMonomials + 3;
  for (std::size_t j = 0; j < 3; ++j) {
    knots[j] =
        std::max(1, static_cast<int>(std::ceil(
                        (alpha_hi[static_cast<Eigen::Index>(j)] - alpha_lo[static_cast<Eigen::Index>(j)]) / kKnotDeg)));
    spline_first[j] = columns;
    columns += knots[j] + 3;
  }
  // The design rows of fit row r (one per axis) at the stage velocity v, the nuisance columns
  // negated (x theta = -target).
  std::array<SparseRow, 3> x;
  auto design = [&](std::size_t r, const Vec3& velocity) {
    const std::size_t i = rows[r];
    const std::array<double, kMonomials> mono = monomials((p_fit[r] - p_mean) / kMonomialScaleM);
    std::array<int, 3> first{};
    std::array<std::array<double, 4>, 3> weight{};
    for (std::size_t j = 0; j < 3; ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      const double u = (alpha_fit[r][jj] - alpha_lo[jj]) / kKnotDeg;
      const int k = std::clamp(static_cast<int>(std::floor(u)), 0, knots[j] - 1);
      const double s = u - k, s2 = s * s, s3 = s2 * s;
      first[j] = spline_first[j] + k;
      weight[j] = {(1 - s) * (1 - s) * (1 - s) / 6, (3 * s3 - 6 * s2 + 4) / 6, (-3 * s3 + 3 * s2 + 3 * s + 1) / 6,
                   s3 / 6};
    }
    for (int axis = 0; axis < 3; ++axis) {
      SparseRow& row = x[static_cast<std::size_t>(axis)];
      row.size = 0;
      row.add(0, velocity[axis]);
      row.add(1, velocity[axis] * (run_t[i] - t_mean));
      for (int k = 0; k < kMonomials; ++k) row.add(2 + kMonomials * axis + k, -mono[static_cast<std::size_t>(k)]);
      for (std::size_t j = 0; j < 3; ++j)
        row.add(2 + 3 * kMonomials + static_cast<int>(j), -column[r][j][axis] * play[i][j]);
      for (std::size_t j = 0; j < 3; ++j) {
        for (std::size_t b = 0; b < 4; ++b) row.add(first[j] + static_cast<int>(b), -column[r][j][axis] * weight[j][b]);
      }
    }
  };
  std::vector<char> keep(m, 1);  // fit rows not dropped as outliers
  struct Normal {
    Eigen::MatrixXd h;  // upper triangle
    Eigen::VectorXd g;
    std::size_t used = 0;
  };
  // The normal equations at an alignment (centre: tau at t_mean).
  auto accumulate = [&](double at_centre, double at_rate, Normal* nm) {
    nm->h.setZero(columns, columns);
    nm->g.setZero(columns);
    nm->used = 0;
    for (std::size_t r = 0; r < m; ++r) {
      if (!keep[r]) continue;
      Vec3 s, v;
      if (!curve.at(at_centre + (1 + at_rate) * (run_t[rows[r]] - t_mean), &s, &v)) continue;
      ++nm->used;
      design(r, v);
      const Vec3 target = beyond_affine(r, s);
      for (int axis = 0; axis < 3; ++axis) x[static_cast<std::size_t>(axis)].accumulate(-target[axis], &nm->h, &nm->g);
    }
  };
  // Solves the normal equations, columns scaled to a unit diagonal, with a ridge of 1e-9 on the
  // nuisance (the monomials and the splines overlap: offsets, scales); timing false holds the
  // alignment (its columns out).
  auto solve = [&](const Normal& nm, const Eigen::MatrixXd& g, bool timing) {
    Eigen::VectorXd scale(columns);
    for (Eigen::Index k = 0; k < columns; ++k) {
      const double d = nm.h(k, k);
      scale[k] = d > 0 && (timing || k >= 2) ? 1.0 / std::sqrt(d) : 0.0;
    }
    Eigen::MatrixXd regularised = nm.h.selfadjointView<Eigen::Upper>();
    regularised = scale.asDiagonal() * regularised * scale.asDiagonal();
    for (Eigen::Index k = 0; k < columns; ++k) regularised(k, k) = scale[k] > 0 && k >= 2 ? 1.0 + kRidge : 1.0;
    const Eigen::MatrixXd rhs = scale.asDiagonal() * g;
    return Eigen::MatrixXd(scale.asDiagonal() * regularised.ldlt().solve(rhs));
  };
  // Residuals (stage - model) of every fit row at an alignment with the nuisance theta (its timing
  // part ignored; NaN outside the stage's log); returns the kept rows' sum of squares.
  std::vector<Vec3> residual(m);
  auto residuals = [&](double at_centre, double at_rate, Eigen::VectorXd theta) {
    theta[0] = theta[1] = 0.0;
    double ss = 0.0;
    for (std::size_t r = 0; r < m; ++r) {
      residual[r] = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
      Vec3 s, v;
      if (!curve.at(at_centre + (1 + at_rate) * (run_t[rows[r]] - t_mean), &s, &v)) continue;
      design(r, v);
      const Vec3 target = beyond_affine(r, s);
      for (int axis = 0; axis < 3; ++axis)
        residual[r][axis] = x[static_cast<std::size_t>(axis)].dot(theta) + target[axis];
      if (keep[r]) ss += residual[r].squaredNorm();
    }
    return ss;
  };
  // The RMS residual of the kept fit rows at an alignment, the nuisance refitted there (the
  // alignment held).
  auto residual_rms_at = [&](double at_centre, double at_rate) {
    Normal nm;
    accumulate(at_centre, at_rate, &nm);
    if (nm.used == 0) return std::numeric_limits<double>::infinity();
    return std::sqrt(residuals(at_centre, at_rate, solve(nm, nm.g, false).col(0)) /
                     (3.0 * static_cast<double>(nm.used)));
  };
  auto refuse_if_short = [&](const Normal& nm) {
    if (nm.used < m / 2) {
      refuse(stage_path, "overlaps " + run_path + " by too little once aligned (" + std::to_string(nm.used) + " rows)");
    }
  };
  auto diverged = [&](double at_centre, double at_rate) {
    return std::abs(at_centre - (offset + (1 + at_rate) * t_mean)) > 5.0 || std::abs(at_rate) > 5e-3;
  };

  double centre = offset + (1 + rate) * t_mean;
  take_out_play();  // p_fit and the columns for the first pass's affine map
  Normal normal;
  for (int pass = 0; pass < kPasses; ++pass) {
    const bool hold = pass == 0;  // the first pass holds the coarse alignment: outliers first
    // The affine map at this alignment.
    {
      Eigen::Matrix4d ata = Eigen::Matrix4d::Zero();
      Eigen::Matrix<double, 4, 3> atb = Eigen::Matrix<double, 4, 3>::Zero();
      for (std::size_t r = 0; r < m; ++r) {
        Vec3 s, v;
        if (!keep[r] || !curve.at(centre + (1 + rate) * (run_t[rows[r]] - t_mean), &s, &v)) continue;
        Eigen::Vector4d a;
        a << (p_fit[r] - p_mean) / kMonomialScaleM, 1.0;
        ata += a * a.transpose();
        atb += a * (s / kMonomialScaleM).transpose();
      }
      const Eigen::Matrix<double, 4, 3> affine = ata.ldlt().solve(atb);
      to_stage = affine.topRows<3>().transpose();
      stage_at_mean = affine.row(3).transpose() * kMonomialScaleM;
      take_out_play();
    }
    // Gauss-Newton on (centre, rate, play), the nuisance profiled out.
    accumulate(centre, rate, &normal);
    refuse_if_short(normal);
    double cost = residuals(centre, rate, solve(normal, normal.g, false).col(0)) / static_cast<double>(normal.used);
    for (int iteration = 0; !hold && iteration < kIterations; ++iteration) {
      const Eigen::VectorXd step = solve(normal, normal.g, true).col(0);
      const double d_centre = step[0], d_rate = step[1];
      const Vec3 d_play = step.segment<3>(2 + 3 * kMonomials);
      if (std::abs(d_centre) < kStepS && std::abs(d_rate) * half_span < kStepS && d_play.cwiseAbs().maxCoeff() < 1e-4) {
        break;
      }
      // The step times k: its residual per row (infinite where it leaves the logs). Longer steps
      // while they lower it (along a valley Gauss-Newton falls short), else shorter ones until one
      // does.
      const Vec3 play_before = play_deg;
      Normal trial, best_normal;
      double best = cost, best_k = 0.0;
      auto consider = [&](double k) {
        const double try_centre = centre + k * d_centre, try_rate = rate + k * d_rate;
        if (diverged(try_centre, try_rate)) return false;
        play_deg = (play_before + k * d_play).cwiseMax(-kPlayMarginDeg).cwiseMin(kPlayMarginDeg);
        take_out_play();
        accumulate(try_centre, try_rate, &trial);
        if (trial.used < m / 2) return false;
        const double c =
            residuals(try_centre, try_rate, solve(trial, trial.g, false).col(0)) / static_cast<double>(trial.used);
        if (!(c < best)) return false;
        best = c;
        best_k = k;
        best_normal = trial;
        return true;
      };
      if (consider(1.0)) {
        for (double k = 2.0; k <= 64.0 && consider(k); k *= 2.0) {
        }
      } else {
        for (double k = 0.5; k >= 1.0 / 8 && !consider(k); k *= 0.5) {
        }
      }
      play_deg = (play_before + best_k * d_play).cwiseMax(-kPlayMarginDeg).cwiseMin(kPlayMarginDeg);
      take_out_play();
      if (best_k == 0.0) break;
      centre += best_k * d_centre;
      rate += best_k * d_rate;
      normal = std::move(best_normal);
      cost = best;
    }
    if (diverged(centre, rate)) {
      refuse(stage_path, "does not belong with " + run_path + ": the clock alignment does not converge");
    }
    // Outliers. A row off by more than kOutlier robust deviations drops the encoder holds it lies
    // in, of every joint; a joint behind its reading (against its direction of motion, in joint
    // space) by more than the reading's resolution or kBehind robust deviations drops its hold: it
    // turned back inside its play and came out the same way, its reading held while the plate moved.
    residuals(centre, rate, solve(normal, normal.g, false).col(0));
    std::vector<double> magnitude;
    magnitude.reserve(3 * m);
    std::vector<Vec3> joint_error(m, Vec3::Zero());
    std::array<std::vector<double>, 3> joint_magnitude;
    for (std::size_t r = 0; r < m; ++r) {
      if (!std::isfinite(residual[r][0])) continue;
      Eigen::Matrix3d columns_r;
      for (std::size_t j = 0; j < 3; ++j) columns_r.col(static_cast<Eigen::Index>(j)) = column[r][j];
      joint_error[r] = columns_r.partialPivLu().solve(residual[r]);
      if (!keep[r]) continue;
      for (std::size_t a = 0; a < 3; ++a) {
        magnitude.push_back(std::abs(residual[r][static_cast<Eigen::Index>(a)]));
        joint_magnitude[a].push_back(std::abs(joint_error[r][static_cast<Eigen::Index>(a)]));
      }
    }
    const double sigma = kRobustSigma * median(&magnitude);
    Vec3 joint_sigma;
    for (std::size_t j = 0; j < 3; ++j)
      joint_sigma[static_cast<Eigen::Index>(j)] = kRobustSigma * median(&joint_magnitude[j]);
    std::vector<char> drop(n, 0);
    auto drop_hold = [&](std::size_t i, int j) {
      std::size_t lo = i, hi = i;
      while (lo > 0 && run_alpha_deg[lo - 1][j] == run_alpha_deg[i][j]) --lo;
      while (hi + 1 < n && run_alpha_deg[hi + 1][j] == run_alpha_deg[i][j]) ++hi;
      std::fill(drop.begin() + static_cast<std::ptrdiff_t>(lo), drop.begin() + static_cast<std::ptrdiff_t>(hi + 1), 1);
    };
    for (std::size_t r = 0; r < m; ++r) {
      if (!std::isfinite(residual[r][0])) continue;
      const std::size_t i = rows[r];
      if (residual[r].cwiseAbs().maxCoeff() > kOutlier * sigma) {
        for (int j = 0; j < 3; ++j) drop_hold(i, j);
        continue;
      }
      for (int j = 0; j < 3; ++j) {
        if (play[i][static_cast<std::size_t>(j)] * joint_error[r][j] <
            -std::min(kBehindCounts * count_deg[j], kBehind * joint_sigma[j])) {
          drop_hold(i, j);
        }
      }
    }
    // The rows kept from now on: those outside the dropped holds (a row dropped on a rougher fit
    // comes back once it fits). Done when few change.
    std::size_t changed = 0, kept = 0;
    for (std::size_t r = 0; r < m; ++r) {
      const char now = drop[rows[r]] ? 0 : 1;
      changed += now != keep[r] ? 1 : 0;
      kept += static_cast<std::size_t>(now);
    }
    if (kept < m / 2) {
      if (hold) continue;
      break;
    }
    if (!hold && changed * 200 <= m) break;
    for (std::size_t r = 0; r < m; ++r) keep[r] = drop[rows[r]] ? 0 : 1;
  }

  // ---- residuals at the final alignment, the sandwich covariance over blocks ----
  accumulate(centre, rate, &normal);
  refuse_if_short(normal);
  const Eigen::VectorXd theta = solve(normal, normal.g, false).col(0);
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(columns, columns);
  double ss = 0.0, motion = 0.0;
  std::size_t used = 0;
  {
    Eigen::VectorXd block = Eigen::VectorXd::Zero(columns);
    double block_start = run_t[rows.front()];
    std::vector<Vec3> positions;
    positions.reserve(m);
    for (std::size_t r = 0; r < m; ++r) {
      if (!keep[r]) continue;
      const double t = run_t[rows[r]];
      Vec3 s, v;
      if (!curve.at(centre + (1 + rate) * (t - t_mean), &s, &v)) continue;
      if (t - block_start >= kBlockS) {
        meat.noalias() += block * block.transpose();
        block.setZero();
        block_start = t;
      }
      ++used;
      positions.push_back(s);
      design(r, v);
      const Vec3 target = beyond_affine(r, s);
      for (int axis = 0; axis < 3; ++axis) {
        const SparseRow& row = x[static_cast<std::size_t>(axis)];
        const double e = row.dot(theta) + target[axis];  // stage - model
        ss += e * e;
        for (int k = 0; k < row.size; ++k) {
          block[row.column[static_cast<std::size_t>(k)]] += row.value[static_cast<std::size_t>(k)] * e;
        }
      }
    }
    meat.noalias() += block * block.transpose();
    Vec3 mean = Vec3::Zero();
    for (const Vec3& p : positions) mean += p;
    mean /= static_cast<double>(positions.size());
    for (const Vec3& p : positions) motion += (p - mean).squaredNorm();
  }
  out.fit_rows = used;
  out.residual_rms_m = std::sqrt(ss / (3.0 * used));
  out.motion_rms_m = std::sqrt(motion / (3.0 * used));
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(columns, 2);
  unit(0, 0) = unit(1, 1) = 1.0;
  const Eigen::MatrixXd z = solve(normal, unit, true);
  const Eigen::Matrix2d covariance = z.transpose() * meat * z;
  // The information on the offset and on the rate with the nuisance fitted (their profiled
  // curvatures) over that with the nuisance known.
  out.offset_signal_left = std::clamp(1.0 / (z(0, 0) * normal.h(0, 0)), 0.0, 1.0);
  out.rate_signal_left = std::clamp(1.0 / (z(1, 1) * normal.h(1, 1)), 0.0, 1.0);
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
  out.data_residual_rms_m = out.residual_rms_m;
  out.data_offset_s = out.offset_s;
  out.data_offset_sd_s = out.offset_sd_s;
  out.data_rate_ppm = out.rate_ppm;
  out.data_rate_sd_ppm = out.rate_sd_ppm;
  // ---- the board's sync output, when the stage logged it ----
  if (!stage_sync.empty()) {
    const SyncAlignment sync =
        align_on_sync(stage_path, stage_t, stage_sync, out.offset_s, rate, board::kStageSyncLevelSeconds);
    if (sync.changes > 0) {
      // The positions must fit at the sync's clocks about as well as at their own (1.00-1.04 x on
      // drags, up to 1.3 x in closed loop): a correction of a lost alignment that they do not bear
      // out is refused. Drags whose positions cannot fix the clocks to 0.1 s fit as well at both.
      const double at_sync = residual_rms_at(sync.offset_s + (1 + sync.rate) * t_mean, sync.rate);
      if (!(at_sync <= kSyncResidualRatio * out.residual_rms_m + kSyncResidualSlackM)) {
        refuse(stage_path, "its sync column does not fit the positions: at the clocks its changes give (" +
                               fixed3(sync.shift_s) + " s from the positions' own) the stage and the encoders' plate " +
                               "differ by " + fixed3(at_sync * 1e6) + " um RMS, against " +
                               fixed3(out.residual_rms_m * 1e6) +
                               " um at the positions' clocks (is it the sync of this run?)");
      }
      out.residual_rms_m = at_sync;
      out.sync_shift_s = sync.shift_s;
      out.sync_corrected_lost_alignment = sync.corrected_lost_alignment;
      out.from_sync = true;
      out.sync_changes = sync.changes;
      out.sync_consistent = sync.consistent;
      out.offset_s = sync.offset_s;
      out.offset_sd_s = sync.offset_sd_s;
      rate = sync.rate;
      out.rate_ppm = sync.rate * 1e6;
      out.rate_sd_ppm = sync.rate_sd * 1e6;
    }
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
