// Outputs of `deltactl diagnose`: the SPEC JSON, the predictions CSV and a Markdown report with plots.
#pragma once

#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

#include "delta/diagnosis/diagnose.hpp"

namespace delta::diagnosis {

// Parameters of one family in SPEC units, as a JSON object (per-joint values as 3-arrays).
nlohmann::json family_parameters_json(Family family, const Parameters& theta);

// The SPEC result document (noise_floor_deg, explained, ranked effects, holdout) plus the
// selection trace, location, identifiability and the fitted effects as an effect file.
nlohmann::json diagnosis_json(const Diagnosis& diagnosis);

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
