// Levenberg-Marquardt fit of the diagnosis model: autodiff through the sim's inverse kinematics.
#include "delta/diagnosis/fit.hpp"

#include <Eigen/Cholesky>
#include <unsupported/Eigen/AutoDiff>

namespace delta::diagnosis {
namespace {

using Derivatives = Eigen::Matrix<double, kLocalCount, 1>;
using Dual = Eigen::AutoDiffScalar<Derivatives>;

// Penalty weight of the gauge constraint sum(dphi_j) = 0, relative to one observation.
constexpr double kGaugeWeight = 1e8;

// Adds the prior and the gauge constraint to the cost and the normal equations.
void add_regularisation(const Parameters& theta, FamilySet families, const Parameters& prior, const FitOptions& options,
                        NormalEquations& equations) {
  const auto& table = parameter_table();
  const double floor_deg = options.noise_floor_deg;
  const double realistic = options.realistic_prior_observations;
  const Parameters nominal = neutral_parameters();
  for (int k : parameter_indices(families)) {
    // The ripple's period and phase have no nominal value: their prior stays the weak one.
    const bool shape = table[k].family == Family::transmission_error && k >= slot::period;
    const bool towards_nominal = realistic > 0.0 && !shape;
    const double weight =
        (towards_nominal ? realistic : 1.0) * floor_deg * floor_deg / (table[k].typical * table[k].typical);
    const double deviation = theta[k] - (towards_nominal ? nominal[k] : prior[k]);
    equations.sum_squares += weight * deviation * deviation;
    equations.jtj(k, k) += weight;
    equations.jtr[k] -= weight * deviation;  // residual of the prior row is -(theta - prior)
  }
  if (families[index_of(Family::chain_angle)] && families[index_of(Family::frame_misalignment)]) {
    const double weight = kGaugeWeight * floor_deg * floor_deg;
    const double sum = theta.segment<3>(slot::chain_angle).sum();
    equations.sum_squares += weight * sum * sum;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) equations.jtj(slot::chain_angle + a, slot::chain_angle + b) += weight;
      equations.jtr[slot::chain_angle + a] -= weight * sum;
    }
  }
}

}  // namespace

NormalEquations evaluate(const Parameters& theta, FamilySet families, const std::vector<Sample>& rows,
                         bool with_jacobian) {
  NormalEquations equations;
  for (int joint = 0; joint < 3; ++joint) {
    const std::array<int, kLocalCount> map = local_parameters(joint);
    std::size_t failed = 0;
    double sum = 0.0;
    bool ok;
    if (with_jacobian) {
      std::array<Dual, kLocalCount> local;
      for (int k = 0; k < kLocalCount; ++k) local[k] = Dual(theta[map[k]], kLocalCount, k);
      Eigen::Matrix<double, kLocalCount, kLocalCount> jtj = Eigen::Matrix<double, kLocalCount, kLocalCount>::Zero();
      Derivatives jtr = Derivatives::Zero();
      ok = predict_joint<Dual>(
          local, families, joint, rows,
          [&](std::size_t i, const Dual& predicted) {
            const double weight = rows[i].fit_weight[joint];
            if (weight == 0.0) return;
            const double residual = rows[i].alpha_deg[joint] - predicted.value();
            sum += weight * residual * residual;
            jtj.selfadjointView<Eigen::Lower>().rankUpdate(predicted.derivatives(), weight);
            jtr += weight * residual * predicted.derivatives();
          },
          &failed);
      jtj = jtj.selfadjointView<Eigen::Lower>();
      for (int a = 0; a < kLocalCount; ++a) {
        equations.jtr[map[a]] += jtr[a];
        for (int b = 0; b < kLocalCount; ++b) equations.jtj(map[a], map[b]) += jtj(a, b);
      }
    } else {
      std::array<double, kLocalCount> local;
      for (int k = 0; k < kLocalCount; ++k) local[k] = theta[map[k]];
      ok = predict_joint<double>(
          local, families, joint, rows,
          [&](std::size_t i, double predicted) {
            const double residual = rows[i].alpha_deg[joint] - predicted;
            sum += rows[i].fit_weight[joint] * residual * residual;
          },
          &failed);
    }
    if (!ok) {
      equations.failed_row = failed;
      return equations;
    }
    equations.joint_sum_squares[joint] = sum;
    equations.sum_squares += sum;
  }
  // Columns of absent families are zero; keep the matrix regular for the solver.
  const std::vector<int> active = parameter_indices(families);
  for (int k = 0; k < kParameterCount; ++k) {
    if (std::find(active.begin(), active.end(), k) == active.end()) {
      equations.jtj.row(k).setZero();
      equations.jtj.col(k).setZero();
      equations.jtr[k] = 0.0;
    }
  }
  equations.ok = true;
  return equations;
}

