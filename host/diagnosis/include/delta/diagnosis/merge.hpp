// Merging the host's recording of a run with the measuring stage's own log (docs/contracts.md, "The lab's
// measurements"): the two clocks are aligned from the data alone, then the stage is resampled at
// the run's board times.
//
// The stage logs the plate on its own clock, t_stage = offset + (1 + rate_ppm 1e-6) t_board.
// The run's encoders imply the plate too, through the nominal forward kinematics; the robot's
// unknown effects bend that image, but smoothly with position and joint angle and with the
// direction of each joint's last move (its play), never with time: what the two plates cannot
// agree on through such a map is the clocks'.
//   0. the readings between their counts: a reading changes when the angle crosses the boundary
//      between two counts, so between two crossings the angle is interpolated in time (the
//      encoders' quantisation, 2.5 um RMS of plate, falls to about 0.1 um); rows where a joint may
//      sit inside its play (a hold that ends in a reversal) are left out; so are, once the clocks
//      are roughly aligned (step 1), a drag's holds in which the stage says an arm fell back from
//      the edge of its play by more than 0.1 count and came out the same way (the reading held: a
//      joint barely moving turns inside its play, on a sweep for much of the drag; left in, such
//      rows put the clock offset 3 ms and the plate 3 um off). Closed-loop telemetry
//      (rows at most 5 ms apart, a joint whose reading turns back at more than 0.5 % of its
//      steps) instead takes each reading less the lead the controller holds it at (the angle
//      behind it stops just past the boundary it crossed last: 0.0043 deg when slow, none above
//      7 deg/s; host/diagnosis/src/closed_loop.hpp); what is left there is the arm falling back
//      inside its play by an amount that changes with the speed, 0.4-3.6 ms of clock offset on
//      the model board's runs (docs/lab_loop.md);
//   1. coarse: the normalised cross-correlation of the two plate paths on 0.5 s bins over every lag
//      (of peaks within 0.01 of the best, the one that overlaps most: a repeating path correlates
//      almost as well one period off); then, on 50 ms bins within 1 s of it, the lag that leaves the
//      least of an affine map with each joint's play (the play alone reads as a lag of half of it
//      over the joint's speed, 0.1 s and more; a turned frame moves a correlation's peak); then
//      the same on 2 to 8 windows of the run with that map held, a straight line through their
//      lags: a first rate;
//   2. fine: Gauss-Newton on the run's rows (at most 20000, evenly thinned) of
//        stage(offset + (1 + rate) t) = A p + P(p) + sum_j A J_j (c_j d_j + S_j(alpha_j + c_j d_j)) + e
//      with the stage interpolated (cubic Hermite), p the encoders' plate (nominal FK of the
//      readings with the play found so far taken out), A the affine map from it to the stage's
//      plate at the current alignment (taken out of the stage, so that the rest keeps its
//      precision, and turning the joints' columns into the stage's frame), P a cubic polynomial
//      per axis (lengths, radii, chain angles, the frame), c_j the play of joint j along its column
//      J_j of the Jacobian, d_j the direction of its last move, S_j a cubic spline of its reading
//      (knots every 0.5 deg: offset, scale, transmission error down to a 3 deg period). The
//      nuisance (P, c, S) is solved exactly at each alignment; a step that lowers the residual is
//      doubled while it lowers it further (along a valley Gauss-Newton falls short), one that does
//      not is halved. Each pass ends by dropping outliers, the encoder holds of a row off by more
//      than 5 robust deviations, and the hold of a joint behind its reading against its
//      direction of motion (in joint space, by 3 robust deviations or 0.75 of a count: it turned
//      back inside its play and came out the same way, its reading held while the plate moved);
//      a row dropped on a rougher fit comes back once it fits. The first pass only drops, at the
//      coarse alignment; at most 6 passes, until fewer than 0.5 % of the rows change;
//   3. uncertainty: the sandwich covariance with the residuals' gradients summed over 2 s blocks
//      (the residuals of a slow motion are correlated; rows are not independent).
// The clocks are fixed by the path coming back to the same joint angles at other times and
// speeds: on 5 to 20 minute drags of the validation trajectory or a sweep the merged plate is
// within 0.1 um RMS of the truth on every axis (docs/lab_loop.md); on a 1-2 minute drag the
// nuisance absorbs most of a clock error (the merged plate off by a micrometre to tens of them,
// the stated uncertainties too small: offset_signal_left and rate_signal_left say so).
// A stage that logs the board's stage sync output beside its positions (a column `sync`) gives the
// clocks from it instead (src/sync_alignment.hpp): each change of the level, between two of the
// stage's samples, bounds offset and rate; their centre is within microseconds, closed loop or
// not. The data's alignment above is still made (it tells which change is which, and refuses
// logs that do not belong together) and reported beside it.
// Refused (InputError, exit 2): a log that is not one (read_csv's reasons, times not increasing), a
// plate at rest in either, logs that do not overlap enough, or do not belong together (a coarse
// correlation below 0.9, or a residual above 0.2 mm or a fifth of the motion).
#pragma once

