// Fitting and scoring one candidate family set (shared by every step of the diagnosis).
#include "candidate.hpp"

#include <algorithm>

namespace delta::diagnosis {

double mean_square(const Vec3& rmse) { return rmse.squaredNorm() / 3.0; }

Vec3 joint_rmse(const std::vector<Sample>& rows, const std::vector<Vec3>& predicted) {
  Vec3 sum = Vec3::Zero();
  for (std::size_t i = 0; i < rows.size(); ++i) sum += (rows[i].alpha_deg - predicted[i]).cwiseAbs2();
  return (sum / static_cast<double>(std::max<std::size_t>(rows.size(), 1))).cwiseSqrt();
}

std::vector<Sample> thin_out(const std::vector<Sample>& rows, std::size_t stride) {
  std::vector<Sample> thinned;
  for (std::size_t i = 0; i < rows.size(); i += std::max<std::size_t>(stride, 1)) thinned.push_back(rows[i]);
  return thinned;
}

NoiseModel pipeline_noise_model(const PipelineData& data, const std::vector<Sample>& fit_rows,
                                const std::vector<Vec3>& fit_prediction) {
  return noise_model(fit_rows, fit_prediction, data.check, data.options.noise_floor_deg, !data.fit_closed_loop);
}

FitOptions fit_options(const DiagnosisOptions& options) {
  FitOptions fit;
  fit.noise_floor_deg = options.noise_floor_deg;
  fit.realistic_prior_observations = options.prior_observations;
  return fit;
}

FitOptions fit_options(const PipelineData& data, Periods periods) {
  FitOptions options = fit_options(data.options);
  // Once the long ripples' periods are chosen (on CHECK, selection.cpp), every later fit holds them.
  options.hold_periods = periods == Periods::held || (periods == Periods::usual && data.long_ripples);
  if (periods != Periods::usual || data.long_ripples) {
    options.max_iterations = std::max(options.max_iterations, kLongValleyIterations);
  }
  return options;
}

Candidate fit_and_check(const PipelineData& data, FamilySet families, const Parameters& start, Periods periods) {
  Candidate candidate;
  const bool hysteresis = families[index_of(Family::backlash)];
  const FitOptions options = fit_options(data, periods);
  candidate.fit = fit_model(hysteresis ? data.fit : data.thinned_fit, families, start, start, options);
  if (!candidate.fit.ok) return candidate;
  Prediction prediction = predict_recording(to_effect_set(candidate.fit.theta, families), data.check);
  candidate.holdout_rmse = joint_rmse(data.check, prediction.alpha_deg);
  candidate.check_prediction = std::move(prediction.alpha_deg);
  candidate.ok = prediction.unreachable == 0 && candidate.holdout_rmse.allFinite();
  return candidate;
}

Parameters without_families(Parameters theta, FamilySet families) {
  for (int k : parameter_indices(families)) theta[k] = neutral_parameters()[k];
  return theta;
}

}  // namespace delta::diagnosis
