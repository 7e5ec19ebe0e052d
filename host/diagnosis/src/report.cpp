// JSON, predictions CSV, Markdown report and plots of a diagnosis.
#include "delta/diagnosis/report.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "delta/effect_file.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"
#include "delta/plot.hpp"
#include "delta/table.hpp"

#include "closed_loop.hpp"

namespace delta::diagnosis {
namespace {

using nlohmann::json;

json triple(const Vec3& v) { return json::array({v[0], v[1], v[2]}); }

double rms(const Vec3& v) { return std::sqrt(v.squaredNorm() / 3.0); }

std::string parameter_label(int k) {
  const ParameterInfo& info = parameter_table()[k];
  return info.name + " [" + info.unit + "]";
}

json identifiability_json(const Identifiability& identifiability) {
  json document;
  document["model"] = identifiability.model;
  json names = json::array();
  for (int k : identifiability.parameters) names.push_back(parameter_label(k));
  document["parameters"] = names;
  document["normalised_singular_values"] = identifiability.singular_values;
  json weak = json::array();
  for (const WeakDirection& direction : identifiability.weak) {
    json components = json::object();
    for (const auto& [k, w] : direction.components) components[parameter_label(k)] = w;
    weak.push_back(
        {{"singular_value", direction.singular_value}, {"combination", components}, {"separate_by", direction.advice}});
  }
  document["weak_directions"] = weak;
  json correlations = json::array();
  for (const Correlation& c : identifiability.correlations) {
    correlations.push_back({{"a", parameter_label(c.a)}, {"b", parameter_label(c.b)}, {"correlation", c.value}});
  }
  document["strong_correlations"] = correlations;
  return document;
}

std::string joined_parameters(Family family, const Parameters& theta) {
  // A parameter without a value of its own (an interval in a weak direction: NaN, null once in
  // the JSON's text) prints as "inseparable".
  auto value_text = [](const json& value) {
    if (value.is_null() || !std::isfinite(value.get<double>())) return std::string("inseparable");
    return format_number(std::round(value.get<double>() * 1e6) / 1e6);
  };
  std::ostringstream text;
  const json parameters = family_parameters_json(family, theta);
  for (auto it = parameters.begin(); it != parameters.end(); ++it) {
    if (it != parameters.begin()) text << "; ";
    text << it.key() << " ";
    if (it.value().is_array()) {
      for (std::size_t j = 0; j < it.value().size(); ++j) text << (j ? ", " : "") << value_text(it.value()[j]);
    } else {
      text << value_text(it.value());
    }
  }
  return text.str();
}

// Error map: the CHECK positions binned on an 8 x 8 grid in x-y, RMS over joints and rows per
// cell, nominal and after side by side (each with its own colour scale, degrees). gnuplot directly: plot.hpp
// draws line series only.
void write_error_map(const std::string& png_path, const std::vector<Sample>& check, const Diagnosis& diagnosis) {
  constexpr int kCells = 8;
  Vec3 low = check.front().position_m, high = low;
  for (const Sample& sample : check) {
    low = low.cwiseMin(sample.position_m);
    high = high.cwiseMax(sample.position_m);
  }
  const double width_x = std::max(high.x() - low.x(), 1e-9) / kCells,
               width_y = std::max(high.y() - low.y(), 1e-9) / kCells;
  std::array<std::array<double, kCells * kCells>, 2> sum{};
  std::array<int, kCells * kCells> count{};
  for (std::size_t i = 0; i < check.size(); ++i) {
    const int cx = std::min(kCells - 1, static_cast<int>((check[i].position_m.x() - low.x()) / width_x));
    const int cy = std::min(kCells - 1, static_cast<int>((check[i].position_m.y() - low.y()) / width_y));
    const int cell = cy * kCells + cx;
    ++count[cell];
    sum[0][cell] += (check[i].alpha_deg - diagnosis.check_nominal_deg[i]).squaredNorm() / 3.0;
    sum[1][cell] += (check[i].alpha_deg - diagnosis.check_after_deg[i]).squaredNorm() / 3.0;
  }
  const char* names[2] = {"nominal model", "after diagnosis"};
  std::ostringstream script;
  for (int panel = 0; panel < 2; ++panel) {
    script << "$map" << panel << " << EOD\n";
    for (int cy = 0; cy < kCells; ++cy) {
      for (int cx = 0; cx < kCells; ++cx) {
        const int cell = cy * kCells + cx;
        if (!count[cell]) continue;
        script << format_number((low.x() + (cx + 0.5) * width_x) * 1e3) << ' '
               << format_number((low.y() + (cy + 0.5) * width_y) * 1e3) << ' '
               << format_number(std::max(std::sqrt(sum[panel][cell] / count[cell]), 1e-6)) << '\n';
      }
    }
    script << "EOD\n";
  }
  script << "set terminal pngcairo size 1300,560 font 'sans,10'\n"
         << "set multiplot layout 1,2 title 'Held-out RMSE over the three joints per x-y cell of the CHECK workspace "
            "[deg]'\n"
         << "set format cb '%.2g'\nset xlabel 'x [mm]'\nset ylabel 'y [mm]'\nset size ratio -1\n"
         << "set palette rgbformulae 22,13,-31\n";
  for (int panel = 0; panel < 2; ++panel) {
    script << "set title '" << names[panel] << "'\nplot $map" << panel
           << " using 1:2:3 with points pt 5 ps 5.5 lc palette notitle\n";
  }
  script << "unset multiplot\n";
  render_gnuplot_png(png_path, script.str());
}
// Confidence half widths of a family laid out as parameters, so they print in the keys and units
// of its parameters (the conversion to SPEC units is linear).
// A parameter the data cannot separate from others (a weak direction of the final model holds it)
// has no interval of its own: NaN (null in the JSON, "inseparable" in the report).
Parameters confidence_theta(Family family, const Parameters& half_widths, const Identifiability& identifiability) {
  Parameters theta = Parameters::Zero();
  for (int k : parameter_indices(single(family))) theta[k] = half_widths[k];
  for (const WeakDirection& weak : identifiability.weak) {
    for (const auto& [k, w] : weak.components) {
      if (parameter_table()[static_cast<std::size_t>(k)].family == family)
        theta[k] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  return theta;
}

// The parameters of `family` in weak directions of the final model, with what they go with.
json inseparable_json(Family family, const Identifiability& identifiability) {
  json list = json::array();
  for (const WeakDirection& weak : identifiability.weak) {
    for (const auto& [k, w] : weak.components) {
      if (parameter_table()[static_cast<std::size_t>(k)].family != family) continue;
      json with = json::array();
      for (const auto& [other, v] : weak.components) {
        if (other != k) with.push_back(parameter_label(other));
      }
      list.push_back({{"parameter", parameter_label(k)},
                      {"with", with},
                      {"singular_value", weak.singular_value},
                      {"separate_by", weak.advice}});
    }
  }
  return list;
}

json floor_test_json(const FloorTest& test) {
  return {{"statistic_z", test.z},
          {"effective_rows", test.effective_rows},
          {"joint_rmse_floors", triple(test.joint_rmse_floors)},
          {"rmse_cap_floors", test.rmse_cap_floors},
          {"threshold_z", test.threshold},
          {"ratio_to_noise_model", test.ratio},
          {"joint_ratio", triple(test.joint_ratio)},
          {"joint_z", triple(test.joint_z)},
          {"noise_model_sigma_deg", triple(test.sigma_deg)},
          {"stage_sigma_deg", test.stage_sigma_deg},
          {"extra_noise_deg", test.extra_noise_deg},
          {"extra_noise_z", test.extra_noise_z},
          {"rows", test.rows},
          {"blocks", test.blocks},
          {"at_floor", test.at_floor}};
}

// The order the effects were added in: the significant ones as ranked (the gap table's rows),
// then the other families forward selection chose on its way (its trace), then the vocabulary's.
std::vector<Family> added_order(const Diagnosis& diagnosis) {
  std::vector<Family> order;
  auto add = [&order](Family family) {
    if (std::find(order.begin(), order.end(), family) == order.end()) order.push_back(family);
  };
  for (const EffectFinding& finding : diagnosis.findings) {
    if (finding.significant) add(finding.family);
  }
  for (const SelectionStep& step : diagnosis.steps) {
    if (step.chosen >= 0) add(family_at(step.chosen));
  }
  for (int f = 0; f < kFamilyCount; ++f) add(family_at(f));
  return order;
}

// A set of families named in the order they were added, so that the selection trace, the gap
// table, the summary and the equivalent sets read alike ("nominal" for none).
std::string describe_as_added(FamilySet families, const Diagnosis& diagnosis) {
  std::string text;
  for (Family family : added_order(diagnosis)) {
    if (families[index_of(family)]) text += (text.empty() ? "" : " + ") + std::string(family_name(family));
  }
  return text.empty() ? "nominal" : text;
}

// The final model's effects, new ones (outside the vocabulary) included.
std::string model_name(const Diagnosis& diagnosis) {
  std::string text = diagnosis.significant.any() ? describe_as_added(diagnosis.significant, diagnosis) : std::string();
  for (const NewEffect& effect : diagnosis.new_effects) text += (text.empty() ? "" : " + ") + effect.name;
  return text.empty() ? std::string("no effect") : text;
}

// A transmission ripple of a period longer than a joint's travel on FIT is a smooth curve there,
// which the geometry families imitate: selection can then miss the floor with effects the
// vocabulary has. The validation trajectory turns the joints by 16-20 deg, the calibration
// trajectory by about twice that; gear ripples of up to 30 deg are realistic.
constexpr double kLongestRippleDeg = 30.0;

std::string inseparable_on_fit(const Diagnosis& diagnosis) {
  const Vec3& travel = diagnosis.fit_joint_travel_deg;
  if (travel.minCoeff() >= kLongestRippleDeg) return "";
  return ", or effects the FIT recording cannot separate (its joints travel " + fixed(travel[0], 1) + " / " +
         fixed(travel[1], 1) + " / " + fixed(travel[2], 1) +
         " deg: a transmission ripple of a longer period looks like geometry there; a drag along the "
         "calibration trajectory turns them further)";
}

// The part of the floor test a model above the floor misses: the three joints together, one joint
// (its own z above the threshold by 0.5), or a joint's held-out RMSE above the cap.
std::string floor_test_missed(const FloorTest& test) {
  std::ostringstream text;
  int joint = 0;
  if (test.z > test.threshold) {
    text << "floor test z = " << fixed(test.z, 2) << " > " << fixed(test.threshold, 1);
  } else if (test.joint_z.maxCoeff(&joint) > test.threshold + 0.5) {
    text << "joint " << joint + 1 << "'s floor test z = " << fixed(test.joint_z[joint], 2) << " > "
         << fixed(test.threshold + 0.5, 1) << ", the three joints' z = " << fixed(test.z, 2);
  } else {
    test.joint_rmse_floors.maxCoeff(&joint);
    text << "joint " << joint + 1 << " at " << fixed(test.joint_rmse_floors[joint], 2)
         << " floors held out, above the cap of " << fixed(test.rmse_cap_floors, 1);
  }
  return text.str();
}

// The verdict sentence of the report and of the summary.
std::string verdict(const Diagnosis& diagnosis) {
  std::ostringstream text;
  text << model_name(diagnosis);
  for (const Alternative& alternative : diagnosis.alternatives) {
    text << ", or equivalently " << describe_as_added(alternative.families, diagnosis)
         << " (to tell them apart: " << alternative.separate_by << ")";
  }
  const FloorTest& test = diagnosis.floor_test;
  if (diagnosis.explained) {
    text << (diagnosis.alternatives.empty() ? " explains" : " explain")
         << " the recording down to the noise floor (floor test z = " << fixed(test.z, 2)
         << " <= " << fixed(test.threshold, 1) << ", held-out r^2 / noise model = " << fixed(test.ratio, 4) << ")";
  } else {
    const UnexplainedResidual& where = diagnosis.unexplained;
    text << " leaves a residual significantly above the noise floor (" << floor_test_missed(test)
         << ", held-out r^2 / noise model = " << fixed(test.ratio, 4) << "): an effect outside the vocabulary"
         << inseparable_on_fit(diagnosis) << "; its excess is " << format_number(where.excess_rms_deg)
         << " deg RMS, largest on joint " << where.joint + 1 << ", in octant " << where.region << " ("
         << format_number(where.region_excess_rms_deg) << " deg) and at t = " << fixed(where.t_from_s, 2) << "-"
         << fixed(where.t_to_s, 2) << " s (" << format_number(where.time_excess_rms_deg) << " deg)";
  }
  return text.str();
}

// Per joint, whether its closed-loop FIT rows were `rows`.
std::array<bool, 3> fitted_so(const Diagnosis& diagnosis, FitRows rows) {
  std::array<bool, 3> so{};
  for (std::size_t j = 0; j < 3; ++j) so[j] = diagnosis.fit_rows[j] == rows;
  return so;
}

// "1, 3": the joints whose FIT rows were `rows`.
std::string joint_list(const Diagnosis& diagnosis, FitRows rows) {
  std::string text;
  const std::array<bool, 3> so = fitted_so(diagnosis, rows);
  for (int j = 0; j < 3; ++j) {
    if (so[static_cast<std::size_t>(j)]) text += (text.empty() ? "" : ", ") + std::to_string(j + 1);
  }
  return text;
}

// What a closed-loop FIT did with the joints with play (closed_loop.hpp), or "".
std::string closed_loop_note(const Diagnosis& diagnosis) {
  if (!diagnosis.fit_closed_loop) return "";
  const std::string fast = joint_list(diagnosis, FitRows::fast_only), slow = joint_list(diagnosis, FitRows::too_slow);
  std::string text = "FIT is closed-loop telemetry: the readings less the controller's lead were fitted";
  if (!fast.empty()) {
    const Vec3& shift = diagnosis.fit_slow_rows_shift_deg;
    text += "; joints " + fast + " (play) first only where faster than " + fixed(closed_loop::kSteadySpeedDegS, 1) +
            " deg/s (slower, the arm falls back inside the play where the stage's sampling cannot follow it), "
            "then every row, the slower ones shifted along their motion by what that model left there (at most " +
            fixed(shift[0], 4) + " / " + fixed(shift[1], 4) + " / " + fixed(shift[2], 4) + " deg)";
  }
  if (!slow.empty()) {
    text += "; joints " + slow + " have play but never move faster than " + fixed(closed_loop::kSteadySpeedDegS, 1) +
            " deg/s for " + fixed(closed_loop::kLeastSteadyS, 0) +
            " s each way: their play may come out narrower than the robot's (fit the play on a drag, or run a "
            "faster path)";
  }
  return text;
}

}  // namespace

json family_parameters_json(Family family, const Parameters& theta) {
  const json effect = effects_to_json(to_effect_set(theta, single(family)))[family_name(family)];
  if (effect.is_object()) return effect;
  static const char* keys[kFamilyCount] = {"o_deg", "dL_A_m", "dL_B_m", "dr_m", "dphi_deg", "", "b_deg", "", "k"};
  return json{{keys[index_of(family)], effect}};
}

namespace {

// An effect outside the vocabulary (a scale error of the measuring stage) as an entry of "effects".
json new_effect_json(const NewEffect& effect) {
  json parameters, half_widths;
  if (effect.per_axis) {
    for (int axis = 0; axis < 3; ++axis) {
      const std::string name = std::string("s_") + "xyz"[axis];
      parameters[name] = effect.scale[axis];
      half_widths[name] = effect.confidence_95[axis];
    }
  } else {
    parameters["s"] = effect.scale[0];
    half_widths["s"] = effect.confidence_95[0];
  }
  return {
      {"name", effect.name},
      {"significant", true},
      {"in_vocabulary", false},
      {"subsystem", effect.subsystem},
      {"parameters", parameters},
      {"final_parameters", parameters},
      {"confidence_95_half_width", half_widths},
      {"holdout_rmse_deg", triple(effect.holdout_rmse_deg)},
      {"description", effect.per_axis ? "p_measured = (1 + s_axis) p_true per axis: a scale error of the "
                                        "measuring stage's axes"
                                      : "p_measured = (1 + s) p_true: a uniform scale error of the measuring stage"}};
}

// A family of the vocabulary as ranked, as an entry of "effects".
json finding_json(const EffectFinding& finding, const Diagnosis& diagnosis) {
  json effect = {{"name", family_name(finding.family)},
                 {"significant", finding.significant},
                 {"subsystem", subsystem_of(finding.family)},
                 {"parameters", family_parameters_json(finding.family, finding.theta)},
                 {"holdout_rmse_deg", triple(finding.holdout_rmse_deg)},
                 {"holdout_gain_deg2", finding.holdout_gain_deg2}};
  if (finding.significant) {
    // The final model's values and their 95 % intervals (value +- half width; null: the data
    // cannot separate the parameter from those `inseparable` names). The values when selection
    // added the family stay in `selection_parameters`.
    effect["parameters"] = family_parameters_json(finding.family, diagnosis.theta);
    effect["final_parameters"] = effect["parameters"];
    effect["selection_parameters"] = family_parameters_json(finding.family, finding.theta);
    effect["confidence_95_half_width"] = family_parameters_json(
        finding.family, confidence_theta(finding.family, diagnosis.confidence_95, diagnosis.final_model));
    effect["inseparable"] = inseparable_json(finding.family, diagnosis.final_model);
  }
  return effect;
}

// The effects outside the vocabulary first, then the vocabulary's families as ranked.
json effects_json(const Diagnosis& diagnosis) {
  json effects = json::array();
  for (const NewEffect& effect : diagnosis.new_effects) effects.push_back(new_effect_json(effect));
  for (const EffectFinding& finding : diagnosis.findings) effects.push_back(finding_json(finding, diagnosis));
  return effects;
}

json alternatives_json(const Diagnosis& diagnosis) {
  json alternatives = json::array();
  for (const Alternative& alternative : diagnosis.alternatives) {
    json names = json::array(), parameters = json::object();
    for (int f = 0; f < kFamilyCount; ++f) {
      if (!alternative.families[f]) continue;
      names.push_back(family_name(family_at(f)));
      parameters[family_name(family_at(f))] = family_parameters_json(family_at(f), alternative.theta);
    }
    alternatives.push_back({{"effects", names},
                            {"parameters", parameters},
                            {"holdout_rmse_deg", triple(alternative.holdout_rmse_deg)},
                            {"holdout_mse_difference_deg2", alternative.mse_difference_deg2},
                            {"paired_z", alternative.paired_z},
                            {"at_floor", alternative.at_floor},
                            {"separate_by", alternative.separate_by}});
  }
  return alternatives;
}

json outliers_json(const Diagnosis& diagnosis) {
  json outliers = json::array();
  for (const Outlier& outlier : diagnosis.outliers) {
    outliers.push_back({{"recording", outlier.recording},
                        {"row", outlier.row},
                        {"t_s", outlier.t_s},
                        {"position_spike_mm", outlier.position_spike_mm},
                        {"angle_spike_deg", outlier.angle_spike_deg}});
  }
  return outliers;
}

// Forward selection's steps: each candidate's held-out RMSE and the family added (null: stop).
json selection_json(const Diagnosis& diagnosis) {
  json steps = json::array();
  for (const SelectionStep& step : diagnosis.steps) {
    json candidates = json::object();
    for (const auto& [family, mse] : step.candidate_mse) candidates[family_name(family)] = std::sqrt(mse);
    steps.push_back({{"model", describe(step.base)},
                     {"candidate_holdout_rmse_deg", candidates},
                     {"added", step.chosen >= 0 ? json(family_name(family_at(step.chosen))) : json(nullptr)}});
  }
  return steps;
}

json regions_json(const Diagnosis& diagnosis) {
  json regions = json::array();
  for (const RegionError& region : diagnosis.regions) {
    regions.push_back({{"octant", region.label},
                       {"samples", region.samples},
                       {"rmse_nominal_deg", triple(region.nominal_rmse_deg)},
                       {"rmse_after_deg", triple(region.after_rmse_deg)}});
  }
  return regions;
}

}  // namespace

json diagnosis_json(const Diagnosis& diagnosis) {
  json document;
  document["noise_floor_deg"] = diagnosis.noise_floor_deg;
  document["explained"] = diagnosis.explained;
  document["rows_used"] = {{"fit", diagnosis.fit_rows_used}, {"check", diagnosis.check_rows_used}};
  document["fit_joint_travel_deg"] = {diagnosis.fit_joint_travel_deg[0], diagnosis.fit_joint_travel_deg[1],
                                      diagnosis.fit_joint_travel_deg[2]};
  document["explained_fraction"] = diagnosis.explained_fraction;
  if (diagnosis.fit_closed_loop) {
    document["closed_loop_fit"] = {{"steady_speed_deg_s", closed_loop::kSteadySpeedDegS},
                                   {"play_fitted_where_faster", fitted_so(diagnosis, FitRows::fast_only)},
                                   {"play_never_fast_enough", fitted_so(diagnosis, FitRows::too_slow)},
                                   {"slow_rows_shift_deg", triple(diagnosis.fit_slow_rows_shift_deg)}};
  }
  document["effects"] = effects_json(diagnosis);
  document["floor_test"] = floor_test_json(diagnosis.floor_test);
  if (!diagnosis.explained) {
    const UnexplainedResidual& where = diagnosis.unexplained;
    document["unexplained"] = {{"excess_rms_deg", where.excess_rms_deg},
                               {"joint", where.joint + 1},
                               {"octant", where.region},
                               {"octant_excess_rms_deg", where.region_excess_rms_deg},
                               {"time_s", json::array({where.t_from_s, where.t_to_s})},
                               {"time_excess_rms_deg", where.time_excess_rms_deg}};
  }
  document["alternatives"] = alternatives_json(diagnosis);
  document["outliers"] = outliers_json(diagnosis);
  document["verdict"] = verdict(diagnosis);
  document["warnings"] = diagnosis_warnings(diagnosis);
  document["holdout"] = {{"rmse_nominal_deg", triple(diagnosis.holdout_rmse_nominal_deg)},
                         {"rmse_after_deg", triple(diagnosis.holdout_rmse_after_deg)},
                         {"samples", diagnosis.check_after_deg.size()},
                         {"span_s", diagnosis.check_span_s},
                         {"unreachable_rows", diagnosis.check_unreachable}};
  document["fit"] = {{"rmse_nominal_deg", triple(diagnosis.fit_rmse_nominal_deg)},
                     {"rmse_after_deg", triple(diagnosis.fit_rmse_after_deg)},
                     {"samples", diagnosis.fit_samples},
                     {"span_s", diagnosis.fit_span_s}};
  document["fitted_effects"] = effects_to_json(diagnosis.fitted_effects);
  document["selection"] = selection_json(diagnosis);
  json eliminated = json::array();
  for (const Elimination& entry : diagnosis.eliminated) eliminated.push_back(elimination_text(entry));
  document["eliminated"] = eliminated;
  json subsystems = json::object();
  for (const auto& [name, rmse] : diagnosis.subsystem_rmse_without_deg) subsystems[name] = triple(rmse);
  document["holdout_rmse_without_subsystem_deg"] = subsystems;
  document["regions"] = regions_json(diagnosis);
  document["identifiability"] = {{"final_model", identifiability_json(diagnosis.final_model)},
                                 {"all_families", identifiability_json(diagnosis.all_families)}};
  document["seconds"] = diagnosis.seconds;
  return document;
}

void write_predictions(std::ostream& out, const std::vector<Sample>& check, const Diagnosis& diagnosis) {
  out << "t_s,alpha1_deg,alpha2_deg,alpha3_deg\n";
  for (std::size_t i = 0; i < check.size(); ++i) {
    out << format_number(check[i].t_s);
    for (int j = 0; j < 3; ++j) out << ',' << format_number(diagnosis.check_after_deg[i][j]);
    out << '\n';
  }
}

std::vector<std::string> diagnosis_warnings(const Diagnosis& diagnosis) {
  std::vector<std::string> warnings;
  if (!diagnosis.fitted_effects.joint_offset_deg) return warnings;
  const Vec3& offset = *diagnosis.fitted_effects.joint_offset_deg;
  for (int j = 0; j < 3; ++j) {
    if (!(std::abs(offset[j]) > kPlausibleJointOffsetDeg)) continue;
    warnings.push_back("joint " + std::to_string(j + 1) + "'s offset " + fixed(offset[j], 2) + " deg is beyond the " +
                       fixed(kPlausibleJointOffsetDeg, 0) +
                       " deg any assembled robot has: its counts were most likely not referenced at the home "
                       "switches when recorded (homed by hand, never homed, or a homing that did not finish); home the "
                       "board (deltactl host home), record again, and do not train on this recording");
  }
  return warnings;
}

void print_summary(std::ostream& out, const Diagnosis& diagnosis) {
  Table table({"model", "held-out RMSE alpha_1 [deg]", "alpha_2 [deg]", "alpha_3 [deg]", "x noise floor"});
  const double floor = diagnosis.noise_floor_deg;
  auto row = [&](const std::string& name, const Vec3& rmse) {
    table.add_row({name, fixed(rmse[0], 5), fixed(rmse[1], 5), fixed(rmse[2], 5), fixed(rmse.maxCoeff() / floor, 2)});
  };
  row("nominal", diagnosis.holdout_rmse_nominal_deg);
  for (const EffectFinding& finding : diagnosis.findings) {
    if (finding.significant) row(std::string("+ ") + family_name(finding.family), finding.holdout_rmse_deg);
  }
  for (const NewEffect& effect : diagnosis.new_effects) {
    std::string values;
    for (int axis = 0; axis < (effect.per_axis ? 3 : 1); ++axis) {
      values += (values.empty() ? "" : ", ") + std::string(effect.per_axis ? std::string("s_") + "xyz"[axis] : "s") +
                " = " + format_number(effect.scale[axis]) + " +- " + format_number(effect.confidence_95[axis]);
    }
    row("final model with " + effect.name + " (outside the vocabulary), " + values, effect.holdout_rmse_deg);
  }
  table.print(out);
  out << "\nnoise floor " << fixed(floor, 5) << " deg; explained: " << (diagnosis.explained ? "yes" : "no") << " ("
      << (diagnosis.explained ? "floor test z " + fixed(diagnosis.floor_test.z, 2) + ", threshold " +
                                    fixed(diagnosis.floor_test.threshold, 1)
                              : floor_test_missed(diagnosis.floor_test))
      << "; " << fixed(100.0 * diagnosis.explained_fraction, 1) << " % of the held-out excess removed); "
      << "significant: " << model_name(diagnosis) << "; FIT " << fixed(diagnosis.fit_span_s, 1) << " s ("
      << diagnosis.fit_samples << " rows), CHECK " << fixed(diagnosis.check_span_s, 1) << " s ("
      << diagnosis.check_samples << " rows) of recording; computed in " << fixed(diagnosis.seconds, 1) << " s\n"
      << "verdict: " << verdict(diagnosis) << "\n";
  for (const std::string& warning : diagnosis_warnings(diagnosis)) out << "warning: " << warning << "\n";
  if (!diagnosis.outliers.empty()) out << diagnosis.outliers.size() << " outlier rows left out (listed in the JSON)\n";
  if (diagnosis.fit_closed_loop) out << closed_loop_note(diagnosis) << "\n";
}

namespace {

// Residual along the CHECK trajectory, before and after.
void write_residual_plot(const std::string& png_path, const ReportInputs& inputs, const std::vector<Sample>& check,
                         const Diagnosis& diagnosis) {
  PlotSpec spec;
  spec.title = "Held-out residual (measured - predicted) along " + inputs.check_path;
  PlotPanel before{"nominal model", "t [s]", "residual [deg]", {}, false};
  PlotPanel after{"after diagnosis (" + model_name(diagnosis) + ")", "t [s]", "residual [deg]", {}, false};
  for (int j = 0; j < 3; ++j) {
    PlotSeries b{"alpha" + std::to_string(j + 1), {}, {}, false}, a = b;
    for (std::size_t i = 0; i < check.size(); ++i) {
      b.x.push_back(check[i].t_s);
      b.y.push_back(check[i].alpha_deg[j] - diagnosis.check_nominal_deg[i][j]);
      a.x.push_back(check[i].t_s);
      a.y.push_back(check[i].alpha_deg[j] - diagnosis.check_after_deg[i][j]);
    }
    before.series.push_back(std::move(b));
    after.series.push_back(std::move(a));
  }
  spec.panels = {before, after};
  write_plot(png_path, spec);
}

// Effect ranking: held-out RMSE as effects are added, and what each would still add.
void write_ranking_plot(const std::string& png_path, const Diagnosis& diagnosis) {
  const double floor = diagnosis.noise_floor_deg;
  PlotSpec spec;
  spec.title = "Effect ranking on held-out data";
  PlotPanel path{
      "held-out RMSE (mean over joints) after each added effect; step 0 = nominal", "step", "RMSE [deg]", {}, true};
  PlotSeries model{"model", {0.0}, {rms(diagnosis.holdout_rmse_nominal_deg)}, true};
  PlotSeries floor_line{"noise floor 0.01/sqrt(12) deg", {}, {}, false};
  int step = 0;
  for (const EffectFinding& finding : diagnosis.findings) {
    if (!finding.significant) continue;
    model.x.push_back(++step);
    model.y.push_back(rms(finding.holdout_rmse_deg));
  }
  floor_line.x = {0.0, static_cast<double>(std::max(step, 1))};
  floor_line.y = {floor, floor};
  path.series = {model, floor_line};
  PlotPanel gains{"held-out MSE gain of each family at its rank (ranked order; significant first)",
                  "rank",
                  "gain [deg^2]",
                  {},
                  true};
  PlotSeries gain{"gain", {}, {}, true};
  PlotSeries threshold{"significance threshold", {}, {}, false};
  for (std::size_t r = 0; r < diagnosis.findings.size(); ++r) {
    gain.x.push_back(static_cast<double>(r + 1));
    gain.y.push_back(std::max(diagnosis.findings[r].holdout_gain_deg2, 1e-12));
  }
  threshold.x = {1.0, static_cast<double>(diagnosis.findings.size())};
  threshold.y = {diagnosis.significance_threshold_deg2, diagnosis.significance_threshold_deg2};
  gains.series = {gain, threshold};
  spec.panels = {path, gains};
  write_plot(png_path, spec);
}

// The report's title, data, verdict, warnings and closed-loop note.
void write_report_head(std::ostream& out, const ReportInputs& inputs, const std::vector<Sample>& check,
                       const Diagnosis& diagnosis) {
  out << "# Sim-to-real diagnosis\n\n"
      << "Fitted on `" << inputs.fit_path << "` (" << inputs.fit_rows << " rows), judged on the held-out `"
      << inputs.check_path << "` (" << check.size()
      << " rows). Noise floor (encoder quantisation 0.01 deg / sqrt(12)): " << fixed(diagnosis.noise_floor_deg, 5)
      << " deg.\n\n"
      << "**Verdict:** " << verdict(diagnosis) << "; " << fixed(100.0 * diagnosis.explained_fraction, 1)
      << " % of the held-out mean-square error above the floor removed.\n\n";
  for (const std::string& warning : diagnosis_warnings(diagnosis)) out << "**Warning:** " << warning << "\n\n";
  if (diagnosis.fit_closed_loop) out << closed_loop_note(diagnosis) << ".\n\n";
}

// The sets CHECK cannot tell from the chosen one, when there are any.
void write_alternatives_section(std::ostream& out, const Diagnosis& diagnosis) {
  if (diagnosis.alternatives.empty()) return;
  out << "## Equivalent explanations\n\nSets the held-out data cannot tell from the chosen one (held-out MSE "
         "not worse by more than the stopping rule's threshold, or not significantly by the paired test; same "
         "floor test). `significant` in the JSON stays the chosen set.\n\n";
  Table table({"effects", "held-out RMSE a1/a2/a3 [deg]", "MSE - chosen [deg^2]", "paired z", "separate by"});
  for (const Alternative& alternative : diagnosis.alternatives) {
    std::ostringstream difference;
    difference.precision(3);
    difference << alternative.mse_difference_deg2;
    table.add_row({describe_as_added(alternative.families, diagnosis),
                   fixed(alternative.holdout_rmse_deg[0], 5) + " / " + fixed(alternative.holdout_rmse_deg[1], 5) +
                       " / " + fixed(alternative.holdout_rmse_deg[2], 5),
                   difference.str(), fixed(alternative.paired_z, 2), alternative.separate_by});
  }
  table.print(out);
  out << "\n";
}

// The floor test: its noise model, its statistic and whether the final model is at the floor.
void write_floor_test_section(std::ostream& out, const FloorTest& test) {
  out << "## Floor test\n\nNoise model per joint: encoder quantisation 0.01/sqrt(12) deg, stage quantisation "
         "6.87 nm/sqrt(12) per axis through the kinematics ("
      << format_number(test.stage_sigma_deg) << " deg RMS) and an extra white noise estimated from the FIT "
      << "residual differences (" << format_number(test.extra_noise_deg) << " deg, z = " << fixed(test.extra_noise_z, 2)
      << "; counted only above z = 4). Statistic: mean of r^2 / sigma^2 over the " << test.rows
      << " held-out rows against 1, standard error by batch means over " << test.blocks << " blocks; ratio "
      << fixed(test.ratio, 4) << " (joints " << fixed(test.joint_ratio[0], 4) << " / " << fixed(test.joint_ratio[1], 4)
      << " / " << fixed(test.joint_ratio[2], 4) << "), z = " << fixed(test.z, 2) << " (joints "
      << fixed(test.joint_z[0], 2) << " / " << fixed(test.joint_z[1], 2) << " / " << fixed(test.joint_z[2], 2)
      << "); at the floor when z <= " << fixed(test.threshold, 1)
      << " and every joint's z <= " << fixed(test.threshold + 0.5, 1) << ": " << (test.at_floor ? "yes" : "no")
      << ".\n\n";
}

// The rows left out of the fit and the scores, when there are any.
void write_outliers_section(std::ostream& out, const Diagnosis& diagnosis) {
  if (diagnosis.outliers.empty()) return;
  out << "## Outlier rows (left out of the fit and the scores)\n\n";
  Table table({"recording", "data row", "t [s]", "position spike [mm]", "angle spike [deg]"});
  for (const Outlier& outlier : diagnosis.outliers) {
    table.add_row({outlier.recording, std::to_string(outlier.row), fixed(outlier.t_s, 3),
                   fixed(outlier.position_spike_mm, 4), fixed(outlier.angle_spike_deg, 4)});
  }
  table.print(out);
  out << "\n";
}

// The ranked effects with their parameters and intervals, the ranking plot, and what backward
// elimination dropped.
void write_ranking_section(std::ostream& out, const Diagnosis& diagnosis, const std::string& ranking_png) {
  out << "\n## Effects, ranked\n\nSignificant effects in the order forward selection added them (judged on the "
         "held-out rows only); then the others by the held-out gain they would still bring. The stopping rule "
         "keeps an effect only if it lowers the held-out mean-square error by more than "
      << format_number(diagnosis.significance_threshold_deg2) << " deg^2.\n\n";
  Table ranking({"rank", "effect", "subsystem", "significant", "held-out gain [deg^2]", "parameters (SPEC units)",
                 "95 % half width (final model)"});
  for (std::size_t r = 0; r < diagnosis.findings.size(); ++r) {
    const EffectFinding& finding = diagnosis.findings[r];
    std::ostringstream gain;
    gain.precision(3);
    gain << finding.holdout_gain_deg2;
    ranking.add_row({std::to_string(r + 1), family_name(finding.family), subsystem_of(finding.family),
                     finding.significant ? "yes" : "no", gain.str(),
                     joined_parameters(finding.family, finding.significant ? diagnosis.theta : finding.theta),
                     finding.significant
                         ? joined_parameters(finding.family, confidence_theta(finding.family, diagnosis.confidence_95,
                                                                              diagnosis.final_model))
                         : std::string("")});
  }
  ranking.print(out);
  out << "\n![effect ranking](" << ranking_png << ")\n";
  if (!diagnosis.eliminated.empty()) {
    out << "\nBackward elimination dropped again:";
    for (const Elimination& entry : diagnosis.eliminated) out << ' ' << elimination_text(entry);
    out << " (made redundant by effects added later).\n";
  }
}

// Where the gap lives: per subsystem and per octant of the workspace, with the map and residual plots.
void write_where_sections(std::ostream& out, const Diagnosis& diagnosis, const std::string& map_png,
                          const std::string& residual_png) {
  out << "\n## Where: per subsystem\n\nHeld-out RMSE of the final model with one subsystem's effects taken out "
         "(the part of the gap that lives there).\n\n";
  Table subsystems({"final model without", "alpha_1 [deg]", "alpha_2 [deg]", "alpha_3 [deg]"});
  for (const auto& [name, rmse] : diagnosis.subsystem_rmse_without_deg) {
    subsystems.add_row({name, fixed(rmse[0], 5), fixed(rmse[1], 5), fixed(rmse[2], 5)});
  }
  subsystems.add_row({"(nothing: final model)", fixed(diagnosis.holdout_rmse_after_deg[0], 5),
                      fixed(diagnosis.holdout_rmse_after_deg[1], 5), fixed(diagnosis.holdout_rmse_after_deg[2], 5)});
  subsystems.print(out);

  out << "\n## Where: per workspace region (held-out octants of the trajectory's bounding box)\n\n";
  Table regions({"octant", "rows", "nominal RMSE a1/a2/a3 [deg]", "after RMSE a1/a2/a3 [deg]"});
  for (const RegionError& region : diagnosis.regions) {
    auto three = [](const Vec3& v) { return fixed(v[0], 4) + " / " + fixed(v[1], 4) + " / " + fixed(v[2], 4); };
    regions.add_row(
        {region.label, std::to_string(region.samples), three(region.nominal_rmse_deg), three(region.after_rmse_deg)});
  }
  regions.print(out);
  out << "\n![error map before and after](" << map_png << ")\n\n![residual along the trajectory](" << residual_png
      << ")\n";
}

void write_selection_trace(std::ostream& out, const Diagnosis& diagnosis) {
  out << "\n## Selection trace (held-out RMSE, mean over joints, of each candidate)\n\n";
  for (const SelectionStep& step : diagnosis.steps) {
    out << "- from **" << describe_as_added(step.base, diagnosis) << "**: ";
    for (std::size_t c = 0; c < step.candidate_mse.size(); ++c) {
      out << (c ? ", " : "") << family_name(step.candidate_mse[c].first) << " "
          << fixed(std::sqrt(step.candidate_mse[c].second), 5);
    }
    out << " -> " << (step.chosen >= 0 ? std::string("added ") + family_name(family_at(step.chosen)) : "stop") << "\n";
  }
}

// One model's identifiability: its singular values, weak directions and strongest correlations.
void write_weak_section(std::ostream& out, const Identifiability& identifiability, const std::string& what) {
  out << "### " << what << " (" << identifiability.model << ")\n\n";
  if (!identifiability.singular_values.empty()) {
    out << "Normalised Jacobian singular values: largest " << fixed(identifiability.singular_values.front(), 3)
        << ", smallest " << format_number(identifiability.singular_values.back()) << ".\n\n";
  }
  if (identifiability.weak.empty()) {
    out << "No direction below 1e-2: every parameter is determined by this data.\n\n";
  }
  for (const WeakDirection& direction : identifiability.weak) {
    out << "- singular value " << format_number(direction.singular_value) << ": ";
    for (std::size_t c = 0; c < direction.components.size() && c < 6; ++c) {
      out << (c ? " " : "") << (direction.components[c].second >= 0 ? "+" : "-")
          << fixed(std::abs(direction.components[c].second), 2) << " "
          << parameter_table()[direction.components[c].first].name;
    }
    out << ". Separate by: " << direction.advice << ".\n";
  }
  if (!identifiability.correlations.empty()) {
    out << "\nStrongest parameter correlations:";
    for (const Correlation& c : identifiability.correlations) {
      out << " " << parameter_table()[c.a].name << "~" << parameter_table()[c.b].name << " " << fixed(c.value, 3)
          << ";";
    }
    out << "\n\n";
  }
}

void write_identifiability_section(std::ostream& out, const Diagnosis& diagnosis) {
  out << "\n## What this data cannot tell apart\n\n";
  write_weak_section(out, diagnosis.final_model, "The fitted model");
  write_weak_section(out, diagnosis.all_families, "Every family of the vocabulary at once");
  out << "Gauge fixing: with chain_angle and frame_misalignment both in a model the common chain rotation is "
         "pinned to zero (it is the frame yaw rz); every parameter carries a weak prior worth one observation at "
         "the noise floor, so directions the data cannot see stay at zero instead of drifting.\n";
}

}  // namespace

void write_report(const std::string& markdown_path, const ReportInputs& inputs, const std::vector<Sample>& check,
                  const Diagnosis& diagnosis) {
  namespace fs = std::filesystem;
  const fs::path markdown(markdown_path);
  const std::string stem = markdown.stem().string();
  const fs::path folder = markdown.has_parent_path() ? markdown.parent_path() : fs::path(".");
  const std::string residual_png = stem + "_residual.png", ranking_png = stem + "_ranking.png",
                    map_png = stem + "_map.png";
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) throw InputError(markdown_path, 0, "cannot create the report folder: " + error.message());

  write_residual_plot((folder / residual_png).string(), inputs, check, diagnosis);
  write_ranking_plot((folder / ranking_png).string(), diagnosis);
  write_error_map((folder / map_png).string(), check, diagnosis);

  OutputFile file(markdown_path);
  std::ostream& out = file.stream();
  write_report_head(out, inputs, check, diagnosis);
  write_alternatives_section(out, diagnosis);
  write_floor_test_section(out, diagnosis.floor_test);
  write_outliers_section(out, diagnosis);
  out << "## How far the gap shrinks (held-out RMSE per joint)\n\n";
  print_summary(out, diagnosis);
  write_ranking_section(out, diagnosis, ranking_png);
  write_where_sections(out, diagnosis, map_png, residual_png);
  write_selection_trace(out, diagnosis);
  write_identifiability_section(out, diagnosis);
  file.commit();
}

}  // namespace delta::diagnosis