#include <string>
#include <vector>

#include "delta/geometry.hpp"

namespace delta::diagnosis {

struct MergeResult {
  double offset_s = 0.0, offset_sd_s = 0.0;  // t_stage at board time 0 and its standard uncertainty
  double rate_ppm = 0.0, rate_sd_ppm = 0.0;  // the stage clock's rate error
  // Where the clocks came from: the sync output's changes (sync_changes of them) or the data alone;
  // the data's alignment either way.
  bool from_sync = false;
  std::size_t sync_changes = 0;
  bool sync_consistent = false;  // every change between its two samples at the alignment found
  double data_offset_s = 0.0, data_offset_sd_s = 0.0, data_rate_ppm = 0.0, data_rate_sd_ppm = 0.0;
  // The data's offset error the sync's changes showed (their phase, in board time); beyond a
  // quarter of the level (0.1 s) the data alone had lost the clocks and the sync corrected them
  // (sync_corrected_lost_alignment).
  double sync_shift_s = 0.0;
  bool sync_corrected_lost_alignment = false;
  double residual_rms_m = 0.0;       // of the fine fit's rows at the alignment found
  double data_residual_rms_m = 0.0;  // ... at the data's alignment
  // The fractions of the offset's signal (the plate's speed) and of the rate's (speed times time)
  // that the robot's unknown effects do not absorb. On 10 minute drags of the validation run or a
  // sweep about 0.1 and 0.5; on a 1-2 minute drag below 0.01, where the clocks are poorly fixed
  // and the stated uncertainties too small; on a single ellipse (experiment 1) the offset's is
  // below 1e-4: a time shift of a sinusoid is an affine map of it.
  double offset_signal_left = 0.0, rate_signal_left = 0.0;
  double motion_rms_m = 0.0;  // the plate's motion about its mean in the overlap
  double correlation = 0.0;   // of the coarse alignment
  double overlap_s = 0.0;     // board time the stage covers
  std::size_t run_rows = 0, stage_rows = 0, merged_rows = 0, fit_rows = 0;
  std::vector<double> t_s;           // merged rows: board time
  std::vector<std::size_t> run_row;  // index into the run's rows
  std::vector<Vec3> position_m;      // the stage at t_stage(t_s)
};

// run: board times and encoder angles (deg); stage: stage times and positions (m), and the logged
// sync levels (0 or 1; empty: not logged). The paths name the files in errors.
MergeResult merge_logs(const std::string& run_path, const std::vector<double>& run_t,
                       const std::vector<Vec3>& run_alpha_deg, const std::string& stage_path,
                       const std::vector<double>& stage_t, const std::vector<Vec3>& stage_m,
                       const std::vector<int>& stage_sync = {});

}  // namespace delta::diagnosis
