// Identifiability: singular values and correlations of the normalised Jacobian, weak directions
// with the measurement that separates them, and confidence intervals from the covariance.
#include "identifiability.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Eigenvalues>

namespace delta::diagnosis {

std::string advice_for(const std::vector<std::pair<int, double>>& components) {
  std::map<Family, double> weight;
  bool yaw = false, common_chain = false;
  for (const auto& [k, w] : components) {
    weight[parameter_table()[k].family] += w * w;
    if (k == slot::frame_rotation + 2) yaw = true;
    if (k >= slot::chain_angle && k < slot::chain_angle + 3) common_chain = true;
  }
  auto has = [&weight](Family f) { return weight.count(f) && weight[f] > 0.05; };
  if (yaw && common_chain) {
    return "frame yaw rz and a common chain rotation are the same motion: measure the stage's yaw against "
           "the base (align the stage axes to a base edge or fiducial) to tell them apart";
  }
  if (has(Family::joint_offset) && has(Family::encoder_scale)) {
    return "encoder zero and scale trade off over this small angle range: record a wider range of joint "
           "angles, or reference the encoders at a known angle (index pulse, gauge block under the arm)";
  }
  if (has(Family::frame_misalignment) && (has(Family::joint_offset) || has(Family::radius_offset))) {
    return "measuring-frame translation trades with joint zeros and radii: touch the plate off on a fixture "
           "whose position in the base frame is known";
  }
  if (has(Family::upper_arm_length) || has(Family::lower_arm_length) || has(Family::radius_offset)) {
    return "link lengths trade off inside a 10 mm cube: measure the arms (calipers, CMM) or record poses far "
           "apart in the 40 mm design workspace";
  }
  if (has(Family::transmission_error)) {
    return "the ripple period spans more than the recorded angle range: record a longer angle travel";
  }
  return "record a trajectory spanning a larger part of the workspace";
}

Parameters confidence_half_widths(const FitResult& fit, std::size_t rows) {
  Parameters half_width = Parameters::Zero();
  const std::vector<int> active = parameter_indices(fit.families);
  const int n = static_cast<int>(active.size());
  if (n == 0 || rows == 0) return half_width;
  Eigen::MatrixXd information(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) information(a, b) = fit.jtj(active[a], active[b]);
  }
  const double residuals = 3.0 * static_cast<double>(rows);
  const double variance = fit.fit_rmse_deg.squaredNorm() * static_cast<double>(rows) / std::max(residuals - n, 1.0);
  const Eigen::MatrixXd covariance = variance * information.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  for (int a = 0; a < n; ++a) half_width[active[a]] = 1.96 * std::sqrt(std::max(covariance(a, a), 0.0));
  return half_width;
}

Identifiability analyse_identifiability(const std::vector<Sample>& rows, FamilySet families, const Parameters& theta) {
  Identifiability result;
  result.model = describe(families);
  const NormalEquations equations = evaluate(theta, families, rows, true);
  if (!equations.ok) return result;
  // Keep only the columns the data touch at all (an absent transmission amplitude leaves its
  // period and phase without any effect).
  for (int k : parameter_indices(families)) {
    if (equations.jtj(k, k) > 1e-300) result.parameters.push_back(k);
  }
  const int n = static_cast<int>(result.parameters.size());
  if (n == 0) return result;
  Eigen::MatrixXd normalised(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      const int ka = result.parameters[a], kb = result.parameters[b];
      normalised(a, b) = equations.jtj(ka, kb) / std::sqrt(equations.jtj(ka, ka) * equations.jtj(kb, kb));
    }
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(normalised);
  for (int a = n - 1; a >= 0; --a) result.singular_values.push_back(std::sqrt(std::max(eigen.eigenvalues()[a], 0.0)));
  for (int a = 0; a < n; ++a) {
    const double singular = std::sqrt(std::max(eigen.eigenvalues()[a], 0.0));
    if (singular >= 1e-2) break;
    WeakDirection weak;
    weak.singular_value = singular;
    const Eigen::VectorXd vector = eigen.eigenvectors().col(a);
    for (int b = 0; b < n; ++b) {
      if (std::abs(vector[b]) > 0.2) weak.components.push_back({result.parameters[b], vector[b]});
    }
    std::sort(weak.components.begin(), weak.components.end(),
              [](const auto& x, const auto& y) { return std::abs(x.second) > std::abs(y.second); });
    weak.advice = advice_for(weak.components);
    result.weak.push_back(weak);
  }
  // Correlations from the pseudo-inverse; exact gauges (normalised singular value below 1e-6,
  // such as frame yaw against a common chain rotation) are left out, they are reported above.
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(n, n);
  for (int a = 0; a < n; ++a) {
    if (eigen.eigenvalues()[a] > 1e-12) {
      covariance += eigen.eigenvectors().col(a) * eigen.eigenvectors().col(a).transpose() / eigen.eigenvalues()[a];
    }
  }
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const double denominator = std::sqrt(covariance(a, a) * covariance(b, b));
      if (denominator <= 0.0) continue;
      const double value = covariance(a, b) / denominator;
      if (std::abs(value) > 0.95) result.correlations.push_back({result.parameters[a], result.parameters[b], value});
    }
  }
  std::sort(result.correlations.begin(), result.correlations.end(),
            [](const Correlation& x, const Correlation& y) { return std::abs(x.value) > std::abs(y.value); });
  if (result.correlations.size() > 12) result.correlations.resize(12);
  return result;
}

}  // namespace delta::diagnosis
