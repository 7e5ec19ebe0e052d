// Uniform scale of the measuring stage as a new effect: the vocabulary's lengths scaled together.
#include "measuring_scale.hpp"

#include <cmath>

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
  const std::vector<Sample> rows = unscaled(hysteresis ? data.fit : data.thinned_fit, scale);
  FitOptions options;
  options.noise_floor_deg = data.options.noise_floor_deg;
  evaluation.fit = fit_model(rows, families, start, start, options);
  evaluation.fit.theta = families.any() ? evaluation.fit.theta : start;
  const NormalEquations equations = evaluate(evaluation.fit.theta, families, rows, false);
  if (equations.ok) evaluation.cost = equations.sum_squares * static_cast<double>(data.fit.size()) / rows.size();
  return evaluation;
}

}  // namespace

std::vector<Sample> unscaled(const std::vector<Sample>& rows, double scale) {
  std::vector<Sample> result = rows;
  for (Sample& sample : result) sample.position_m /= (1.0 + scale);
  return result;
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
  model.scale = scale;
  model.families = others;
  FitOptions options;
  options.noise_floor_deg = data.options.noise_floor_deg;
  const std::vector<Sample> fit_rows = unscaled(data.fit, scale);
  model.theta = start;
  if (others.any()) {
    const FitResult refit = fit_model(fit_rows, others, middle.fit.theta, start, options);
    if (!refit.ok) return std::nullopt;
    model.theta = refit.theta;
    model.fit = refit;
  }
  const EffectSet effects = to_effect_set(model.theta, others);
  const Prediction fit_prediction = predict_recording(effects, fit_rows);
  const Prediction check_prediction = predict_recording(effects, unscaled(data.check, scale));
  if (fit_prediction.unreachable || check_prediction.unreachable) return std::nullopt;
  model.fit_prediction = fit_prediction.alpha_deg;
  model.check_prediction = check_prediction.alpha_deg;
  model.holdout_rmse = joint_rmse(data.check, model.check_prediction);
  // Cost = residual variance x (3 N - p) near the minimum; the curvature gives the variance of s.
  if (curvature > 0.0) {
    const double variance = middle.cost / (3.0 * data.fit.size());
    model.confidence_95 = 1.96 * std::sqrt(2.0 * variance / curvature);
  }
  return model;
}

}  // namespace delta::diagnosis
