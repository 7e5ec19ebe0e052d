// diagnose(): the diagnosis as a sequence of steps (outliers, selection, final fit, floor test,
// alternatives, ranking, location, identifiability); each step lives in its own file.
#include "delta/diagnosis/diagnose.hpp"

#include <chrono>
#include <cmath>

#include "alternatives.hpp"
#include "attribution.hpp"
#include "candidate.hpp"
#include "floor_test.hpp"
#include "identifiability.hpp"
#include "outliers.hpp"
#include "selection.hpp"

namespace delta::diagnosis {
namespace {

// The nominal model scored on the kept CHECK rows, as a candidate the selection starts from.
Candidate nominal_candidate(const std::vector<Sample>& check) {
  Candidate nominal;
  nominal.ok = true;
  nominal.fit.theta = neutral_parameters();
  nominal.check_prediction = predict_recording(EffectSet{}, check).alpha_deg;
  nominal.holdout_rmse = joint_rmse(check, nominal.check_prediction);
  return nominal;
}

// Of the held-out MSE above the floor, the part the final model removes.
double explained_fraction(const Vec3& nominal_rmse, const Vec3& after_rmse, double floor_deg) {
  const double floor_square = floor_deg * floor_deg;
  const double before = nominal_rmse.squaredNorm() / 3.0 - floor_square;
  const double after = std::max(after_rmse.squaredNorm() / 3.0 - floor_square, 0.0);
  return before > 0.0 ? std::clamp(1.0 - after / before, 0.0, 1.0) : 1.0;
}

}  // namespace

Diagnosis diagnose(const std::vector<Sample>& fit, const std::vector<Sample>& check, const DiagnosisOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  Diagnosis diagnosis;
  diagnosis.noise_floor_deg = options.noise_floor_deg;
  const double encoder_step_deg = options.noise_floor_deg * std::sqrt(12.0);

  // 1. Outlier rows (stage or encoder glitches) leave both recordings before anything is fitted.
  const std::vector<Outlier> fit_outliers = find_outliers(fit, "FIT", encoder_step_deg);
  const std::vector<Outlier> check_outliers = find_outliers(check, "CHECK", encoder_step_deg);
  diagnosis.outliers = fit_outliers;
  diagnosis.outliers.insert(diagnosis.outliers.end(), check_outliers.begin(), check_outliers.end());
  PipelineData data;
  data.options = options;
  data.fit = without_outliers(fit, fit_outliers);
  data.check = without_outliers(check, check_outliers);
  data.thinned_fit = thin_out(data.fit, options.screening_stride);
  data.threshold_deg2 = options.significance * options.noise_floor_deg * options.noise_floor_deg;
  diagnosis.significance_threshold_deg2 = data.threshold_deg2;

  // 2. Selection of the families by held-out error.
  const Candidate nominal = nominal_candidate(data.check);
  diagnosis.fit_rmse_nominal_deg = joint_rmse(data.fit, predict_recording(EffectSet{}, data.fit).alpha_deg);
  diagnosis.holdout_rmse_nominal_deg = nominal.holdout_rmse;
  const Selection selection = select_families(data, nominal);
  diagnosis.steps = selection.steps;
  diagnosis.eliminated = selection.eliminated;

  // 3. The kept model, refitted on every kept FIT row; its covariance gives the intervals.
  FitResult final_fit;
  final_fit.theta = selection.theta;
  final_fit.families = selection.families;
  if (selection.families.any()) {
    FitOptions fit_options;
    fit_options.noise_floor_deg = options.noise_floor_deg;
    const FitResult refit = fit_model(data.fit, selection.families, selection.theta, selection.theta, fit_options);
    if (refit.ok) final_fit = refit;
    diagnosis.confidence_95 = confidence_half_widths(final_fit, data.fit.size());
  }
  diagnosis.significant = selection.families;
  diagnosis.theta = without_families(final_fit.theta, ~selection.families);
  diagnosis.fitted_effects = to_effect_set(diagnosis.theta, selection.families);

  // 4. Predictions: every CHECK row for PRED.csv and the plots, the kept rows for the statistics.
  const Prediction full_check = predict_recording(diagnosis.fitted_effects, check);
  diagnosis.check_nominal_deg = predict_recording(EffectSet{}, check).alpha_deg;
  diagnosis.check_after_deg = full_check.alpha_deg;
  diagnosis.check_unreachable = full_check.unreachable;
  const std::vector<Vec3> fit_after = predict_recording(diagnosis.fitted_effects, data.fit).alpha_deg;
  const std::vector<Vec3> check_after = predict_recording(diagnosis.fitted_effects, data.check).alpha_deg;
  diagnosis.fit_rmse_after_deg = joint_rmse(data.fit, fit_after);
  diagnosis.holdout_rmse_after_deg = joint_rmse(data.check, check_after);
  diagnosis.explained_fraction = explained_fraction(diagnosis.holdout_rmse_nominal_deg,
                                                    diagnosis.holdout_rmse_after_deg, options.noise_floor_deg);

  // 5. The floor test decides `explained`; an excess is located.
  const NoiseModel noise = noise_model(data.fit, fit_after, data.check, options.noise_floor_deg);
  diagnosis.floor_test = floor_test(data.check, check_after, noise, options);
  diagnosis.explained = diagnosis.floor_test.at_floor;
  if (!diagnosis.explained) diagnosis.unexplained = locate_unexplained(data.check, check_after, noise);

  // 6. Other sets the held-out data cannot tell from the chosen one.
  diagnosis.alternatives = find_alternatives(data, selection.families, diagnosis.theta, check_after, noise,
                                             diagnosis.floor_test.at_floor);

  // 7. Ranking and location of the gap.
  diagnosis.findings = rank_findings(data, selection, diagnosis, diagnosis.holdout_rmse_after_deg, fit_after);
  diagnosis.subsystem_rmse_without_deg = subsystem_errors(data.check, selection.families, diagnosis.theta);
  diagnosis.regions = region_errors(data.check, nominal.check_prediction, check_after);

  // 8. What the data cannot tell apart.
  diagnosis.final_model = analyse_identifiability(data.fit, selection.families, diagnosis.theta);
  FamilySet everything;
  everything.set();
  if (!selection.families[index_of(Family::transmission_error)]) everything.reset(index_of(Family::transmission_error));
  Parameters probe = diagnosis.theta;
  // Backlash of exactly zero hides its column's sign; a tiny width makes the direction visible.
  for (int j = 0; j < 3; ++j) probe[slot::backlash + j] = std::max(probe[slot::backlash + j], 0.01);
  diagnosis.all_families = analyse_identifiability(data.fit, everything, probe);
  diagnosis.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return diagnosis;
}

}  // namespace delta::diagnosis
