// diagnose(): the diagnosis as a sequence of steps (outliers, selection, final fit, floor test,
// alternatives, ranking, location, a new effect, identifiability); each step lives in its own file.
#include "delta/diagnosis/diagnose.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "delta/kinematics.hpp"

#include "alternatives.hpp"
#include "attribution.hpp"
#include "candidate.hpp"
#include "closed_loop.hpp"
#include "floor_test.hpp"
#include "identifiability.hpp"
#include "measuring_scale.hpp"
#include "outliers.hpp"
#include "selection.hpp"

namespace delta::diagnosis {
namespace {

Vec3 joint_travel(const std::vector<Sample>& rows) {
  if (rows.empty()) return Vec3::Zero();
  Vec3 low = rows.front().alpha_deg, high = low;
  for (const Sample& row : rows) {
    low = low.cwiseMin(row.alpha_deg);
    high = high.cwiseMax(row.alpha_deg);
  }
  return high - low;
}

// A joint's turn between two kept rows that a play can hold: the angle goes beyond both ends by
// more than this (a tenth of an encoder count; a stage's noise moves the angle by 1e-5 deg).
constexpr double kTurnDeg = 0.001;

// Closed-loop telemetry (closed_loop.hpp): the model is fitted to (or judged on) the angle behind
// each reading, the reading less the lead the controller holds it at. Whether a recording is one
// is told from its readings (a drag's seldom turn back; 10 Hz recordings are never telemetry).
// With `diagnosis` (FIT), each row's fit_weight and which rows of each joint count
// (closed_loop::fit_weights) go there too, and with `motion` each row's time, speed and direction.
struct Motion {
  std::vector<double> t_s;
  closed_loop::Readings readings;  // speed_deg_s and way (angle_deg left empty)
};

bool correct_closed_loop(std::vector<Sample>& samples, double count_deg, Diagnosis* diagnosis = nullptr,
                         Motion* motion = nullptr) {
  std::vector<double> t(samples.size());
  std::vector<Vec3> reading(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    t[i] = samples[i].t_s;
    reading[i] = samples[i].alpha_deg;
  }
  closed_loop::Readings readings = closed_loop::read_closed_loop(t, reading, count_deg);
  if (!readings.closed_loop) return false;
  for (std::size_t i = 0; i < samples.size(); ++i) samples[i].alpha_deg = readings.angle_deg[i];
  if (diagnosis) {
    const closed_loop::FitWeights weights = closed_loop::fit_weights(t, readings);
    for (std::size_t i = 0; i < samples.size(); ++i) samples[i].fit_weight = weights.weight[i];
    diagnosis->fit_closed_loop = true;
    diagnosis->fit_rows = weights.joints;
  }
  if (motion) {
    motion->t_s = std::move(t);
    readings.angle_deg.clear();  // in the samples now
    motion->readings = std::move(readings);
  }
  return true;
}

// The slower rows of the joints fitted on their fast rows only (closed_loop.hpp), back in the fit:
// each shifted along its direction of motion by what the model those fast rows gave (`predicted`)
// leaves there on average, per band of speed (closed_loop::kLeads' speeds): the arm's place in the
// play that the stage cannot follow, so that these rows inform the geometry and no longer narrow
// the play. A band with fewer than kLeastBandRows rows stays out. `motion`: the times, speeds and
// directions of FIT's rows before thinning (time order). Returns the largest shift per joint.
constexpr std::size_t kLeastBandRows = 50;

Vec3 restore_slow_rows(std::vector<Sample>& fit, const std::vector<Vec3>& predicted, const Motion& motion) {
  constexpr std::size_t kBands = closed_loop::kLeads.size();
  constexpr std::size_t kNoBand = kBands;  // a row that counts already, or one that never moved
  const std::vector<double>& t = motion.t_s;
  std::vector<std::size_t> source(fit.size());
  for (std::size_t i = 0; i < fit.size(); ++i) {
    const auto at = std::lower_bound(t.begin(), t.end(), fit[i].t_s);
    source[i] =
        static_cast<std::size_t>(std::min<std::ptrdiff_t>(at - t.begin(), static_cast<std::ptrdiff_t>(t.size()) - 1));
  }
  Vec3 largest = Vec3::Zero();
  std::vector<std::size_t> band(fit.size());
  for (int j = 0; j < 3; ++j) {
    std::array<double, kBands> sum{};
    std::array<std::size_t, kBands> rows{};
    for (std::size_t i = 0; i < fit.size(); ++i) {
      const double way = motion.readings.way[source[i]][j];
      band[i] = kNoBand;
      if (fit[i].fit_weight[j] != 0.0 || way == 0.0) continue;
      const double speed = motion.readings.speed_deg_s[source[i]][j];
      band[i] = 0;
      while (band[i] + 1 < kBands && speed >= closed_loop::kLeads[band[i] + 1].speed_deg_s) ++band[i];
      sum[band[i]] += way * (fit[i].alpha_deg[j] - predicted[i][j]);
      ++rows[band[i]];
    }
    for (std::size_t i = 0; i < fit.size(); ++i) {
      if (band[i] == kNoBand || rows[band[i]] < kLeastBandRows) continue;
      const double way = motion.readings.way[source[i]][j];
      const double shift = sum[band[i]] / static_cast<double>(rows[band[i]]);
      fit[i].alpha_deg[j] -= way * shift;
      fit[i].fit_weight[j] = 1.0;
      largest[j] = std::max(largest[j], std::abs(shift));
    }
  }
  return largest;
}

// Every k-th row, plus, between two kept rows, the rows where a joint's angle (nominal inverse
// kinematics of the plate) turns beyond both of them by more than kTurnDeg: a play's state
// follows the input's extremes, and a closed-loop run's plate turns back and forth inside the play
// every few milliseconds (the controller's dither), far more often than every k-th row sees. A
// drag moves one way between kept rows and adds nothing. k is the smallest that leaves at most
// `rows` rows with the turns (the first row kept).
std::vector<Sample> thin_to(std::vector<Sample> samples, std::size_t rows) {
  if (rows == 0 || samples.size() <= rows) return samples;
  const std::size_t n = samples.size();
  const Geometry nominal = Geometry::nominal();
  std::vector<Vec3> angle(n);
  for (std::size_t i = 0; i < n; ++i) {
    const IkSolution ik = inverse_kinematics(nominal, samples[i].position_m);
    angle[i] = ik.ok() ? ik.alpha_deg : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  auto thin = [&](std::size_t stride) {
    std::vector<std::size_t> kept = {0};
    for (std::size_t end = stride; end < n + stride; end += stride) {
      const std::size_t last = std::min(end, n - 1), begin = kept.back();
      if (last <= begin) break;
      std::vector<std::size_t> turns;
      for (int j = 0; j < 3; ++j) {
        const double a = angle[begin][j], b = angle[last][j];
        if (!std::isfinite(a) || !std::isfinite(b)) continue;
        std::size_t high = begin, low = begin;
        for (std::size_t i = begin + 1; i < last; ++i) {
          if (angle[i][j] > angle[high][j]) high = i;
          if (angle[i][j] < angle[low][j]) low = i;
        }
        if (angle[high][j] > std::max(a, b) + kTurnDeg) turns.push_back(high);
        if (angle[low][j] < std::min(a, b) - kTurnDeg) turns.push_back(low);
      }
      std::sort(turns.begin(), turns.end());
      turns.erase(std::unique(turns.begin(), turns.end()), turns.end());
      kept.insert(kept.end(), turns.begin(), turns.end());
      if (end < n) kept.push_back(last);
    }
    return kept;
  };
  std::size_t stride = (n + rows - 1) / rows;
  std::vector<std::size_t> kept = thin(stride);
  while (kept.size() > rows) {
    stride = stride * kept.size() / rows + 1;
    kept = thin(stride);
  }
  std::vector<Sample> result;
  result.reserve(kept.size());
  for (std::size_t i : kept) result.push_back(samples[i]);
  return result;
}

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

struct FinalModel {
  std::vector<Vec3> fit_prediction;    // kept FIT rows
  std::vector<Vec3> check_prediction;  // kept CHECK rows
};

// Refits `families` on every kept FIT row and fills the final model's part of the diagnosis:
// parameters and intervals, predictions, RMSE, floor test, location of an excess, alternatives.
FinalModel finish_model(const PipelineData& data, FamilySet families, const Parameters& theta,
                        const std::vector<Sample>& all_check, Diagnosis& diagnosis) {
  const DiagnosisOptions& options = data.options;
  FitResult final_fit;
  final_fit.theta = theta;
  final_fit.families = families;
  diagnosis.confidence_95 = Parameters::Zero();
  if (families.any()) {
    const FitResult refit = fit_model(data.fit, families, theta, theta, fit_options(data));
    if (refit.ok) final_fit = refit;
    diagnosis.confidence_95 = confidence_half_widths(final_fit, data.fit.size());
  }
  diagnosis.significant = families;
  diagnosis.theta = without_families(final_fit.theta, ~families);
  diagnosis.fitted_effects = to_effect_set(diagnosis.theta, families);

  // Every CHECK row for PRED.csv and the plots, the kept rows for the statistics.
  const Prediction full_check = predict_recording(diagnosis.fitted_effects, all_check);
  diagnosis.check_after_deg = full_check.alpha_deg;
  diagnosis.check_unreachable = full_check.unreachable;
  FinalModel model;
  model.fit_prediction = predict_recording(diagnosis.fitted_effects, data.fit).alpha_deg;
  model.check_prediction = predict_recording(diagnosis.fitted_effects, data.check).alpha_deg;
  diagnosis.fit_rmse_after_deg = joint_rmse(data.fit, model.fit_prediction);
  diagnosis.holdout_rmse_after_deg = joint_rmse(data.check, model.check_prediction);
  diagnosis.explained_fraction =
      explained_fraction(diagnosis.holdout_rmse_nominal_deg, diagnosis.holdout_rmse_after_deg, options.noise_floor_deg);

  // The floor test decides `explained`; an excess is located.
  const NoiseModel noise = pipeline_noise_model(data, data.fit, model.fit_prediction);
  diagnosis.floor_test = floor_test(data.check, model.check_prediction, noise, options);
  diagnosis.explained = diagnosis.floor_test.at_floor;
  diagnosis.unexplained =
      diagnosis.explained ? UnexplainedResidual{} : locate_unexplained(data.check, model.check_prediction, noise);
  // Alternatives only where the floor is in reach: far above it (an effect outside the vocabulary)
  // the search costs seconds and names nothing useful.
  diagnosis.alternatives.clear();
  const bool near_floor =
      diagnosis.holdout_rmse_after_deg.maxCoeff() <= options.near_floor_ratio * options.noise_floor_deg;
  if (diagnosis.floor_test.at_floor || near_floor) {
    diagnosis.alternatives = find_alternatives(data, families, diagnosis.theta, model.check_prediction, noise,
                                               diagnosis.floor_test.at_floor);
  }
  return model;
}

// The selection's result replaced by another family set (kept families keep their rank).
void adopt(Selection& selection, FamilySet families, const Parameters& theta) {
  std::vector<Family> order;
  for (Family family : selection.order) {
    if (families[index_of(family)]) order.push_back(family);
  }
  for (int f = 0; f < kFamilyCount; ++f) {
    if (families[f] && !selection.families[f]) order.push_back(family_at(f));
  }
  selection.order = order;
  selection.families = families;
  selection.theta = theta;
  selection.path_changed = true;
}

// A measuring scale in place of the families that imitate it, when it does as well on CHECK with
// fewer parameters (or reaches the floor where they do not): the new effect becomes part of the
// final model, the vocabulary-only set its first alternative. Returns whether it was adopted.
bool adopt_measuring_scale(const PipelineData& data, const std::vector<Sample>& all_check, Diagnosis& diagnosis,
                           const std::vector<Vec3>& chosen_check, const std::optional<ScaleModel>& model) {
  if (!model) return false;
  const DiagnosisOptions& options = data.options;
  const NoiseModel noise = pipeline_noise_model(data, unscaled(data.fit, model->scale), model->fit_prediction);
  const FloorTest test = floor_test(data.check, model->check_prediction, noise, options);
  const PairedDifference difference =
      paired_difference(data.check, model->check_prediction, chosen_check, options.batch_rows);
  if (!test.at_floor || (diagnosis.floor_test.at_floor && difference.z > options.paired_z)) return false;
  const std::size_t parameters = parameter_indices(model->families).size() + (model->per_axis ? 3 : 1);
  if (diagnosis.floor_test.at_floor && parameters >= parameter_indices(diagnosis.significant).size()) return false;

  Alternative vocabulary;
  vocabulary.families = diagnosis.significant;
  vocabulary.theta = diagnosis.theta;
  vocabulary.holdout_rmse_deg = diagnosis.holdout_rmse_after_deg;
  vocabulary.mse_difference_deg2 = -difference.mean_deg2;
  vocabulary.paired_z = -difference.z;
  vocabulary.at_floor = diagnosis.floor_test.at_floor;
  vocabulary.separate_by =
      model->per_axis
          ? "a scale of one measuring-stage axis is imitated by encoder scales, the frame and the lengths together: "
            "check the stage's axes against a gauge block"
          : "a uniform scale of the measuring stage equals every robot length scaled the other way: "
            "measure one arm (calipers) or check the stage against a gauge block";
  // The vocabulary-only set stays an alternative where CHECK cannot tell it from the new effect;
  // where the new effect predicts CHECK significantly better, it and the sets found equivalent to
  // it go.
  if (vocabulary.at_floor && std::abs(difference.z) <= options.paired_z) {
    diagnosis.alternatives.insert(diagnosis.alternatives.begin(), vocabulary);
  } else {
    std::string replaced = describe(diagnosis.significant);
    for (const Alternative& alternative : diagnosis.alternatives) replaced += "; " + describe(alternative.families);
    diagnosis.eliminated.push_back(
        {std::nullopt, replaced, "replaced by measuring_scale, which predicts CHECK significantly better"});
    diagnosis.alternatives.clear();
  }

  NewEffect effect;
  effect.name = "measuring_scale";
  effect.subsystem = "measuring frame";
  effect.per_axis = model->per_axis;
  effect.scale = model->scale;
  effect.confidence_95 = model->confidence_95;
  effect.holdout_rmse_deg = model->holdout_rmse;
  diagnosis.new_effects = {effect};
  diagnosis.measuring_scale = model->scale;
  for (EffectFinding& finding : diagnosis.findings) {
    if (!finding.significant) continue;
    finding.significant = model->families[index_of(finding.family)];
    if (finding.significant) finding.theta = model->theta;
  }
  diagnosis.significant = model->families;
  diagnosis.theta = without_families(model->theta, ~model->families);
  diagnosis.confidence_95 =
      model->families.any() ? confidence_half_widths(model->fit, data.fit.size()) : Parameters::Zero();
  diagnosis.fitted_effects = to_effect_set(diagnosis.theta, model->families);
  const Prediction full_check = predict_recording(diagnosis.fitted_effects, unscaled(all_check, model->scale));
  diagnosis.check_after_deg = full_check.alpha_deg;
  diagnosis.check_unreachable = full_check.unreachable;
  diagnosis.fit_rmse_after_deg = joint_rmse(data.fit, model->fit_prediction);
  diagnosis.holdout_rmse_after_deg = model->holdout_rmse;
  diagnosis.explained_fraction =
      explained_fraction(diagnosis.holdout_rmse_nominal_deg, diagnosis.holdout_rmse_after_deg, options.noise_floor_deg);
  diagnosis.floor_test = test;
  diagnosis.explained = test.at_floor;
  diagnosis.unexplained = UnexplainedResidual{};
  const std::vector<Sample> check_rows = unscaled(data.check, model->scale);
  diagnosis.subsystem_rmse_without_deg = subsystem_errors(check_rows, model->families, diagnosis.theta);
  diagnosis.regions =
      region_errors(data.check, predict_recording(EffectSet{}, data.check).alpha_deg, model->check_prediction);
  return true;
}

// A uniform scale where the length families look like one; else a scale per axis where the chosen
// set holds families that imitate one or leaves a residual above the floor, fitted with the chosen
// set's other families and alone, the better on CHECK (measuring_scale.hpp).
void try_measuring_scale(const PipelineData& data, const std::vector<Sample>& all_check, Diagnosis& diagnosis,
                         const std::vector<Vec3>& chosen_check) {
  if (adopt_measuring_scale(data, all_check, diagnosis, chosen_check,
                            fit_measuring_scale(data, diagnosis.significant, diagnosis.theta))) {
    return;
  }
  if ((diagnosis.significant & scale_imitators()).none() && diagnosis.floor_test.at_floor) return;
  std::optional<ScaleModel> best;
  const FamilySet others = diagnosis.significant & ~scale_imitators();
  std::vector<FamilySet> candidates = {others};
  if (others.any()) candidates.push_back(FamilySet{});
  for (const FamilySet families : candidates) {
    std::optional<ScaleModel> model = fit_axis_scale(data, families, diagnosis.theta);
    if (model && (!best || mean_square(model->holdout_rmse) < mean_square(best->holdout_rmse))) best = std::move(model);
  }
  adopt_measuring_scale(data, all_check, diagnosis, chosen_check, best);
}

// An alternative that reaches the floor when the chosen set does not, or predicts CHECK
// significantly better, replaces the chosen set (greedy selection can stop one swap short).
bool adopt_better_alternative(const DiagnosisOptions& options, Selection& selection, Diagnosis& diagnosis) {
  const auto better =
      std::find_if(diagnosis.alternatives.begin(), diagnosis.alternatives.end(), [&](const Alternative& a) {
        return a.paired_z < -options.paired_z || (a.at_floor && !diagnosis.floor_test.at_floor);
      });
  if (better == diagnosis.alternatives.end()) return false;
  for (Family family : selection.order) {
    if (!better->families[index_of(family)]) {
      diagnosis.eliminated.push_back({family, "", "replaced by an alternative set that predicts CHECK better"});
    }
  }
  adopt(selection, better->families, better->theta);
  return true;
}

// Identifiability of the final model and of every family at once, on the FIT rows as the final
// model sees them (positions unscaled when measuring_scale is part of it).
void analyse_final_identifiability(const PipelineData& data, Diagnosis& diagnosis) {
  const std::vector<Sample> rows = unscaled(data.fit, diagnosis.measuring_scale);
  diagnosis.final_model = analyse_identifiability(rows, diagnosis.significant, diagnosis.theta);
  FamilySet everything;
  everything.set();
  if (!diagnosis.significant[index_of(Family::transmission_error)])
    everything.reset(index_of(Family::transmission_error));
  Parameters probe = diagnosis.theta;
  // Backlash of exactly zero hides its column's sign; a tiny width makes the direction visible.
  for (int j = 0; j < 3; ++j) probe[slot::backlash + j] = std::max(probe[slot::backlash + j], 0.01);
  diagnosis.all_families = analyse_identifiability(rows, everything, probe);
}

// Steps 2-9 of diagnose on the prepared rows.
void run_pipeline(PipelineData& data, const std::vector<Sample>& check, Diagnosis& diagnosis);

}  // namespace

std::string elimination_text(const Elimination& elimination) {
  const std::string what = elimination.family ? family_name(*elimination.family) : elimination.sets;
  return elimination.reason.empty() ? what : what + " (" + elimination.reason + ")";
}

Diagnosis diagnose(const std::vector<Sample>& fit, const std::vector<Sample>& check, const DiagnosisOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  Diagnosis diagnosis;
  diagnosis.noise_floor_deg = options.noise_floor_deg;
  diagnosis.fit_samples = fit.size();
  diagnosis.check_samples = check.size();
  if (!fit.empty()) diagnosis.fit_span_s = fit.back().t_s - fit.front().t_s;
  if (!check.empty()) diagnosis.check_span_s = check.back().t_s - check.front().t_s;
  const double encoder_step_deg = options.noise_floor_deg * std::sqrt(12.0);

  // 1. Outlier rows (stage or encoder glitches) leave both recordings before anything is fitted.
  const std::vector<Outlier> fit_outliers = find_outliers(fit, "FIT", encoder_step_deg);
  const std::vector<Outlier> check_outliers = find_outliers(check, "CHECK", encoder_step_deg);
  diagnosis.outliers = fit_outliers;
  diagnosis.outliers.insert(diagnosis.outliers.end(), check_outliers.begin(), check_outliers.end());
  PipelineData data;
  data.options = options;
  data.fit = without_outliers(fit, fit_outliers);
  diagnosis.fit_joint_travel_deg = joint_travel(data.fit);
  data.check = without_outliers(check, check_outliers);
  Motion fit_motion;
  data.fit_closed_loop = correct_closed_loop(data.fit, encoder_step_deg, &diagnosis, &fit_motion);
  correct_closed_loop(data.check, encoder_step_deg);
  data.fit = thin_to(std::move(data.fit), options.max_fit_rows);
  data.check = thin_to(std::move(data.check), options.max_check_rows);
  diagnosis.fit_rows_used = data.fit.size();
  diagnosis.check_rows_used = data.check.size();
  data.thinned_fit = thin_out(data.fit, options.screening_stride);
  data.threshold_deg2 = options.significance * options.noise_floor_deg * options.noise_floor_deg;
  diagnosis.significance_threshold_deg2 = data.threshold_deg2;

  const bool fast_rows_only =
      std::find(diagnosis.fit_rows.begin(), diagnosis.fit_rows.end(), FitRows::fast_only) != diagnosis.fit_rows.end();
  const Diagnosis prepared = diagnosis;
  run_pipeline(data, check, diagnosis);
  // A closed-loop FIT whose joints with play counted on their fast rows only: once more with their
  // slower rows back in, shifted by what that model leaves there (restore_slow_rows).
  if (fast_rows_only && diagnosis.new_effects.empty()) {
    const std::vector<Vec3> predicted = predict_recording(diagnosis.fitted_effects, data.fit).alpha_deg;
    const Vec3 shift = restore_slow_rows(data.fit, predicted, fit_motion);
    diagnosis = prepared;
    diagnosis.fit_slow_rows_shift_deg = shift;
    data.thinned_fit = thin_out(data.fit, options.screening_stride);
    data.long_ripples = false;
    data.equivalent_sets.clear();
    run_pipeline(data, check, diagnosis);
  }
  diagnosis.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return diagnosis;
}

namespace {

void run_pipeline(PipelineData& data, const std::vector<Sample>& check, Diagnosis& diagnosis) {
  const DiagnosisOptions& options = data.options;
  // 2. The nominal model, where selection starts.
  const Candidate nominal = nominal_candidate(data.check);
  diagnosis.fit_rmse_nominal_deg = joint_rmse(data.fit, predict_recording(EffectSet{}, data.fit).alpha_deg);
  diagnosis.holdout_rmse_nominal_deg = nominal.holdout_rmse;
  diagnosis.check_nominal_deg = predict_recording(EffectSet{}, check).alpha_deg;

  // 3. Selection of the families by held-out error. 4-6. The kept model refitted on every kept FIT
  // row, its floor test and the sets CHECK cannot tell from it; a better alternative replaces it
  // and 4-6 run again.
  Selection selection = select_families(data, nominal);
  diagnosis.steps = selection.steps;
  diagnosis.eliminated = selection.eliminated;
  FinalModel final_model = finish_model(data, selection.families, selection.theta, check, diagnosis);
  if (adopt_better_alternative(options, selection, diagnosis)) {
    final_model = finish_model(data, selection.families, selection.theta, check, diagnosis);
  }
  // A family dropped on the way (a first path, a swap) that the final set holds is not eliminated.
  const auto held = [&](const Elimination& entry) {
    return entry.family && selection.families[index_of(*entry.family)];
  };
  diagnosis.eliminated.erase(std::remove_if(diagnosis.eliminated.begin(), diagnosis.eliminated.end(), held),
                             diagnosis.eliminated.end());

  // 7. Ranking and location of the gap.
  diagnosis.findings =
      rank_findings(data, selection, diagnosis, diagnosis.holdout_rmse_after_deg, final_model.fit_prediction);
  diagnosis.subsystem_rmse_without_deg = subsystem_errors(data.check, selection.families, diagnosis.theta);
  diagnosis.regions = region_errors(data.check, nominal.check_prediction, final_model.check_prediction);

  // 8. An effect outside the vocabulary in place of the families that imitate it (measuring_scale.hpp).
  try_measuring_scale(data, check, diagnosis, final_model.check_prediction);

  // 9. What the data cannot tell apart.
  analyse_final_identifiability(data, diagnosis);
}

}  // namespace

}  // namespace delta::diagnosis
