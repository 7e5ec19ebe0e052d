// The measuring stage's own log (SPEC.md, "The lab's measurements": t_s on the stage's clock,
// x_m,y_m,z_m, optionally the board's sync output as the stage sampled it), and the plate it saw
// at each of a run's rows: the two clocks aligned by the merge (merge.hpp), for `deltactl merge` and
// `deltactl run-report --stage`.
#pragma once

#include <string>
#include <vector>

#include "delta/diagnosis/merge.hpp"
#include "delta/geometry.hpp"
#include "delta/run_report.hpp"

namespace delta::diagnosis {

struct StageLog {
  std::string path;
  std::vector<double> t_s;  // the stage's clock
  std::vector<Vec3> position_m;
  std::vector<int> sync;  // 0 or 1 per row; empty: no column sync
};

// InputError (file, line, reason): csv.hpp's reasons, times not strictly increasing, a sync level
// other than 0 or 1.
StageLog read_stage_log(const std::string& path);

// The stage at each of the run's rows the merge covers, its clock aligned to the run's board time
// by merge_logs (the run's t_s and encoders); the alignment in *merge when given. merge_logs'
// refusals are InputError.
PlateTrack plate_from_stage(const RunColumns& run, const StageLog& stage, MergeResult* merge = nullptr);

}  // namespace delta::diagnosis
