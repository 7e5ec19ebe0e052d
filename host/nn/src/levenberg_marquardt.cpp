// Levenberg-Marquardt iteration with adaptive damping (MATLAB trainlm's schedule).
#include "delta/nn/levenberg_marquardt.hpp"

#include <cmath>
#include <deque>

#include <Eigen/Cholesky>

namespace delta::nn {

LmResult levenberg_marquardt(LeastSquaresProblem& problem, const Eigen::VectorXd& x0, const LmOptions& options,
                             const LmCallback& after_epoch) {
  LmResult result;
  result.x = x0;
  double mu = options.mu_initial;
  std::deque<double> history;  // sse at the end of recent epochs, for the plateau test
  result.sse = problem.sum_squared_error(result.x);
  history.push_back(result.sse);
  while (true) {
    if (result.epochs >= options.max_epochs) {
      result.stop_reason = "max_epochs";
      break;
    }
    // Normal equations only at the start of an epoch: a stopped run never pays for unused ones.
    const LeastSquaresProblem::NormalEquations equations = problem.normal_equations(result.x);
    const double gradient_norm = equations.jte.norm();
    if (!(gradient_norm > options.min_gradient * (std::sqrt(result.sse) + 1e-300))) {
      result.stop_reason = "min_gradient";
      break;
    }
    bool accepted = false;
    Eigen::VectorXd trial;
    double trial_sse = 0.0;
    while (mu <= options.mu_max) {
      Eigen::MatrixXd damped = equations.jtj;
      damped.diagonal().array() += mu;
      const Eigen::LDLT<Eigen::MatrixXd> factor(damped);
      trial = result.x + factor.solve(equations.jte);
      trial_sse = problem.sum_squared_error(trial);
      if (std::isfinite(trial_sse) && trial_sse < result.sse) {
        accepted = true;
        break;
      }
      mu *= options.mu_increase;
    }
    if (!accepted) {
      result.stop_reason = "mu_max";
      break;
    }
    ++result.epochs;
    LmEpoch epoch{result.epochs, trial_sse, mu, gradient_norm};
    result.x = trial;
    mu = std::max(mu * options.mu_decrease, 1e-20);
    result.sse = trial_sse;
    if (after_epoch) {
      const std::string stop = after_epoch(epoch, result.x);
      if (!stop.empty()) {
        result.stop_reason = stop;
        break;
      }
    }
    history.push_back(result.sse);
    if (options.plateau_epochs > 0 && static_cast<int>(history.size()) > options.plateau_epochs) {
      const double earlier = history.front();
      history.pop_front();
      if (earlier - result.sse < options.plateau_fraction * earlier) {
        result.stop_reason = "plateau";
        break;
      }
    }
  }
  return result;
}

}  // namespace delta::nn
