// deltactl diagnose: which unmodelled effect explains a recording, judged on held-out data (SPEC).
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/diagnosis/diagnose.hpp"
#include "delta/diagnosis/report.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "delta/output_file.hpp"
#include "delta/recording.hpp"
#include "options.hpp"

namespace delta {
namespace {

struct DiagnoseOptions {
  std::string data;
  std::string holdout;
  std::string json;
  std::string predictions;
  std::string report;
  double significance = 0.05;
  bool unreferenced = false;  // take recordings whose counts were not referenced at the home switches
};

constexpr std::size_t kMinimumRows = 50;

// Every measured position must be reachable by the nominal robot, else the file is not a
// recording of this robot (or a row is corrupt): name the first such line.
void check_reachable(const Recording& recording) {
  if (recording.samples.size() < kMinimumRows) {
    throw InputError(recording.path, 0,
                     "has " + std::to_string(recording.samples.size()) + " rows; a diagnosis needs at least " +
                         std::to_string(kMinimumRows));
  }
  const Geometry nominal = Geometry::nominal();
  for (std::size_t i = 0; i < recording.samples.size(); ++i) {
    const IkSolution ik = inverse_kinematics(nominal, recording.samples[i].position_m);
    if (!ik.ok()) {
      throw InputError(recording.path, recording.line_numbers[i],
                       "the nominal robot cannot reach this plate position (" + ik.reason() + ")");
    }
  }
}

void run_diagnose(const DiagnoseOptions& options) {
  const Recording fit = read_recording(options.data);
  const Recording check = read_recording(options.holdout);
  check_referenced(fit, options.unreferenced);
  check_referenced(check, options.unreferenced);
  check_reachable(fit);
  check_reachable(check);
  // Open the outputs before the long computation, so an unwritable folder fails at once.
  OutputFile json_file(options.json);
  OutputFile predictions_file(options.predictions);
  diagnosis::DiagnosisOptions diagnosis_options;
  diagnosis_options.significance = options.significance;
  const diagnosis::Diagnosis result = diagnosis::diagnose(fit.samples, check.samples, diagnosis_options);
  json_file.stream() << diagnosis::diagnosis_json(result).dump(2) << '\n';
  diagnosis::write_predictions(predictions_file.stream(), check.samples, result);
  if (!options.report.empty()) {
    diagnosis::write_report(options.report, {options.data, options.holdout, fit.samples.size()}, check.samples, result);
  }
  json_file.finish();  // both complete before either appears
  predictions_file.finish();
  json_file.commit();
  predictions_file.commit();
  diagnosis::print_summary(std::cout, result);
  if (result.check_unreachable) {
    std::cerr << "diagnose: " << result.check_unreachable
              << " held-out rows are unreachable for the fitted model (their previous angle is held)\n";
  }
}

const RegisterCommand command("diagnose", 60, [](CLI::App& root) {
  auto options = std::make_shared<DiagnoseOptions>();
  CLI::App* sub = root.add_subcommand(
      "diagnose", "Sim-to-real diagnosis: which unmodelled effect explains a recording, proved on held-out data");
  sub->footer(
      "\nFits the nominal model plus the effects of docs/contracts.md to FIT only (Levenberg-Marquardt, autodiff\n"
      "through the sim's inverse kinematics). Forward selection adds the family that lowers the held-out (CHECK)\n"
      "error most while it lowers the mean-square error by more than --significance x floor^2 and significantly\n"
      "(paired test on the CHECK rows, z > 3), floor being the encoder quantisation 0.01/sqrt(12) deg; backward\n"
      "elimination drops families later ones made redundant. Outlier rows (isolated position or angle spikes)\n"
      "are left out and listed. 'explained' is the floor test: the held-out mean of r^2 / sigma^2 (noise model:\n"
      "encoder and stage quantisation, plus extra noise when FIT shows one) is not above 1 by more than 4\n"
      "standard errors (batch means). 'alternatives' lists other effect sets CHECK cannot tell from the chosen one.\n"
      "A scale error of the measuring stage, which the vocabulary can only imitate (uniform: by scaling every\n"
      "length; one axis: by encoder scales, the frame and the lengths together), is reported as the new effect\n"
      "'measuring_scale' (parameter s, or s_x, s_y, s_z) when it does as well with fewer parameters or reaches\n"
      "the floor where the vocabulary does not.\n"
      "A fitted joint offset beyond 2 deg (no assembled robot has one: counts not referenced at the home\n"
      "switches) is a warning in the summary, the report and the JSON's warnings. A recording whose header\n"
      "says '# referenced: hand' or 'none' (host record --unreferenced) is refused unless --unreferenced.\n"
      "Outputs: JSON (ranked effects, parameters, held-out RMSE per joint, selection trace, location per\n"
      "subsystem and octant, identifiability), PRED.csv (t_s,alpha1_deg,alpha2_deg,alpha3_deg per CHECK row,\n"
      "final model), and with --report a Markdown report with PNG plots beside it.\n"
      "Example:\n"
      "  deltactl simulate --experiment validation --effects E.json --out fit.csv\n"
      "  deltactl simulate --experiment sweep --seed 3 --effects E.json --out check.csv\n"
      "  deltactl diagnose --data fit.csv --holdout check.csv --json diag.json --predictions pred.csv \\\n"
      "                    --report report/diagnosis.md");
  sub->add_option("--data", options->data,
                  "FIT recording (docs/contracts.md): the only rows the parameters are fitted on")
      ->required();
  sub->add_option("--holdout", options->holdout, "CHECK recording (docs/contracts.md): judges effects, never fitted")
      ->required();
  sub->add_option("--json", options->json, "result document to write")->required();
  sub->add_option("--predictions", options->predictions, "predicted angles for every CHECK row")->required();
  sub->add_option("--report", options->report, "Markdown report to write (PNG plots go beside it)");
  sub->add_flag("--unreferenced", options->unreferenced,
                "diagnose recordings whose header says their counts were not referenced at the home switches "
                "('# referenced: hand' or 'none'; refused otherwise)");
  sub->add_option("--significance", options->significance,
                  "stopping rule: minimum held-out MSE drop in units of floor^2")
      ->capture_default_str()
      ->check(options::real_number(0, 1e6, true));
  sub->callback([options] { run_diagnose(*options); });
});

}  // namespace
}  // namespace delta
