// Scale of the measuring stage as a new effect: uniform (the vocabulary's lengths scaled together)
// or per axis.
#include "measuring_scale.hpp"

#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace delta::diagnosis {
namespace {

const FamilySet kLengths =
    single(Family::upper_arm_length) | single(Family::lower_arm_length) | single(Family::radius_offset);

struct Evaluation {
  double cost = 1e300;  // FIT sum of squares, deg^2
  FitResult fit;
};

// The other families refitted on FIT with positions divided by (1 + scale).
Evaluation evaluate_scale(const PipelineData& data, FamilySet families, const Parameters& start, double scale) {
  Evaluation evaluation;
  const bool hysteresis = families[index_of(Family::backlash)];
  const std::vector<Sample> rows = unscaled(hysteresis ? data.fit : data.thinned_fit, Vec3::Constant(scale));
  const FitOptions options = fit_options(data);
  evaluation.fit = fit_model(rows, families, start, start, options);
  evaluation.fit.theta = families.any() ? evaluation.fit.theta : start;
  const NormalEquations equations = evaluate(evaluation.fit.theta, families, rows, false);
  if (equations.ok) evaluation.cost = equations.sum_squares * static_cast<double>(data.fit.size()) / rows.size();
  return evaluation;
}

// Measured minus predicted angles of a model on the rows' positions unscaled; not ok when a row is
// unreachable.
struct Residuals {
  Eigen::VectorXd r;  // measured - predicted, 3 per row
  bool ok = false;
};
Residuals residuals(const EffectSet& effects, const std::vector<Sample>& rows, const Vec3& scale) {
  Residuals result;
  const Prediction prediction = predict_recording(effects, unscaled(rows, scale));
  if (prediction.unreachable > 0) return result;
  result.r.resize(3 * static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (int j = 0; j < 3; ++j)
      result.r[3 * static_cast<Eigen::Index>(i) + j] = rows[i].alpha_deg[j] - prediction.alpha_deg[i][j];
  }
  result.ok = true;
  return result;
}

// Gauss-Newton on the three scales with the other families held; the Jacobian by central
// differences. Returns false when a row becomes unreachable.
bool step_scales(const EffectSet& effects, const std::vector<Sample>& rows, Vec3& scale, Eigen::Matrix3d& jtj) {
  const double h = 1e-5;
  Eigen::MatrixXd jacobian(3 * static_cast<Eigen::Index>(rows.size()), 3);
  for (int axis = 0; axis < 3; ++axis) {
    Vec3 up = scale, down = scale;
    up[axis] += h;
    down[axis] -= h;
    const Residuals high = residuals(effects, rows, up), low = residuals(effects, rows, down);
    if (!high.ok || !low.ok) return false;
    jacobian.col(axis) = (high.r - low.r) / (2.0 * h);
  }
  const Residuals here = residuals(effects, rows, scale);
  if (!here.ok) return false;
  jtj = jacobian.transpose() * jacobian;
  const Vec3 delta = jtj.ldlt().solve(-jacobian.transpose() * here.r);
  if (!delta.allFinite()) return false;
  scale += delta;
  return true;
}

// The scale model's other families refitted from `refit_from` on every FIT row unscaled (prior
// `start`), and its FIT and CHECK predictions; false when the refit fails or a row is unreachable.
bool finish_scale_model(const PipelineData& data, const Parameters& start, const Parameters& refit_from,
                        ScaleModel& model) {
  const std::vector<Sample> fit_rows = unscaled(data.fit, model.scale);
  if (model.families.any()) {
    const FitOptions options = fit_options(data);
    const FitResult refit = fit_model(fit_rows, model.families, refit_from, start, options);
    if (!refit.ok) return false;
    model.theta = refit.theta;
    model.fit = refit;
  }
  const EffectSet effects = to_effect_set(model.theta, model.families);
  const Prediction fit_prediction = predict_recording(effects, fit_rows);
  const Prediction check_prediction = predict_recording(effects, unscaled(data.check, model.scale));
  if (fit_prediction.unreachable || check_prediction.unreachable) return false;
  model.fit_prediction = fit_prediction.alpha_deg;
  model.check_prediction = check_prediction.alpha_deg;
  model.holdout_rmse = joint_rmse(data.check, model.check_prediction);
  return true;
}

}  // namespace

std::vector<Sample> unscaled(const std::vector<Sample>& rows, const Vec3& scale) {
  std::vector<Sample> result = rows;
  const Vec3 divisor = Vec3::Ones() + scale;
  for (Sample& sample : result) sample.position_m = sample.position_m.cwiseQuotient(divisor);
  return result;
}

