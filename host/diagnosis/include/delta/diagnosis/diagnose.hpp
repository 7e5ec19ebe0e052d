// Sim-to-real diagnosis: which effect families explain a recording, judged on held-out data, how
// far the gap shrinks, and what this data cannot tell apart.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "delta/diagnosis/effect_model.hpp"
#include "delta/diagnosis/fit.hpp"

namespace delta::diagnosis {

// Encoder quantisation of 0.01 deg seen as uniform noise: 0.01 / sqrt(12) deg per joint.
constexpr double kNoiseFloorDeg = 0.0028867513459481290;

struct DiagnosisOptions {
  double noise_floor_deg = kNoiseFloorDeg;
  // Stopping rule: an effect joins the model only if it lowers the held-out mean square error
  // (over the three joints) by more than significance * floor^2, i.e. it carries held-out signal
  // of at least sqrt(significance) * floor RMS. 0.05 -> 0.22 floor = 0.00065 deg.
  double significance = 0.05;
  // Selection heuristics only (ripple restart, swap search): a model counts as near the floor when
  // every joint's held-out RMSE is within this many floors. `explained` uses the floor test below.
  double near_floor_ratio = 1.2;
  // Floor test: one-sided z of the held-out mean of r^2 / sigma^2 - 1 (batch means over blocks of
  // `batch_rows` rows); above `floor_z` the residual is significantly above the noise floor.
  double floor_z = 4.0;
  std::size_t batch_rows = 100;  // at least; longer when the series is correlated over more rows
  // `explained` never holds with a joint's held-out RMSE above this many noise floors.
  double rmse_cap_floors = 1.5;
  // High-rate recordings (the host's 1 kHz telemetry merged with a stage) are thinned evenly to at
  // most this many FIT and CHECK rows after the outliers are found (neighbouring rows of a slow
  // motion carry little new information; PRED.csv still has every CHECK row).
  std::size_t max_fit_rows = 15000;
  std::size_t max_check_rows = 8000;
  // Stopping rule and equivalence: a held-out MSE difference between two models counts only when
  // its paired z (batch means over the same CHECK rows) exceeds this.
  double paired_z = 3.0;
  // Every fit pulls each parameter towards the nominal robot with the weight of this many
  // observations at the noise floor per parameter at its typical magnitude (1 deg, 1 mm, 0.3 deg
  // of play, 0.1 deg of ripple, 1 % of encoder scale). Negligible where the FIT rows fix a
  // parameter; where families imitate each other inside the trajectory's volume, it keeps their
  // parameters near realistic sizes instead of wandering along the valley to values that
  // extrapolate badly to CHECK.
  double prior_observations = 10.0;
  int threads = 2;
  std::size_t screening_stride = 2;  // candidates are fitted on every 2nd FIT row (all rows with backlash)
};

// One family as the report ranks it.
struct EffectFinding {
  Family family;
  bool significant = false;
  Parameters theta;                      // parameters of the model this finding was measured with
  Vec3 holdout_rmse_deg = Vec3::Zero();  // significant: after adding it (cumulative, in rank order);
                                         // not significant: the final model plus this family
  double holdout_gain_deg2 = 0.0;        // drop of held-out MSE (mean over joints) it brought
};

// One forward-selection step: every candidate tried and the one kept.
struct SelectionStep {
  FamilySet base;
  std::vector<std::pair<Family, double>> candidate_mse;  // held-out MSE (mean over joints, deg^2)
  int chosen = -1;                                       // family index kept, -1 if none passed the stopping rule
  double seconds = 0.0;                                  // time the round took
  std::string note;
};

// A direction in parameter space the data barely sees.
struct WeakDirection {
  double singular_value = 0.0;                     // of the column-normalised Jacobian (1 = fully independent)
  std::vector<std::pair<int, double>> components;  // (parameter index, weight), largest first
  std::string advice;                              // the extra measurement that would separate them
};

struct Correlation {
  int a = 0, b = 0;  // parameter indices
  double value = 0.0;
};

struct Identifiability {
  std::string model;  // the family set it was computed for
  std::vector<int> parameters;
  std::vector<double> singular_values;    // normalised, descending
  std::vector<WeakDirection> weak;        // singular value below 1e-2
  std::vector<Correlation> correlations;  // |correlation| above 0.95, strongest first
};

// The noise model and the test of a held-out residual against it.
struct FloorTest {
  Vec3 sigma_deg = Vec3::Zero();  // noise model per joint: encoder + stage quantisation + extra (RMS)
  double stage_sigma_deg = 0.0;   // stage quantisation seen through the kinematics (RMS over rows and joints)
  double extra_noise_deg = 0.0;   // extra white noise per joint estimated from FIT (0 unless significant)
  double extra_noise_z = 0.0;     // its significance (estimate / standard error)
  double ratio = 0.0;             // held-out mean of r^2 / sigma^2 (1 at the floor)
  Vec3 joint_ratio = Vec3::Zero();
  double z = 0.0;  // (ratio - 1) / standard error (batch means)
  Vec3 joint_z = Vec3::Zero();
  double threshold = 0.0;  // z above this: significantly above the floor
  std::size_t rows = 0, blocks = 0;
  double effective_rows = 0.0;            // rows / integrated autocorrelation time of r^2 / sigma^2
  Vec3 joint_rmse_floors = Vec3::Zero();  // held-out RMSE per joint in noise floors
  double rmse_cap_floors = 0.0;           // at_floor needs every joint at or below this
  bool at_floor = false;
};

// Where a residual significantly above the floor lives.
struct UnexplainedResidual {
  int joint = -1;               // 0-based joint with the largest excess
  double excess_rms_deg = 0.0;  // sqrt(mean r^2 - sigma^2) over every joint and row
  std::string region;           // octant with the largest excess
  double region_excess_rms_deg = 0.0;
  double t_from_s = 0.0, t_to_s = 0.0;  // tenth of the CHECK time with the largest excess
  double time_excess_rms_deg = 0.0;
};

// Another set of effects that predicts CHECK as well as the chosen one.
// Which of a joint's rows of a closed-loop FIT were fitted: every one; only those faster than
// closed_loop::kSteadySpeedDegS (a joint with play); or every one because a joint with play was
// never that fast for long enough.
enum class FitRows { every, fast_only, too_slow };

struct Alternative {
  FamilySet families;
  Parameters theta;
  Vec3 holdout_rmse_deg = Vec3::Zero();
  double mse_difference_deg2 = 0.0;  // held-out MSE of this set minus the chosen set's
  double paired_z = 0.0;             // of that difference
  bool at_floor = false;
  std::string separate_by;  // the measurement that would tell the two apart
};

// A row judged a glitch (isolated spike in position or angle) and left out of the fit and scores.
struct Outlier {
  std::string recording;  // "FIT" or "CHECK"
  std::size_t row = 0;    // 1-based data row
  double t_s = 0.0;
  double position_spike_mm = 0.0;  // size of the spike in the measured position
  double angle_spike_deg = 0.0;    // largest spike over the joints
};

// An effect outside the SPEC vocabulary, reported under its own name. The one tried: a scale of
// the measuring stage, p_measured = (1 + s) p_true per axis. Uniform (s_x = s_y = s_z = s), the
// vocabulary can only imitate it by scaling every robot length (upper and lower arms, radius
// offset) by 1 / (1 + s); one axis alone, by encoder scales, the frame and the lengths together.
struct NewEffect {
  std::string name;                      // "measuring_scale"
  std::string subsystem;                 // "measuring frame"
  bool per_axis = false;                 // parameters s_x, s_y, s_z; else one s
  Vec3 scale = Vec3::Zero();             // s per axis [-]
  Vec3 confidence_95 = Vec3::Zero();     // half widths
  Vec3 holdout_rmse_deg = Vec3::Zero();  // the final model with it
};

struct RegionError {
  std::string label;  // e.g. "x- y+ z-" (octant of the trajectory's bounding box)
  std::size_t samples = 0;
  Vec3 nominal_rmse_deg = Vec3::Zero();
  Vec3 after_rmse_deg = Vec3::Zero();
};

// A family the selection dropped on the way, and why; or, with no family, whole sets it replaced.
struct Elimination {
  std::optional<Family> family;
  std::string sets;    // the sets replaced, when there is no family
  std::string reason;  // empty: backward elimination (made redundant by a family added later)
};
// "name" or "name (reason)", as the report lists it.
std::string elimination_text(const Elimination& elimination);

struct Diagnosis {
  double noise_floor_deg = kNoiseFloorDeg;
  double significance_threshold_deg2 = 0.0;  // the stopping rule's minimum held-out MSE gain
  bool explained = false;
  FamilySet significant;
  Parameters theta;                     // final model
  EffectSet fitted_effects;             // final model in SPEC units
  std::vector<EffectFinding> findings;  // ranked, most important first
  std::vector<SelectionStep> steps;
  std::vector<Elimination> eliminated;  // dropped on the way and not in the final set
  Vec3 fit_rmse_nominal_deg = Vec3::Zero(), fit_rmse_after_deg = Vec3::Zero();
  Vec3 holdout_rmse_nominal_deg = Vec3::Zero(), holdout_rmse_after_deg = Vec3::Zero();
  double explained_fraction = 0.0;                       // of the held-out MSE above the floor, the part removed
  std::vector<Vec3> check_nominal_deg, check_after_deg;  // predictions per CHECK row
  std::size_t check_unreachable = 0;
  std::vector<RegionError> regions;
  // Per subsystem: held-out RMSE per joint of the final model with that subsystem's families
  // removed (how much of the gap lives there).
  std::vector<std::pair<std::string, Vec3>> subsystem_rmse_without_deg;
  Identifiability final_model, all_families;
  FloorTest floor_test;                   // of the final model on CHECK; decides `explained`
  UnexplainedResidual unexplained;        // filled when the floor test fails
  std::vector<Alternative> alternatives;  // statistically indistinguishable sets, best first
  std::vector<Outlier> outliers;
  std::size_t fit_rows_used = 0, check_rows_used = 0;  // after outliers and thinning
  // How far each joint's reading travels on FIT (largest - smallest, deg). Effects that vary slowly
  // over a joint (a transmission ripple of a period longer than this) look like geometry there.
  Vec3 fit_joint_travel_deg = Vec3::Zero();
  // FIT is closed-loop telemetry (a `host run`). Per joint, which rows were fitted (FitRows): a
  // joint with play only where faster than closed_loop::kSteadySpeedDegS (slower, the stage misses
  // where the arm sits in the play), or every row when it was never that fast for long enough (its
  // play may come out narrow).
  bool fit_closed_loop = false;
  std::array<FitRows, 3> fit_rows{};
  // Those joints' slower rows were then fitted too, each shifted along its direction of motion by
  // what the model of the fast rows left there per band of speed: the largest shift per joint.
  Vec3 fit_slow_rows_shift_deg = Vec3::Zero();
  std::vector<NewEffect> new_effects;   // significant effects outside the vocabulary (final model)
  Vec3 measuring_scale = Vec3::Zero();  // s per axis of a measuring_scale new effect; PRED uses p / (1 + s)
  // 1.96 standard errors of each fitted parameter (internal units), from the covariance of the
  // final fit: residual variance on FIT times the inverse of J^T J (with the weak prior).
  Parameters confidence_95 = Parameters::Zero();
  double seconds = 0.0;  // how long the diagnosis took to compute (wall clock)
  // The recordings: rows and the time they span (last t_s - first t_s, seconds of recording).
  std::size_t fit_samples = 0, check_samples = 0;
  double fit_span_s = 0.0, check_span_s = 0.0;
};

// Fits on `fit` only; `check` is used to choose effects and to report held-out errors.
// Throws InputError (naming `fit_path`/`check_path` and the row's line) when the nominal model
// cannot reach a measured position.
Diagnosis diagnose(const std::vector<Sample>& fit, const std::vector<Sample>& check,
                   const DiagnosisOptions& options = {});

// Per-joint RMSE of measured - predicted.
Vec3 joint_rmse(const std::vector<Sample>& rows, const std::vector<Vec3>& predicted);

// Identifiability of `families` at theta on `rows`.
Identifiability analyse_identifiability(const std::vector<Sample>& rows, FamilySet families, const Parameters& theta);

}  // namespace delta::diagnosis
