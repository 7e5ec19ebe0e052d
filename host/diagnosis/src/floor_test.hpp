// The noise model of a recording and the statistical tests against it: is a held-out residual at
// the floor, does one model predict CHECK better than another, where does an excess live
// (internal to the diagnosis library).
#pragma once

#include <vector>

#include "delta/diagnosis/diagnose.hpp"

namespace delta::diagnosis {

// Variance (deg^2) of the measurement noise per CHECK row and joint: encoder quantisation q^2/12,
// stage quantisation (6.87 nm / sqrt(12) per axis) through the kinematics, and an extra white
// noise estimated from FIT when it is significant.
struct NoiseModel {
  std::vector<Vec3> variance_deg2;
  double encoder_variance_deg2 = 0.0;
  double stage_sigma_deg = 0.0;
  double extra_noise_deg = 0.0;
  double extra_noise_z = 0.0;
};

// `fit_prediction` is the final model on the FIT rows: the extra noise is what the differences of
// neighbouring FIT residuals carry beyond what quantisation of the predicted motion explains
// (a quantised angle moving by d between rows differs by f (q - f) in mean square, f = d mod q).
// fit_quantised false (closed-loop telemetry, its readings less their lead: not quantised, and
// their errors the controller's, not the measurement's): no extra noise is taken from FIT.
NoiseModel noise_model(const std::vector<Sample>& fit, const std::vector<Vec3>& fit_prediction,
                       const std::vector<Sample>& check, double noise_floor_deg, bool fit_quantised = true);

// Mean of r^2 / sigma^2 over the held-out rows against 1, standard error by batch means.
FloorTest floor_test(const std::vector<Sample>& check, const std::vector<Vec3>& prediction, const NoiseModel& noise,
                     const DiagnosisOptions& options);

// Held-out MSE of model a minus that of model b (mean over joints, deg^2), paired row by row,
// with its z (batch means): the squared noise cancels, so small systematic differences show.
struct PairedDifference {
  double mean_deg2 = 0.0;
  double z = 0.0;
};
PairedDifference paired_difference(const std::vector<Sample>& check, const std::vector<Vec3>& prediction_a,
                                   const std::vector<Vec3>& prediction_b, std::size_t batch_rows);

// Joint, octant and tenth of the CHECK time where the residual exceeds the noise model most.
UnexplainedResidual locate_unexplained(const std::vector<Sample>& check, const std::vector<Vec3>& prediction,
                                       const NoiseModel& noise);

}  // namespace delta::diagnosis
