// Merging the host's recording of a run with the measuring stage's own log (SPEC.md, "The lab's
// measurements"): the two clocks are aligned from the data alone, then the stage is resampled at
// the run's board times.
//
// The stage logs the plate on its own clock, t_stage = offset + (1 + rate_ppm 1e-6) t_board.
// The run's encoders imply the plate too, through the nominal forward kinematics; the robot's
// unknown effects bend that image, but smoothly with position and direction, not with time.
//   1. coarse: the normalised cross-correlation of the two plate paths on 0.5 s bins over every lag
//      that overlaps at least half the shorter log (of peaks within 0.01 of the best, the one that
//      overlaps most: a repeating path correlates almost as well one period off), then on 50 ms bins
//      near the best lag, and on the first and last thirds of the run for a first rate;
//   2. fine: Gauss-Newton on the run's rows (at most 40000, evenly thinned), leaving out the rows
//      where a joint may sit inside its play (an encoder hold that ends in a reversal), of
//        stage(offset + (1 + rate) t) = P(p) + sum_j J_j(t) (c_j d_j(t) + S_j(alpha_j + c_j d_j)) + e
//      with the stage interpolated (cubic Hermite), p the encoders' plate (nominal FK of the
//      readings with the play found so far taken out), P a cubic polynomial per axis (frame,
//      lengths, radii, chain angles), c_j the play of joint j along its column J_j of the Jacobian,
//      d_j the direction of its last move, S_j a cubic spline of its reading (knots every 1.25 deg:
//      offset, scale, transmission error). Everything the robot gets wrong must be smooth in
//      position and angle, or it reads as a lag: the play's dead band and its direction-dependent
//      shift of every other effect biased the offset by 9-35 ms with an affine map alone;
//   3. uncertainty: the sandwich covariance with the residuals' gradients summed over 2 s blocks
//      (the residuals of a slow, quantised motion are correlated; rows are not independent).
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
  double residual_rms_m = 0.0;               // of the fine fit
  double motion_rms_m = 0.0;                 // the plate's motion about its mean in the overlap
  double correlation = 0.0;                  // of the coarse alignment
  double overlap_s = 0.0;                    // board time the stage covers
  std::size_t run_rows = 0, stage_rows = 0, merged_rows = 0, fit_rows = 0;
  std::vector<double> t_s;           // merged rows: board time
  std::vector<std::size_t> run_row;  // index into the run's rows
  std::vector<Vec3> position_m;      // the stage at t_stage(t_s)
};

// run: board times and encoder angles (deg); stage: stage times and positions (m). The paths name
// the files in errors.
MergeResult merge_logs(const std::string& run_path, const std::vector<double>& run_t,
                       const std::vector<Vec3>& run_alpha_deg, const std::string& stage_path,
                       const std::vector<double>& stage_t, const std::vector<Vec3>& stage_m);

}  // namespace delta::diagnosis
