// Merging a run with the measuring stage's log: clocks aligned from the data (see merge.hpp), its
// phases in merge_phases.hpp.
#include "delta/diagnosis/merge.hpp"

#include <cmath>
#include <string>

#include "delta/board_facts.hpp"

#include "merge_phases.hpp"
#include "sync_alignment.hpp"

namespace delta::diagnosis {
namespace {

using merging::fixed3;
using merging::refuse;

constexpr double kRestM = 5e-6;    // stage motion RMS below this: at rest
constexpr double kRestDeg = 0.05;  // every joint's span below this: at rest
// A sync whose clocks leave the positions' residual more than this much above the data's own (and
// by more than the slack) does not belong with them.
constexpr double kSyncResidualRatio = 4.0;
constexpr double kSyncResidualSlackM = 0.05e-6;

// Refuses logs too short to merge, or in which the robot or the plate is at rest.
void refuse_without_motion(const std::string& run_path, const std::vector<double>& run_t,
                           const std::vector<Vec3>& run_alpha_deg, const std::string& stage_path,
                           const std::vector<double>& stage_t, const std::vector<Vec3>& stage_m) {
  if (run_t.size() < 100) refuse(run_path, "has " + std::to_string(run_t.size()) + " rows; a merge needs at least 100");
  if (stage_t.size() < 100) {
    refuse(stage_path, "has " + std::to_string(stage_t.size()) + " rows; a merge needs at least 100");
  }
  {
    Vec3 lo = run_alpha_deg.front(), hi = lo;
    for (const Vec3& a : run_alpha_deg) {
      lo = lo.cwiseMin(a);
      hi = hi.cwiseMax(a);
    }
    if ((hi - lo).maxCoeff() < kRestDeg) {
      refuse(run_path, "the robot is at rest (every joint within " + fixed3(kRestDeg) +
                           " deg): a merge needs motion to align the clocks");
    }
    Vec3 mean = Vec3::Zero();
    for (const Vec3& p : stage_m) mean += p;
    mean /= static_cast<double>(stage_m.size());
    double ss = 0;
    for (const Vec3& p : stage_m) ss += (p - mean).squaredNorm();
    if (std::sqrt(ss / (3.0 * stage_m.size())) < kRestM) {
      refuse(stage_path, "the plate is at rest (motion below 5 um RMS): a merge needs motion to align the clocks");
    }
  }
}

}  // namespace

MergeResult merge_logs(const std::string& run_path, const std::vector<double>& run_t,
                       const std::vector<Vec3>& run_alpha_deg, const std::string& stage_path,
                       const std::vector<double>& stage_t, const std::vector<Vec3>& stage_m,
                       const std::vector<int>& stage_sync) {
  MergeResult out;
  out.run_rows = run_t.size();
  out.stage_rows = stage_t.size();
  refuse_without_motion(run_path, run_t, run_alpha_deg, stage_path, stage_t, stage_m);
  const merging::Logs logs{run_path, run_t, run_alpha_deg, stage_path, stage_t, stage_m};
  const Geometry nominal = Geometry::nominal();
  const merging::EncoderPlate plate = merging::encoder_plate(run_t, run_alpha_deg, nominal);
  const merging::CoarseAlignment coarse = merging::align_coarsely(logs, plate, nominal);
  out.correlation = coarse.correlation;
  const merging::StageCurve curve(stage_t, stage_m);
  merging::FineFit fit(logs, plate, curve, nominal, coarse);
  fit.run();
  fit.finish(&out);
  double rate = fit.rate();
  out.data_residual_rms_m = out.residual_rms_m;
  out.data_offset_s = out.offset_s;
  out.data_offset_sd_s = out.offset_sd_s;
  out.data_rate_ppm = out.rate_ppm;
  out.data_rate_sd_ppm = out.rate_sd_ppm;
  // ---- the board's sync output, when the stage logged it ----
  if (!stage_sync.empty()) {
    const SyncAlignment sync =
        align_on_sync(stage_path, stage_t, stage_sync, out.offset_s, rate, board::kStageSyncLevelSeconds);
    if (sync.changes > 0) {
      // The positions must fit at the sync's clocks about as well as at their own (1.00-1.04 x on
      // drags, up to 1.3 x in closed loop): a correction of a lost alignment that they do not bear
      // out is refused. Drags whose positions cannot fix the clocks to 0.1 s fit as well at both.
      const double at_sync = fit.residual_rms_at(sync.offset_s + (1 + sync.rate) * fit.t_mean(), sync.rate);
      if (!(at_sync <= kSyncResidualRatio * out.residual_rms_m + kSyncResidualSlackM)) {
        refuse(stage_path, "its sync column does not fit the positions: at the clocks its changes give (" +
                               fixed3(sync.shift_s) + " s from the positions' own) the stage and the encoders' plate " +
                               "differ by " + fixed3(at_sync * 1e6) + " um RMS, against " +
                               fixed3(out.residual_rms_m * 1e6) +
                               " um at the positions' clocks (is it the sync of this run?)");
      }
      out.residual_rms_m = at_sync;
      out.sync_shift_s = sync.shift_s;
      out.sync_corrected_lost_alignment = sync.corrected_lost_alignment;
      out.from_sync = true;
      out.sync_changes = sync.changes;
      out.sync_consistent = sync.consistent;
      out.offset_s = sync.offset_s;
      out.offset_sd_s = sync.offset_sd_s;
      rate = sync.rate;
      out.rate_ppm = sync.rate * 1e6;
      out.rate_sd_ppm = sync.rate_sd * 1e6;
    }
  }
  // ---- the stage at every run row it covers ----
  for (std::size_t i = 0; i < run_t.size(); ++i) {
    const double tau = out.offset_s + (1 + rate) * run_t[i];
    Vec3 s;
    if (!curve.at(tau, &s, nullptr)) continue;
    out.t_s.push_back(run_t[i]);
    out.run_row.push_back(i);
    out.position_m.push_back(s);
  }
  out.merged_rows = out.t_s.size();
  out.overlap_s = out.t_s.empty() ? 0.0 : out.t_s.back() - out.t_s.front();
  return out;
}

}  // namespace delta::diagnosis
