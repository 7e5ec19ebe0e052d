// Levenberg-Marquardt on a sum of squared errors, as MATLAB's trainlm runs it: solve
// (J^T J + mu I) dx = J^T e, accept the step and divide mu by 10 when the error falls, otherwise
// multiply mu by 10 and retry, until mu exceeds its maximum.
#pragma once

#include <functional>
#include <string>

#include <Eigen/Core>

namespace delta::nn {

// A least-squares problem: residuals e(x) = target - model(x), Jacobian J = d model / d x.
class LeastSquaresProblem {
 public:
  virtual ~LeastSquaresProblem() = default;
  struct NormalEquations {
    Eigen::MatrixXd jtj;  // J^T J (both triangles filled)
    Eigen::VectorXd jte;  // J^T e
  };
  virtual NormalEquations normal_equations(const Eigen::VectorXd& x) = 0;
  virtual double sum_squared_error(const Eigen::VectorXd& x) = 0;
};

struct LmOptions {
  int max_epochs = 1000;
  double mu_initial = 1e-3;  // MATLAB trainlm defaults
  double mu_decrease = 0.1;
  double mu_increase = 10.0;
  double mu_max = 1e10;
  double min_gradient = 1e-12;  // stop when |J^T e| falls below (relative to sqrt(sse) + 1e-300)
  // Converged when the sum of squared errors fell by less than this fraction over the last
  // plateau_epochs epochs (0 disables).
  int plateau_epochs = 0;
  double plateau_fraction = 1e-3;
};

struct LmEpoch {
  int epoch = 0;               // 1-based
  double sse = 0.0;            // after the epoch's step
  double mu = 0.0;             // damping used by the accepted step
  double gradient_norm = 0.0;  // |J^T e| before the step
};

struct LmResult {
  Eigen::VectorXd x;
  int epochs = 0;
  double sse = 0.0;
  std::string stop_reason;  // "max_epochs", "mu_max", "min_gradient", "plateau", or the callback's reason
};

// after_epoch sees each accepted step; returning a non-empty string stops with that reason.
using LmCallback = std::function<std::string(const LmEpoch& epoch, const Eigen::VectorXd& x)>;

LmResult levenberg_marquardt(LeastSquaresProblem& problem, const Eigen::VectorXd& x0, const LmOptions& options,
                             const LmCallback& after_epoch = {});

}  // namespace delta::nn
