// deltactl merge: a run recorded by the host and the measuring stage's own log, aligned without a
// shared clock and merged into one recording on the run's board time (docs/contracts.md, "The lab's measurements").
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "delta/csv.hpp"
#include "delta/diagnosis/merge.hpp"
#include "delta/diagnosis/stage_log.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"
#include "delta/recording.hpp"
#include "delta/table.hpp"

namespace delta {
namespace {

// Below this fraction of the offset's or the rate's signal left by the nuisance (10 minute drags:
// about 0.1 and 0.5; 2 minute ones below 0.01), the summary says the clocks are poorly fixed.
constexpr double kSignalLeast = 0.01;

struct MergeOptions {
  std::string run, stage, out, report;
};

// The run's columns carried into DATA.csv when present (after the SPEC columns).
const std::vector<std::string> kCarried = {"drives_enabled", "alpha1_ref_deg", "alpha2_ref_deg", "alpha3_ref_deg",
                                           "x_ref_m",        "y_ref_m",        "z_ref_m",        "fault_bits",
                                           "flags",          "stream_sample"};

// The merge's figures as --report writes them.
nlohmann::json merge_report(const MergeOptions& options, const diagnosis::MergeResult& m, bool closed_loop) {
  return {{"run", options.run},
          {"closed_loop", closed_loop},
          {"stage", options.stage},
          {"clock_from", m.from_sync ? "sync" : "data"},
          {"sync_changes", m.sync_changes},
          {"sync_consistent", m.sync_consistent},
          {"data_offset_s", m.data_offset_s},
          {"data_offset_sd_s", m.data_offset_sd_s},
          {"data_rate_ppm", m.data_rate_ppm},
          {"data_rate_sd_ppm", m.data_rate_sd_ppm},
          {"data_residual_rms_m", m.data_residual_rms_m},
          {"sync_shift_s", m.sync_shift_s},
          {"sync_corrected_lost_alignment", m.sync_corrected_lost_alignment},
          {"offset_s", m.offset_s},
          {"offset_sd_s", m.offset_sd_s},
          {"rate_ppm", m.rate_ppm},
          {"rate_sd_ppm", m.rate_sd_ppm},
          {"offset_signal_left", m.offset_signal_left},
          {"rate_signal_left", m.rate_signal_left},
          {"residual_rms_m", m.residual_rms_m},
          {"motion_rms_m", m.motion_rms_m},
          {"correlation", m.correlation},
          {"overlap_s", m.overlap_s},
          {"run_rows", m.run_rows},
          {"stage_rows", m.stage_rows},
          {"fit_rows", m.fit_rows},
          {"merged_rows", m.merged_rows},
          {"clock_model", "t_stage = offset_s + (1 + rate_ppm * 1e-6) * t_board"},
          {"uncertainty", m.from_sync ? "standard (1 sigma), of the region the sync output's changes leave"
                                      : "standard (1 sigma), residuals correlated over 2 s blocks"}};
}

// What the user should know of a merge: counts not referenced at the home switches, a sync that
// corrected or never changed, a closed-loop run without the sync, clocks poorly fixed.
void print_merge_warnings(const MergeOptions& options, const diagnosis::MergeResult& m,
                          const std::optional<Referencing>& referencing, const diagnosis::StageLog& stage,
                          bool closed_loop, std::size_t drives_on, std::size_t run_rows) {
  if (referencing && *referencing != Referencing::kHomeSwitches) {
    std::cout << "merge: warning: " << options.run << " says its counts were not referenced at the home switches "
              << "(referenced: " << referencing_name(*referencing) << "), and so does " << options.out
              << ": diagnose and train refuse it unless --unreferenced\n";
  }
  if (m.sync_corrected_lost_alignment) {
    std::cout << "merge: the positions alone put the clocks " << fixed(m.sync_shift_s, 3)
              << " s off (this drag cannot fix them: too short or too repetitive); the sync output's phase "
                 "corrected them, and the positions fit there as well\n";
  }
  if (!stage.sync.empty() && !m.from_sync) {
    std::cout << "merge: the stage's sync column never changes (its input not wired to the board's stage_sync_o?): "
                 "the clocks come from the data alone\n";
  }
  if (closed_loop && !m.from_sync) {
    std::cout << "merge: a closed-loop run (the drives on in " << drives_on << " of " << run_rows
              << " rows): the readings are corrected for the controller's lead over the arm, but inside a "
                 "joint's play the arm falls back and creeps on unseen by them, and the alignment can be "
                 "milliseconds off (1.5-4.2 ms, 3-11 um of plate, on 4-5 minute runs of robots with 0.1-0.25 deg "
                 "of play): log the board's stage sync output with the stage (a column sync), or calibrate on "
                 "drags\n";
  }
  if (!m.from_sync && (m.offset_signal_left < kSignalLeast || m.rate_signal_left < kSignalLeast)) {
    std::cout << "merge: the logs fix the clocks poorly (the robot's unknown effects absorb "
              << fixed(100.0 * (1.0 - m.offset_signal_left), 1) << " % of the offset's signal and "
              << fixed(100.0 * (1.0 - m.rate_signal_left), 1)
              << " % of the rate's; the uncertainties are larger than stated): drag longer, 5 minutes or more of "
                 "the validation run or a sweep\n";
  }
}

void run_merge(const MergeOptions& options) {
  const CsvTable run = read_csv(options.run, {"t_s", "alpha1_deg", "alpha2_deg", "alpha3_deg"}, kCarried);
  const std::optional<Referencing> referencing = referencing_of(run);  // carried into DATA.csv
  for (std::size_t i = 0; i < run.rows.size(); ++i) {  // the bounds diagnose and train apply to DATA.csv
    check_time_order(run, i, 0);
    check_plausible_angles(run, i, 1, 3);
    check_plausible_angles(run, i, 5, 3);     // alpha*_ref_deg (0 when absent)
    check_plausible_positions(run, i, 8, 3);  // x/y/z_ref_m
  }
  const diagnosis::StageLog stage = diagnosis::read_stage_log(options.stage);
  std::vector<double> run_t(run.rows.size());
  std::vector<Vec3> alpha(run.rows.size());
  for (std::size_t i = 0; i < run.rows.size(); ++i) {
    run_t[i] = run.rows[i][0];
    alpha[i] = Vec3(run.rows[i][1], run.rows[i][2], run.rows[i][3]);
  }
  OutputFile data(options.out);
  std::unique_ptr<OutputFile> report;
  if (!options.report.empty()) report = std::make_unique<OutputFile>(options.report);
  const diagnosis::MergeResult m =
      diagnosis::merge_logs(options.run, run_t, alpha, options.stage, stage.t_s, stage.position_m, stage.sync);

  std::ostream& out = data.stream();
  out << "# deltactl merge --run " << options.run << " --stage " << options.stage << "\n"
      << "# t_stage = offset + (1 + rate 1e-6) t_board: offset " << format_number(m.offset_s) << " +- "
      << format_number(m.offset_sd_s) << " s, rate " << format_number(m.rate_ppm) << " +- "
      << format_number(m.rate_sd_ppm) << " ppm (from "
      << (m.from_sync ? std::to_string(m.sync_changes) + " changes of the board's sync output" : "the data alone")
      << "); x/y/z_m: the stage at the aligned instants\n";
  if (referencing) out << "# " << referencing_comment(*referencing) << "\n";
  out << "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m";
  std::vector<std::size_t> carried;
  for (std::size_t k = 0; k < kCarried.size(); ++k) {
    if (run.present[4 + k]) {
      carried.push_back(4 + k);
      out << ',' << kCarried[k];
    }
  }
  out << '\n';
  for (std::size_t r = 0; r < m.merged_rows; ++r) {
    const auto& row = run.rows[m.run_row[r]];
    out << format_number(row[0]);
    for (int k = 1; k <= 3; ++k) out << ',' << format_number(row[static_cast<std::size_t>(k)]);
    for (int k = 0; k < 3; ++k) out << ',' << format_number(m.position_m[r][k]);
    for (std::size_t c : carried) out << ',' << format_number(row[c]);
    out << '\n';
  }
  // A closed-loop run (rows with the drives on): the merge corrects the readings for the
  // controller's lead (diagnosis/src/closed_loop.hpp), but the arm's fall-back inside a joint's play
  // changes with the speed, and the alignment takes part of it for a clock offset.
  std::size_t drives_on = 0;
  if (run.present[4]) {
    for (const auto& row : run.rows) drives_on += row[4] != 0.0 ? 1 : 0;
  }
  const bool closed_loop = drives_on > run.rows.size() / 2;
  if (report) {
    const nlohmann::json j = merge_report(options, m, closed_loop);
    report->stream() << j.dump(2) << '\n';
    report->finish();
  }
  data.finish();
  data.commit();
  if (report) report->commit();
  std::cout << "merge: " << m.merged_rows << " of " << m.run_rows << " run rows covered by the stage ("
            << fixed(m.overlap_s, 1) << " s); t_stage = " << fixed(m.offset_s, 6) << " s + (1 + "
            << fixed(m.rate_ppm, 3) << " ppm) t_board; uncertainty " << fixed(m.offset_sd_s * 1e6, 1) << " us, "
            << fixed(m.rate_sd_ppm, 3) << " ppm, from "
            << (m.from_sync ? std::to_string(m.sync_changes) + " changes of the board's sync output (the data: " +
                                  fixed((m.data_offset_s - m.offset_s) * 1e3, 3) + " ms, " +
                                  fixed(m.data_rate_ppm - m.rate_ppm, 3) + " ppm off it)"
                            : std::string("the data alone"))
            << "; residual " << fixed(m.residual_rms_m * 1e6, 2) << " um RMS -> " << options.out << '\n';
  print_merge_warnings(options, m, referencing, stage, closed_loop, drives_on, run.rows.size());
}

const RegisterCommand command("merge", 61, [](CLI::App& root) {
  auto options = std::make_shared<MergeOptions>();
  CLI::App* sub = root.add_subcommand(
      "merge", "Merge a host recording with the measuring stage's own log (clocks from the data or the board's sync)");
  sub->footer(
      "\nRUN.csv: a 'deltactl host record' or 'host run' recording (t_s board time, alpha*_deg encoders).\n"
      "STAGE.csv: the stage controller's log (t_s on its own clock, x_m,y_m,z_m, optionally sync). No\n"
      "shared clock: the stage's clock is found as t_stage = offset + (1 + rate 1e-6) t_board from the\n"
      "data alone, by matching the plate the stage saw with the plate the encoders imply (nominal\n"
      "forward kinematics of the readings interpolated between their counts; an affine map, a cubic\n"
      "polynomial of the plate, the joints' play and a spline of each reading absorbing the robot's\n"
      "unknown effects): a cross-correlation over every offset, then a least-squares fit of offset and\n"
      "rate on the rows (at most 20000) where no joint sits inside its play, outliers dropped. The rate\n"
      "needs a drag that comes back to the same joint angles at other times (5 minutes or more of the\n"
      "validation run or a sweep); on a shorter one (or a single ellipse, such as experiment1) the\n"
      "summary says the clocks are poorly fixed. In closed loop the arm's fall-back inside its play\n"
      "leaves milliseconds of error. A column sync (0/1) is the board's stage sync output as the stage\n"
      "sampled it (wire stage_sync_o, docs/lab_loop.md): then the clocks come from its changes, each\n"
      "bounding offset and rate between two stage samples, to within microseconds, closed loop or not\n"
      "(the data's alignment, reported beside it, tells which change is which, corrected by the\n"
      "changes' phase when the data alone are up to 0.3 s off); a sync column that does not follow the\n"
      "board's output, looks inverted (its changes one level, 0.41 s, off) or whose clocks do not fit\n"
      "the positions is refused.\n"
      "DATA.csv: a recording (docs/contracts.md: t_s,alpha1..3_deg,x_m,y_m,z_m, plus drives_enabled and the run's\n"
      "references when present) with the run's rows the stage covers, the stage interpolated (cubic) at\n"
      "the aligned instants; compare, diagnose, train and table1 take it. MERGE.json: offset_s,\n"
      "rate_ppm, their standard uncertainties (offset_sd_s, rate_sd_ppm; residuals correlated over 2 s\n"
      "blocks), offset_signal_left and rate_signal_left (the fractions of their signal the robot's\n"
      "effects leave: about 0.1 and 0.5 on a 10 minute drag; below 0.01 the clocks are poorly fixed),\n"
      "the residual (residual_rms_m) and the overlap; clock_from (sync or data), sync_changes, the\n"
      "data's own alignment (data_offset_s, data_rate_ppm, their uncertainties, data_residual_rms_m)\n"
      "and the data's offset error the sync's phase showed (sync_shift_s; beyond a quarter of a level\n"
      "the data alone had lost the clocks and the phase corrected them: sync_corrected_lost_alignment).\n"
      "Refused (exit 2, one line, no output): a file that is not such a log, a plate at rest, logs\n"
      "that overlap by less than half the shorter one or 10 s, logs that do not belong together.\n"
      "Example: deltactl merge --run run.csv --stage stage.csv --out data.csv --report merge.json");
  sub->add_option("--run", options->run, "RUN.csv: the host's recording (board time)")->required();
  sub->add_option("--stage", options->stage, "STAGE.csv: the stage's own log (its clock)")->required();
  sub->add_option("--out", options->out, "DATA.csv: the merged recording")->required();
  sub->add_option("--report", options->report, "MERGE.json: the alignment found and its uncertainty");
  sub->callback([options] { run_merge(*options); });
});

}  // namespace
}  // namespace delta
