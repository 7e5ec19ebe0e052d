// Merging, the coarse alignment (merge_phases.hpp, merge.hpp step 1): binned plate paths
// correlated over every lag; then, on finer bins near it, the lag that leaves the least of an affine
// map with each joint's play; then the same on windows of the run, a line through their lags.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "delta/kinematics.hpp"

#include "merge_phases.hpp"

namespace delta::diagnosis::merging {
namespace {

constexpr double kCoarseBinS = 0.5;
constexpr double kFineBinS = 0.05;
constexpr double kRateWindowS = 30.0;       // windows of the first rate (2 to 8 of them)
constexpr std::int64_t kRateSpanBins = 12;  // lags searched on each window, each way
constexpr double kMinCorrelation = 0.9;
constexpr double kPeakTie = 0.01;  // correlation peaks this close are told apart by their overlap

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

}  // namespace

CoarseAlignment align_coarsely(const Logs& logs, const EncoderPlate& plate, const Geometry& nominal) {
  // ---- coarse alignment: 0.5 s bins over every lag ----
  const Binned run_c = bin(logs.run_t, plate.position_m, kCoarseBinS),
               stage_c = bin(logs.stage_t, logs.stage_m, kCoarseBinS);
  const std::size_t min_c = std::max<std::size_t>(static_cast<std::size_t>(kMinOverlapS / kCoarseBinS),
                                                  std::min(run_c.valid, stage_c.valid) / 2);
  const std::int64_t lo_c = stage_c.first - run_c.first - static_cast<std::int64_t>(run_c.mean.size());
  const std::int64_t hi_c = stage_c.first + static_cast<std::int64_t>(stage_c.mean.size()) - run_c.first;
  std::int64_t lag_c = 0;
  double frac = 0.0;
  const LagCorrelation coarse = best_lag(run_c, stage_c, lo_c, hi_c, 0, run_c.mean.size(), min_c, &lag_c, &frac, true);
  if (coarse.r <= -2.0) {
    refuse(logs.stage_path, "does not overlap " + logs.run_path + " by " + fixed3(min_c * kCoarseBinS) +
                                " s at any clock offset (the logs must share at least half the shorter one)");
  }
  CoarseAlignment out;
  out.correlation = coarse.r;
  if (coarse.r < kMinCorrelation) {
    refuse(logs.stage_path, "no clock offset makes its plate path agree with " + logs.run_path +
                                "'s (correlation at most " + fixed3(coarse.r) + ", below " + fixed3(kMinCorrelation) +
                                "): the logs do not overlap, or do not belong together");
  }
  // ---- then 50 ms bins near that lag, each lag judged by the residual of an affine map with the
  // play; the same on windows of the run with that map held: a line through their lags ----
  const Binned run_f = bin_run(logs.run_t, plate.alpha_deg, plate.position_m, plate.direction, plate.play_band, nominal,
                               kFineBinS),
               stage_f = bin(logs.stage_t, logs.stage_m, kFineBinS);
  const double ratio = kCoarseBinS / kFineBinS;
  const auto centre_f = static_cast<std::int64_t>(std::llround(lag_c * ratio));
  const auto span_f = static_cast<std::int64_t>(2 * ratio);
  const std::size_t min_f = std::max<std::size_t>(20, min_c * static_cast<std::size_t>(ratio) / 2);
  const LagFit whole =
      best_affine_lag(run_f, stage_f, centre_f - span_f, centre_f + span_f, 0, run_f.mean.size(), min_f, nullptr);
  if (!whole.ok) {
    refuse(logs.stage_path, "overlaps " + logs.run_path + " by too little (at least " + fixed3(kMinOverlapS) + " s)");
  }
  out.affine = whole.affine;
  double& offset = out.offset_s;  // tau - t
  double& rate = out.rate;
  offset = whole.lag * kFineBinS;
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

  return out;
}

}  // namespace delta::diagnosis::merging
