// The measuring stage's log and the plate it saw at a run's rows (see stage_log.hpp).
#include "delta/diagnosis/stage_log.hpp"

#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"
#include "delta/recording.hpp"
#include "delta/table.hpp"

namespace delta::diagnosis {

StageLog read_stage_log(const std::string& path) {
  const CsvTable table = read_csv(path, {"t_s", "x_m", "y_m", "z_m"}, {"sync"});
  StageLog log;
  log.path = path;
  const std::size_t n = table.rows.size();
  log.t_s.resize(n);
  log.position_m.resize(n);
  if (table.present[4]) log.sync.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& row = table.rows[i];
    // Strictly increasing: a stage log with a repeated time is not one.
    if (i > 0 && !(row[0] > table.rows[i - 1][0])) {
      throw InputError(path, table.line_numbers[i],
                       "time does not increase (" + format_number(row[0]) + " s after " +
                           format_number(table.rows[i - 1][0]) + " s)");
    }
    check_plausible_positions(table, i, 1, 3);  // the bounds diagnose and train apply to DATA.csv
    log.t_s[i] = row[0];
    log.position_m[i] = Vec3(row[1], row[2], row[3]);
    if (table.present[4]) {
      if (row[4] != 0.0 && row[4] != 1.0) {
        throw InputError(path, table.line_numbers[i],
                         "sync is " + format_number(row[4]) + ": the logged level of the board's sync output, 0 or 1");
      }
      log.sync[i] = row[4] != 0.0 ? 1 : 0;
    }
  }
  return log;
}

PlateTrack plate_from_stage(const RunColumns& run, const StageLog& stage, MergeResult* merge) {
  const MergeResult m =
      merge_logs(run.path, run.t_s, run.alpha_deg, stage.path, stage.t_s, stage.position_m, stage.sync);
  PlateTrack track;
  track.source = "the stage's log " + stage.path + ", its clock aligned to board time by the merge";
  track.measured.assign(run.t_s.size(), false);
  track.plate_m.assign(run.t_s.size(), Vec3::Zero());
  for (std::size_t r = 0; r < m.merged_rows; ++r) {
    track.measured[m.run_row[r]] = true;
    track.plate_m[m.run_row[r]] = m.position_m[r];
  }
  track.note = "t_stage = " + fixed(m.offset_s, 6) + " s + (1 + " + fixed(m.rate_ppm, 3) + " ppm) t_board, +-" +
               fixed(m.offset_sd_s * 1e6, 1) + " us, " + fixed(m.rate_sd_ppm, 3) + " ppm, from " +
               (m.from_sync ? std::to_string(m.sync_changes) + " changes of the board's sync output"
                            : std::string("the data alone (no sync column: milliseconds off on a closed-loop run, "
                                          "micrometres of plate)")) +
               "; residual " + fixed(m.residual_rms_m * 1e6, 2) + " um RMS";
  if (merge != nullptr) *merge = m;
  return track;
}

}  // namespace delta::diagnosis
