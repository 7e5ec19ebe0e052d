// Nonlinear least squares (Levenberg-Marquardt on the normal equations, autodiff Jacobian) of the
// diagnosis model to the FIT rows of a recording, with gauge fixing.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "delta/diagnosis/effect_model.hpp"

namespace delta::diagnosis {

using NormalMatrix = Eigen::Matrix<double, kParameterCount, kParameterCount>;

// Sum of squared residuals (measured - predicted, deg^2), each weighted by its row's fit_weight of
// the joint, and, when asked, J^T W J and J^T W r where J = d predicted / d theta (all 36 columns;
// those of absent families are zero). A row of weight 0 still moves the play's state.
struct NormalEquations {
  bool ok = false;  // false: some row is unreachable for this theta
  std::size_t failed_row = 0;
  double sum_squares = 0.0;
  Eigen::Vector3d joint_sum_squares = Eigen::Vector3d::Zero();
  NormalMatrix jtj = NormalMatrix::Zero();
  Parameters jtr = Parameters::Zero();
};
NormalEquations evaluate(const Parameters& theta, FamilySet families, const std::vector<Sample>& rows,
                         bool with_jacobian);

struct FitResult {
  Parameters theta;
  FamilySet families;
  bool ok = false;  // every FIT row reachable at the solution
  int iterations = 0;
  Eigen::Vector3d fit_rmse_deg = Eigen::Vector3d::Zero();
  NormalMatrix jtj = NormalMatrix::Zero();  // at the solution, for identifiability
};

struct FitOptions {
  int max_iterations = 40;
  bool hold_periods = false;                           // the ripple's periods stay at their start values
  double tolerance = 1e-7;                             // stop when one step lowers the cost by less than this fraction
  double noise_floor_deg = 0.01 / 3.4641016151377544;  // sets the weight of the weak prior
  // Above 0: the prior pulls each parameter towards the nominal robot instead (neutral_parameters,
  // the ripple's period and phase still towards `prior`), with this many observations' weight.
  double realistic_prior_observations = 0.0;
};

// Levenberg-Marquardt from `start` over the parameters of `families`. Gauge fixing, so that
// directions the data cannot see never drift:
// - a weak prior pulls each parameter towards `prior` with the weight of one observation at the
//   noise floor per parameter and `typical` magnitude (negligible where the data are informative);
//   with options.realistic_prior_observations, towards the nominal robot with that weight;
// - with both chain_angle and frame_misalignment, a common rotation of the three chains is the
//   same as a yaw rz of the measuring frame: the sum of dphi_j is pinned to zero, the yaw goes to rz.
// Backlash widths are kept >= 0 and periods >= 0.05 deg.
FitResult fit_model(const std::vector<Sample>& rows, FamilySet families, const Parameters& start,
                    const Parameters& prior, const FitOptions& options = {});

}  // namespace delta::diagnosis
