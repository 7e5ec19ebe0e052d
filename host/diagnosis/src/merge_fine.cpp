// Merging, the fine fit (merge_phases.hpp, merge.hpp steps 2 and 3): Gauss-Newton on the clocks and
// each joint's play with the robot's unknown effects profiled out, outliers dropped pass by pass,
// then the sandwich covariance over 2 s blocks.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "delta/board_facts.hpp"
#include "delta/kinematics.hpp"

#include "merge_phases.hpp"

namespace delta::diagnosis::merging {
namespace {

constexpr double kBlockS = 2.0;             // residual blocks for the covariance
constexpr std::size_t kMaxFitRows = 20000;  // rows of the fine fit (evenly thinned)
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
constexpr double kMaxResidualM = 0.2e-3;
constexpr double kMaxResidualOfMotion = 0.2;
constexpr double kMinFitSpanS = 5.0;  // of the fine fit's rows (a 10 s closed-loop run keeps 9.4 s)

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

}  // namespace

void SparseRow::accumulate(double y, Eigen::MatrixXd* h, Eigen::VectorXd* g) const {
  for (int a = 0; a < size; ++a) {
    const double va = value[static_cast<std::size_t>(a)];
    const int ca = column[static_cast<std::size_t>(a)];
    (*g)[ca] += va * y;
    double* col = h->col(ca).data();
    for (int b = 0; b <= a; ++b) col[column[static_cast<std::size_t>(b)]] += va * value[static_cast<std::size_t>(b)];
  }
}

FineFit::FineFit(const Logs& logs, const EncoderPlate& plate, const StageCurve& curve, const Geometry& nominal,
                 const CoarseAlignment& coarse)
    : logs_(logs),
      plate_(plate),
      curve_(curve),
      nominal_(nominal),
      n_(logs.run_t.size()),
      offset_(coarse.offset_s),
      rate_(coarse.rate) {
  const std::vector<bool> turned = plate.closed_loop ? std::vector<bool>(n_, false)
                                                     : turned_inside_play(logs.run_t, logs.run_alpha_deg, curve,
                                                                          offset_, rate_, coarse.affine, nominal);
  select_rows(turned);
  measure_rows();
  // ---- the model: the nuisance functions are evaluated at the readings with the play found so
  // far taken out (alpha + play d): at the readings themselves, both directions of a joint would
  // see a function at points b apart, a difference that follows the direction of motion and reads
  // as a lag. The affine map from the encoders' plate to the stage's is taken out of the stage
  // (the nuisance then fits what is left, small, and keeps its precision) and its matrix maps each
  // joint's Jacobian column into the stage's frame (a rotated stage sees the play and the joints'
  // reading errors rotated) ----
  play_deg_ = coarse.affine.play.cwiseMax(-kPlayMarginDeg).cwiseMin(kPlayMarginDeg);
  stage_at_mean_ = p_mean_;
  alpha_fit_.resize(m_);
  p_fit_.resize(m_);
  column_.resize(m_);
  // The columns: 0 the centre, 1 the rate; the nuisance (the robot's unknown effects, smooth in
  // position and joint angle, so that none of them reads as a lag): per axis the encoders' plate in
  // the 20 monomials up to the third degree of its offset from the mean (frame, lengths, radii,
  // chain angles); along each joint's column its play (the direction of its last move) and a cubic
  // B-spline of its reading, knots every kKnotDeg (offset, scale, transmission error).
  columns_ = 2 + 3 * kMonomials + 3;
  for (std::size_t j = 0; j < 3; ++j) {
    knots_[j] = std::max(
        1, static_cast<int>(std::ceil(
               (alpha_hi_[static_cast<Eigen::Index>(j)] - alpha_lo_[static_cast<Eigen::Index>(j)]) / kKnotDeg)));
    spline_first_[j] = columns_;
    columns_ += knots_[j] + 3;
  }
  keep_.assign(m_, 1);
  residual_.resize(m_);
}

// The fit rows: no joint inside its play, the stage's log at least a second on either side;
// evenly thinned to at most kMaxFitRows.
void FineFit::select_rows(const std::vector<bool>& turned) {
  const std::vector<double>& run_t = logs_.run_t;
  auto usable = [&](std::size_t i) {
    const double tau = offset_ + (1 + rate_) * run_t[i];
    return !plate_.play_band[i] && !turned[i] && std::isfinite(plate_.position_m[i][0]) && tau > curve_.first() + 1.0 &&
           tau < curve_.last() - 1.0;
  };
  std::size_t covered = 0;
  for (std::size_t i = 0; i < n_; ++i) covered += usable(i) ? 1 : 0;
  const std::size_t stride = std::max<std::size_t>(1, (covered + kMaxFitRows - 1) / kMaxFitRows);
  std::size_t seen = 0;
  for (std::size_t i = 0; i < n_; ++i) {
    if (usable(i) && seen++ % stride == 0) rows_.push_back(i);
  }
  if (rows_.size() < 100 || run_t[rows_.back()] - run_t[rows_.front()] < kMinFitSpanS) {
    refuse(logs_.stage_path, "overlaps " + logs_.run_path + " by too little (at least " + fixed3(kMinFitSpanS) +
                                 " s of rows where no joint sits inside its play)");
  }
  m_ = rows_.size();
}

// The fit rows' Jacobians, means and reading ranges; each joint's resolution (the median of its
// steps).
void FineFit::measure_rows() {
  const std::vector<Vec3>& alpha = plate_.alpha_deg;
  const std::vector<Vec3>& p_enc = plate_.position_m;
  jacobian_.resize(m_);
  for (std::size_t r = 0; r < m_; ++r) {
    for (int j = 0; j < 3; ++j) {
      Vec3 a = alpha[rows_[r]];
      a[j] += 1e-4;
      const FkSolution fk = forward_kinematics(nominal_, a);
      jacobian_[r][j] = fk.ok() ? Vec3((fk.position_m - p_enc[rows_[r]]) / 1e-4) : Vec3(Vec3::Zero());
    }
  }
  t_mean_ = 0.0;
  p_mean_ = Vec3::Zero();
  alpha_lo_ = alpha[rows_.front()];
  alpha_hi_ = alpha_lo_;
  for (std::size_t i : rows_) {
    t_mean_ += logs_.run_t[i];
    p_mean_ += p_enc[i];
    alpha_lo_ = alpha_lo_.cwiseMin(alpha[i]);
    alpha_hi_ = alpha_hi_.cwiseMax(alpha[i]);
  }
  t_mean_ /= static_cast<double>(m_);
  p_mean_ /= static_cast<double>(m_);
  alpha_lo_ -= Vec3::Constant(kPlayMarginDeg);  // the readings with their play taken out lie within
  alpha_hi_ += Vec3::Constant(kPlayMarginDeg);
  half_span_ = 0.5 * (logs_.run_t[rows_.back()] - logs_.run_t[rows_.front()]);
  count_deg_ = Vec3::Constant(kEncoderResolutionDeg);
  for (int j = 0; j < 3; ++j) {
    std::vector<double> steps;
    for (std::size_t i = 1; i < n_; ++i) {
      const double step = std::abs(logs_.run_alpha_deg[i][j] - logs_.run_alpha_deg[i - 1][j]);
      if (step > 0) steps.push_back(step);
    }
    if (steps.empty()) continue;
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
    count_deg_[j] = steps[steps.size() / 2];
  }
}

void FineFit::take_out_play() {
  for (std::size_t r = 0; r < m_; ++r) {
    const std::size_t i = rows_[r];
    Vec3 a = plate_.alpha_deg[i];
    for (int j = 0; j < 3; ++j) a[j] += play_deg_[j] * plate_.direction[i][j];
    alpha_fit_[r] = a;
    const FkSolution fk = forward_kinematics(nominal_, a);
    p_fit_[r] = fk.ok() ? fk.position_m : plate_.position_m[i];
    for (std::size_t j = 0; j < 3; ++j) column_[r][j] = to_stage_ * jacobian_[r][j];
  }
}

// The design rows of fit row r (one per axis) at the stage velocity v, the nuisance columns
// negated (x theta = -target).
void FineFit::design(std::size_t r, const Vec3& velocity) {
  const std::size_t i = rows_[r];
  const std::array<double, kMonomials> mono = monomials((p_fit_[r] - p_mean_) / kMonomialScaleM);
  std::array<int, 3> first{};
  std::array<std::array<double, 4>, 3> weight{};
  for (std::size_t j = 0; j < 3; ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    const double u = (alpha_fit_[r][jj] - alpha_lo_[jj]) / kKnotDeg;
    const int k = std::clamp(static_cast<int>(std::floor(u)), 0, knots_[j] - 1);
    const double s = u - k, s2 = s * s, s3 = s2 * s;
    first[j] = spline_first_[j] + k;
    weight[j] = {(1 - s) * (1 - s) * (1 - s) / 6, (3 * s3 - 6 * s2 + 4) / 6, (-3 * s3 + 3 * s2 + 3 * s + 1) / 6,
                 s3 / 6};
  }
  for (int axis = 0; axis < 3; ++axis) {
    SparseRow& row = x_[static_cast<std::size_t>(axis)];
    row.size = 0;
    row.add(0, velocity[axis]);
    row.add(1, velocity[axis] * (logs_.run_t[i] - t_mean_));
    for (int k = 0; k < kMonomials; ++k) row.add(2 + kMonomials * axis + k, -mono[static_cast<std::size_t>(k)]);
    for (std::size_t j = 0; j < 3; ++j)
      row.add(2 + 3 * kMonomials + static_cast<int>(j), -column_[r][j][axis] * plate_.direction[i][j]);
    for (std::size_t j = 0; j < 3; ++j) {
      for (std::size_t b = 0; b < 4; ++b) row.add(first[j] + static_cast<int>(b), -column_[r][j][axis] * weight[j][b]);
    }
  }
}

// The normal equations at an alignment (centre: tau at t_mean).
void FineFit::accumulate(double at_centre, double at_rate, Normal* nm) {
  nm->h.setZero(columns_, columns_);
  nm->g.setZero(columns_);
  nm->used = 0;
  for (std::size_t r = 0; r < m_; ++r) {
    if (!keep_[r]) continue;
    Vec3 s, v;
    if (!curve_.at(at_centre + (1 + at_rate) * (logs_.run_t[rows_[r]] - t_mean_), &s, &v)) continue;
    ++nm->used;
    design(r, v);
    const Vec3 target = beyond_affine(r, s);
    for (int axis = 0; axis < 3; ++axis) x_[static_cast<std::size_t>(axis)].accumulate(-target[axis], &nm->h, &nm->g);
  }
}

// Solves the normal equations, columns scaled to a unit diagonal, with a ridge of 1e-9 on the
// nuisance (the monomials and the splines overlap: offsets, scales); timing false holds the
// alignment (its columns out).
Eigen::MatrixXd FineFit::solve(const Normal& nm, const Eigen::MatrixXd& g, bool timing) const {
  Eigen::VectorXd scale(columns_);
  for (Eigen::Index k = 0; k < columns_; ++k) {
    const double d = nm.h(k, k);
    scale[k] = d > 0 && (timing || k >= 2) ? 1.0 / std::sqrt(d) : 0.0;
  }
  Eigen::MatrixXd regularised = nm.h.selfadjointView<Eigen::Upper>();
  regularised = scale.asDiagonal() * regularised * scale.asDiagonal();
  for (Eigen::Index k = 0; k < columns_; ++k) regularised(k, k) = scale[k] > 0 && k >= 2 ? 1.0 + kRidge : 1.0;
  const Eigen::MatrixXd rhs = scale.asDiagonal() * g;
  return Eigen::MatrixXd(scale.asDiagonal() * regularised.ldlt().solve(rhs));
}

// Residuals (stage - model) of every fit row at an alignment with the nuisance theta (its timing
// part ignored; NaN outside the stage's log); returns the kept rows' sum of squares.
double FineFit::residuals(double at_centre, double at_rate, Eigen::VectorXd theta) {
  theta[0] = theta[1] = 0.0;
  double ss = 0.0;
  for (std::size_t r = 0; r < m_; ++r) {
    residual_[r] = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    Vec3 s, v;
    if (!curve_.at(at_centre + (1 + at_rate) * (logs_.run_t[rows_[r]] - t_mean_), &s, &v)) continue;
    design(r, v);
    const Vec3 target = beyond_affine(r, s);
    for (int axis = 0; axis < 3; ++axis)
      residual_[r][axis] = x_[static_cast<std::size_t>(axis)].dot(theta) + target[axis];
    if (keep_[r]) ss += residual_[r].squaredNorm();
  }
  return ss;
}

double FineFit::residual_rms_at(double centre, double rate) {
  Normal nm;
  accumulate(centre, rate, &nm);
  if (nm.used == 0) return std::numeric_limits<double>::infinity();
  return std::sqrt(residuals(centre, rate, solve(nm, nm.g, false).col(0)) / (3.0 * static_cast<double>(nm.used)));
}

void FineFit::refuse_if_short(const Normal& nm) const {
  if (nm.used < m_ / 2) {
    refuse(logs_.stage_path,
           "overlaps " + logs_.run_path + " by too little once aligned (" + std::to_string(nm.used) + " rows)");
  }
}

bool FineFit::diverged(double at_centre, double at_rate) const {
  return std::abs(at_centre - (offset_ + (1 + at_rate) * t_mean_)) > 5.0 || std::abs(at_rate) > 5e-3;
}

void FineFit::run() {
  centre_ = offset_ + (1 + rate_) * t_mean_;
  take_out_play();  // p_fit and the columns for the first pass's affine map
  for (int pass = 0; pass < kPasses; ++pass) {
    const bool hold = pass == 0;  // the first pass holds the coarse alignment: outliers first
    fit_affine();
    // Gauss-Newton on (centre, rate, play), the nuisance profiled out.
    accumulate(centre_, rate_, &normal_);
    refuse_if_short(normal_);
    const double cost =
        residuals(centre_, rate_, solve(normal_, normal_.g, false).col(0)) / static_cast<double>(normal_.used);
    if (!hold) gauss_newton(cost);
    if (diverged(centre_, rate_)) {
      refuse(logs_.stage_path, "does not belong with " + logs_.run_path + ": the clock alignment does not converge");
    }
    if (!drop_outliers(hold)) break;
  }
}

// The affine map from the encoders' plate to the stage's at the current alignment.
void FineFit::fit_affine() {
  Eigen::Matrix4d ata = Eigen::Matrix4d::Zero();
  Eigen::Matrix<double, 4, 3> atb = Eigen::Matrix<double, 4, 3>::Zero();
  for (std::size_t r = 0; r < m_; ++r) {
    Vec3 s, v;
    if (!keep_[r] || !curve_.at(centre_ + (1 + rate_) * (logs_.run_t[rows_[r]] - t_mean_), &s, &v)) continue;
    Eigen::Vector4d a;
    a << (p_fit_[r] - p_mean_) / kMonomialScaleM, 1.0;
    ata += a * a.transpose();
    atb += a * (s / kMonomialScaleM).transpose();
  }
  const Eigen::Matrix<double, 4, 3> affine = ata.ldlt().solve(atb);
  to_stage_ = affine.topRows<3>().transpose();
  stage_at_mean_ = affine.row(3).transpose() * kMonomialScaleM;
  take_out_play();
}

// Gauss-Newton steps on (centre, rate, play) from the residual per row `cost` at the current ones.
void FineFit::gauss_newton(double cost) {
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    const Eigen::VectorXd step = solve(normal_, normal_.g, true).col(0);
    const double d_centre = step[0], d_rate = step[1];
    const Vec3 d_play = step.segment<3>(2 + 3 * kMonomials);
    if (std::abs(d_centre) < kStepS && std::abs(d_rate) * half_span_ < kStepS && d_play.cwiseAbs().maxCoeff() < 1e-4) {
      break;
    }
    // The step times k: its residual per row (infinite where it leaves the logs). Longer steps
    // while they lower it (along a valley Gauss-Newton falls short), else shorter ones until one
    // does.
    const Vec3 play_before = play_deg_;
    Normal trial, best_normal;
    double best = cost, best_k = 0.0;
    auto consider = [&](double k) {
      const double try_centre = centre_ + k * d_centre, try_rate = rate_ + k * d_rate;
      if (diverged(try_centre, try_rate)) return false;
      play_deg_ = (play_before + k * d_play).cwiseMax(-kPlayMarginDeg).cwiseMin(kPlayMarginDeg);
      take_out_play();
      accumulate(try_centre, try_rate, &trial);
      if (trial.used < m_ / 2) return false;
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
    play_deg_ = (play_before + best_k * d_play).cwiseMax(-kPlayMarginDeg).cwiseMin(kPlayMarginDeg);
    take_out_play();
    if (best_k == 0.0) break;
    centre_ += best_k * d_centre;
    rate_ += best_k * d_rate;
    normal_ = std::move(best_normal);
    cost = best;
  }
}

// Outliers. A row off by more than kOutlier robust deviations drops the encoder holds it lies in,
// of every joint; a joint behind its reading (against its direction of motion, in joint space) by
// more than the reading's resolution or kBehind robust deviations drops its hold: it turned back
// inside its play and came out the same way, its reading held while the plate moved. The rows kept
// from now on: those outside the dropped holds (a row dropped on a rougher fit comes back once it
// fits). False when done: few rows change (or too few would be kept after the first pass).
bool FineFit::drop_outliers(bool hold) {
  residuals(centre_, rate_, solve(normal_, normal_.g, false).col(0));
  std::vector<double> magnitude;
  magnitude.reserve(3 * m_);
  std::vector<Vec3> joint_error(m_, Vec3::Zero());
  std::array<std::vector<double>, 3> joint_magnitude;
  for (std::size_t r = 0; r < m_; ++r) {
    if (!std::isfinite(residual_[r][0])) continue;
    Eigen::Matrix3d columns_r;
    for (std::size_t j = 0; j < 3; ++j) columns_r.col(static_cast<Eigen::Index>(j)) = column_[r][j];
    joint_error[r] = columns_r.partialPivLu().solve(residual_[r]);
    if (!keep_[r]) continue;
    for (std::size_t a = 0; a < 3; ++a) {
      magnitude.push_back(std::abs(residual_[r][static_cast<Eigen::Index>(a)]));
      joint_magnitude[a].push_back(std::abs(joint_error[r][static_cast<Eigen::Index>(a)]));
    }
  }
  const double sigma = kRobustSigma * median(&magnitude);
  Vec3 joint_sigma;
  for (std::size_t j = 0; j < 3; ++j)
    joint_sigma[static_cast<Eigen::Index>(j)] = kRobustSigma * median(&joint_magnitude[j]);
  const std::vector<Vec3>& reading = logs_.run_alpha_deg;
  std::vector<char> drop(n_, 0);
  auto drop_hold = [&](std::size_t i, int j) {
    std::size_t lo = i, hi = i;
    while (lo > 0 && reading[lo - 1][j] == reading[i][j]) --lo;
    while (hi + 1 < n_ && reading[hi + 1][j] == reading[i][j]) ++hi;
    std::fill(drop.begin() + static_cast<std::ptrdiff_t>(lo), drop.begin() + static_cast<std::ptrdiff_t>(hi + 1), 1);
  };
  for (std::size_t r = 0; r < m_; ++r) {
    if (!std::isfinite(residual_[r][0])) continue;
    const std::size_t i = rows_[r];
    if (residual_[r].cwiseAbs().maxCoeff() > kOutlier * sigma) {
      for (int j = 0; j < 3; ++j) drop_hold(i, j);
      continue;
    }
    for (int j = 0; j < 3; ++j) {
      if (plate_.direction[i][static_cast<std::size_t>(j)] * joint_error[r][j] <
          -std::min(kBehindCounts * count_deg_[j], kBehind * joint_sigma[j])) {
        drop_hold(i, j);
      }
    }
  }
  std::size_t changed = 0, kept = 0;
  for (std::size_t r = 0; r < m_; ++r) {
    const char now = drop[rows_[r]] ? 0 : 1;
    changed += now != keep_[r] ? 1 : 0;
    kept += static_cast<std::size_t>(now);
  }
  if (kept < m_ / 2) return hold;
  if (!hold && changed * 200 <= m_) return false;
  for (std::size_t r = 0; r < m_; ++r) keep_[r] = drop[rows_[r]] ? 0 : 1;
  return true;
}

// ---- residuals at the final alignment, the sandwich covariance over blocks ----
void FineFit::finish(MergeResult* out) {
  accumulate(centre_, rate_, &normal_);
  refuse_if_short(normal_);
  const Eigen::VectorXd theta = solve(normal_, normal_.g, false).col(0);
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(columns_, columns_);
  double ss = 0.0, motion = 0.0;
  std::size_t used = 0;
  {
    Eigen::VectorXd block = Eigen::VectorXd::Zero(columns_);
    double block_start = logs_.run_t[rows_.front()];
    std::vector<Vec3> positions;
    positions.reserve(m_);
    for (std::size_t r = 0; r < m_; ++r) {
      if (!keep_[r]) continue;
      const double t = logs_.run_t[rows_[r]];
      Vec3 s, v;
      if (!curve_.at(centre_ + (1 + rate_) * (t - t_mean_), &s, &v)) continue;
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
        const SparseRow& row = x_[static_cast<std::size_t>(axis)];
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
  out->fit_rows = used;
  out->residual_rms_m = std::sqrt(ss / (3.0 * used));
  out->motion_rms_m = std::sqrt(motion / (3.0 * used));
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(columns_, 2);
  unit(0, 0) = unit(1, 1) = 1.0;
  const Eigen::MatrixXd z = solve(normal_, unit, true);
  const Eigen::Matrix2d covariance = z.transpose() * meat * z;
  // The information on the offset and on the rate with the nuisance fitted (their profiled
  // curvatures) over that with the nuisance known.
  out->offset_signal_left = std::clamp(1.0 / (z(0, 0) * normal_.h(0, 0)), 0.0, 1.0);
  out->rate_signal_left = std::clamp(1.0 / (z(1, 1) * normal_.h(1, 1)), 0.0, 1.0);
  out->rate_ppm = rate_ * 1e6;
  out->offset_s = centre_ - (1 + rate_) * t_mean_;
  out->rate_sd_ppm = std::sqrt(std::max(0.0, covariance(1, 1))) * 1e6;
  out->offset_sd_s = std::sqrt(
      std::max(0.0, covariance(0, 0) + t_mean_ * t_mean_ * covariance(1, 1) - 2 * t_mean_ * covariance(0, 1)));
  if (out->residual_rms_m > kMaxResidualM || out->residual_rms_m > kMaxResidualOfMotion * out->motion_rms_m) {
    refuse(logs_.stage_path,
           "does not belong with " + logs_.run_path + ": aligned, the stage and the encoders' plate still differ by " +
               fixed3(out->residual_rms_m * 1e6) + " um RMS (motion " + fixed3(out->motion_rms_m * 1e6) + " um RMS)");
  }
}

}  // namespace delta::diagnosis::merging
