// deltactl run-report: a run's accuracy, the plate against its reference and the joints against
// theirs, moving, at rest and through reversals (run_report.hpp), with the plate from the run's own
// columns, the measuring stage's log (its clock aligned by the merge) or the virtual board's truth.
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/diagnosis/stage_log.hpp"
#include "delta/output_file.hpp"
#include "delta/run_report.hpp"

namespace delta {
namespace {

struct RunReportOptions {
  std::string run, stage, truth, json;
};

void run_run_report(const RunReportOptions& options) {
  const RunColumns run = read_run_columns(options.run);
  std::unique_ptr<OutputFile> json;
  if (!options.json.empty()) json = std::make_unique<OutputFile>(options.json);
  PlateTrack plate;
  bool have_plate = true;
  if (!options.stage.empty()) {
    plate = diagnosis::plate_from_stage(run, diagnosis::read_stage_log(options.stage));
  } else if (!options.truth.empty()) {
    plate = plate_from_truth(run, options.truth);
  } else if (!run.plate_m.empty()) {
    plate = plate_from_run(run);
  } else {
    have_plate = false;
  }
  const RunReport report = make_run_report(run, have_plate ? &plate : nullptr);
  if (json) {
    json->stream() << report_json(report).dump(2) << '\n';
    json->finish();
    json->commit();
  }
  std::cout << report_text(report);
  if (json) std::cout << "json: " << options.json << '\n';
}

const RegisterCommand command("run-report", 62, [](CLI::App& root) {
  auto options = std::make_shared<RunReportOptions>();
  CLI::App* sub = root.add_subcommand(
      "run-report", "A run's accuracy: the plate against its reference (moving, at rest, at reversals), the joints");
  sub->footer(
      "\nRUN.csv: a 'deltactl host run' recording (t_s board time, x/y/z_ref_m the pose asked for,\n"
      "alpha*_ref_deg the board's joint references, alpha*_deg the encoders, drives_enabled), or the\n"
      "DATA.csv 'deltactl merge' made of one (it carries those columns and the stage's x_m,y_m,z_m),\n"
      "or a co-simulation's 'deltactl cosim --out' (its net*_deg and ref_*_m the same quantities).\n"
      "The rows with the drives on are reported, at each row's board time:\n"
      "  plate - reference: the plate (x_m,y_m,z_m, in the frame of what measured it: the stage's,\n"
      "    the frame the model was trained in) minus x/y/z_ref_m; RMS and max per axis and of the\n"
      "    distance;\n"
      "  joint reference - encoder: alpha*_ref_deg - alpha*_deg, RMS and max per joint.\n"
      "The plate comes from, in this order: --stage STAGE.csv (the stage's own log on its own clock;\n"
      "its clock is aligned to the run's board time exactly as 'deltactl merge' does, from the board's\n"
      "sync output when the log has a column sync, else from the data: see 'merge --help'); --truth\n"
      "TRUTH.csv (the virtual board's truth, board time, interpolated at each row); the run's own\n"
      "x_m,y_m,z_m (a merged recording). Without any of them only the joints are measured: the report\n"
      "says the plate is not, and what would measure it.\n"
      "Each figure is given for all rows and split by what the reference does:\n"
      "  at rest: dwells, at least 0.1 s with the reference within 1 um (joint references: 0.001 deg)\n"
      "    of where it started; each dwell's start, duration, mean and max plate error;\n"
      "  reversals: from 20 ms before to 100 ms after a reversal of any axis's or joint's reference\n"
      "    (the last row at its extreme, a peak or the end of a dwell there, before it turns back by\n"
      "    more than 5 um or 0.005 deg), rows at rest excepted; where backlash shows;\n"
      "  moving: every other row.\n"
      "OUT.json (--json): the same figures (micrometres, degrees), the dwells, the reversals' times\n"
      "and these definitions. Bad input (a file that is not such a run, log or truth; a run with no\n"
      "row with the drives on; logs that the merge cannot align): exit 2, one line, no output.\n"
      "Examples:\n"
      "  deltactl run-report --run run.csv --stage stage.csv --json report.json\n"
      "  deltactl run-report --run run.csv --truth truth.csv     # the virtual board's truth\n"
      "  deltactl run-report --run run.csv                       # the joints only");
  sub->add_option("--run", options->run, "RUN.csv: the host's recording of the run (board time)")->required();
  auto* stage =
      sub->add_option("--stage", options->stage, "STAGE.csv: the measuring stage's own log (its clock, aligned here)");
  auto* truth = sub->add_option("--truth", options->truth, "TRUTH.csv: the virtual board's truth (board time)");
  stage->excludes(truth);
  truth->excludes(stage);
  sub->add_option("--json", options->json, "OUT.json: the report as JSON");
  sub->callback([options] { run_run_report(*options); });
});

}  // namespace
}  // namespace delta