namespace {

void project(Parameters& theta) {
  for (int j = 0; j < 3; ++j) {
    theta[slot::backlash + j] = std::max(theta[slot::backlash + j], 0.0);
    theta[slot::period + j] = std::max(theta[slot::period + j], 0.05);
  }
}

}  // namespace

FitResult fit_model(const std::vector<Sample>& rows, FamilySet families, const Parameters& start,
                    const Parameters& prior, const FitOptions& options) {
  FitResult result;
  result.families = families;
  result.theta = start;
  project(result.theta);
  std::vector<int> active = parameter_indices(families);
  if (options.hold_periods) {
    active.erase(
        std::remove_if(active.begin(), active.end(), [](int k) { return k >= slot::period && k < slot::period + 3; }),
        active.end());
  }
  const int n = static_cast<int>(active.size());
  NormalEquations current = evaluate(result.theta, families, rows, true);
  if (!current.ok) return result;
  add_regularisation(result.theta, families, prior, options, current);
  double damping = 1e-3;
  for (int iteration = 0; iteration < options.max_iterations && n > 0; ++iteration) {
    result.iterations = iteration + 1;
    Eigen::MatrixXd h(n, n);
    Eigen::VectorXd g(n);
    for (int a = 0; a < n; ++a) {
      g[a] = current.jtr[active[a]];
      for (int b = 0; b < n; ++b) h(a, b) = current.jtj(active[a], active[b]);
    }
    bool improved = false;
    double relative_decrease = 0.0;
    for (int attempt = 0; attempt < 12 && !improved; ++attempt) {
      Eigen::MatrixXd damped = h;
      for (int a = 0; a < n; ++a) damped(a, a) += damping * std::max(h(a, a), 1e-12);
      const Eigen::VectorXd step = damped.ldlt().solve(g);
      Parameters trial = result.theta;
      for (int a = 0; a < n; ++a) trial[active[a]] += step[a];
      project(trial);
      NormalEquations next = evaluate(trial, families, rows, false);
      if (next.ok) add_regularisation(trial, families, prior, options, next);
      if (next.ok && next.sum_squares < current.sum_squares) {
        relative_decrease = (current.sum_squares - next.sum_squares) / current.sum_squares;
        result.theta = trial;
        current = evaluate(result.theta, families, rows, true);
        add_regularisation(result.theta, families, prior, options, current);
        damping = std::max(damping / 5.0, 1e-9);
        improved = true;
      } else {
        damping *= 8.0;
      }
    }
    if (!improved || relative_decrease < options.tolerance) break;
  }
  result.ok = current.ok;
  result.jtj = current.jtj;
  for (int j = 0; j < 3; ++j) {
    double counted = 0.0;
    for (const Sample& row : rows) counted += row.fit_weight[j];
    result.fit_rmse_deg[j] = counted > 0.0 ? std::sqrt(current.joint_sum_squares[j] / counted) : 0.0;
  }
  return result;
}

}  // namespace delta::diagnosis