FamilySet scale_imitators() { return kLengths | single(Family::encoder_scale) | single(Family::frame_misalignment); }

std::optional<ScaleModel> fit_axis_scale(const PipelineData& data, FamilySet others, const Parameters& theta) {
  const Parameters start = without_families(theta, ~others);
  const bool hysteresis = others[index_of(Family::backlash)];
  const std::vector<Sample>& screening = hysteresis ? data.fit : data.thinned_fit;
  const FitOptions options = fit_options(data);
  ScaleModel model;
  model.per_axis = true;
  model.families = others;
  model.theta = start;
  Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
  // Scales and other families alternately: three rounds of two Gauss-Newton steps and a refit.
  for (int round = 0; round < 3; ++round) {
    const EffectSet effects = to_effect_set(model.theta, others);
    for (int step = 0; step < 2; ++step) {
      if (!step_scales(effects, screening, model.scale, jtj)) return std::nullopt;
    }
    if (!(model.scale.cwiseAbs().maxCoeff() < 0.1)) return std::nullopt;  // no stage is 10 % off
    if (others.any()) {
      const FitResult refit = fit_model(unscaled(screening, model.scale), others, model.theta, start, options);
      if (!refit.ok) return std::nullopt;
      model.theta = refit.theta;
    }
  }
  if (!finish_scale_model(data, start, model.theta, model)) return std::nullopt;
  // Covariance of the scales: residual variance on the screening rows times (J^T J)^-1.
  double sum_squares = 0.0;
  for (std::size_t i = 0; i < data.fit.size(); ++i)
    sum_squares += (data.fit[i].alpha_deg - model.fit_prediction[i]).squaredNorm();
  const double variance = sum_squares / (3.0 * static_cast<double>(data.fit.size()));
  const double rows_ratio = static_cast<double>(data.fit.size()) / static_cast<double>(screening.size());
  const Eigen::Matrix3d covariance = variance * (rows_ratio * jtj).inverse();
  model.confidence_95 = 1.96 * covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  return model;
}

std::optional<ScaleModel> fit_measuring_scale(const PipelineData& data, FamilySet chosen, const Parameters& theta) {
  if ((chosen & kLengths).none()) return std::nullopt;
  // Least-squares common relative change k of the present length families (mm over mm).
  const std::pair<int, double> lengths[3] = {{slot::upper_arm, 40.0}, {slot::lower_arm, 68.0}, {slot::radius, 10.0}};
  const Family families_of_lengths[3] = {Family::upper_arm_length, Family::lower_arm_length, Family::radius_offset};
  double numerator = 0.0, denominator = 0.0, total = 0.0;
  for (int l = 0; l < 3; ++l) {
    if (!chosen[index_of(families_of_lengths[l])]) continue;
    for (int j = 0; j < 3; ++j) {
      const double change = theta[lengths[l].first + j];
      numerator += lengths[l].second * change;
      denominator += lengths[l].second * lengths[l].second;
      total += change * change;
    }
  }
  const double k = numerator / denominator;
  if (total <= 0.0 || k * k * denominator < 0.9 * total) return std::nullopt;

  const FamilySet others = chosen & ~kLengths;
  const Parameters start = without_families(theta, kLengths);
  // Parabola through the FIT cost at three scales around k.
  const double step = std::max(0.05 * std::abs(k), 1e-5);
  const Evaluation low = evaluate_scale(data, others, start, k - step);
  const Evaluation middle = evaluate_scale(data, others, start, k);
  const Evaluation high = evaluate_scale(data, others, start, k + step);
  const double curvature = (low.cost - 2.0 * middle.cost + high.cost) / (step * step);
  double scale = k;
  if (curvature > 0.0) scale = k - 0.5 * (high.cost - low.cost) / step / curvature;
  if (!(std::abs(scale - k) <= 4.0 * step)) scale = k;

  ScaleModel model;
  model.scale = Vec3::Constant(scale);
  model.families = others;
  model.theta = start;
  if (!finish_scale_model(data, start, middle.fit.theta, model)) return std::nullopt;
  // Cost = residual variance x (3 N - p) near the minimum; the curvature gives the variance of s.
  if (curvature > 0.0) {
    const double variance = middle.cost / (3.0 * data.fit.size());
    model.confidence_95 = Vec3::Constant(1.96 * std::sqrt(2.0 * variance / curvature));
  }
  return model;
}

}  // namespace delta::diagnosis
