// Outputs of `deltactl diagnose`: the SPEC JSON, the predictions CSV and a Markdown report with plots.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "delta/diagnosis/diagnose.hpp"

namespace delta::diagnosis {

// Parameters of one family in SPEC units, as a JSON object (per-joint values as 3-arrays).
nlohmann::json family_parameters_json(Family family, const Parameters& theta);

// The SPEC result document (noise_floor_deg, explained, ranked effects, holdout) plus the
// selection trace, location, identifiability and the fitted effects as an effect file.
nlohmann::json diagnosis_json(const Diagnosis& diagnosis);

// A joint offset beyond this no assembled robot has (an arm keyed to its shaft, its home switch
// set at its reference: tenths of a degree, the paper-like robot's 0.2-0.5): counts not referenced
// where the robot was homed (homed by hand elsewhere, never homed, a homing that did not finish).
constexpr double kPlausibleJointOffsetDeg = 2.0;

// One line per thing in the result a person should act on: each fitted joint offset beyond
// kPlausibleJointOffsetDeg, naming homing as its likely cause (JSON "warnings", the summary, the
// report).
std::vector<std::string> diagnosis_warnings(const Diagnosis& diagnosis);

// t_s,alpha1_deg,alpha2_deg,alpha3_deg for every CHECK row, in order (final model).
void write_predictions(std::ostream& out, const std::vector<Sample>& check, const Diagnosis& diagnosis);

struct ReportInputs {
  std::string fit_path;
  std::string check_path;
  std::size_t fit_rows = 0;
};

// Markdown report at `markdown_path`, PNG plots beside it (<stem>_residual.png, _ranking.png,
// _map.png). Throws std::runtime_error when gnuplot fails.
void write_report(const std::string& markdown_path, const ReportInputs& inputs, const std::vector<Sample>& check,
                  const Diagnosis& diagnosis);

// The short summary deltactl prints: ranked effects and held-out RMSE per joint.
void print_summary(std::ostream& out, const Diagnosis& diagnosis);

}  // namespace delta::diagnosis
