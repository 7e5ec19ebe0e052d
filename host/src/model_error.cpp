// Table 1 statistics (RMSE, MAE per joint) and forward-kinematics error ranges.
#include "delta/model_error.hpp"

#include <cmath>

#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"

namespace delta {

JointErrorStats joint_error_stats(const std::vector<Vec3>& measured_deg, const std::vector<Vec3>& predicted_deg) {
  JointErrorStats stats;
  const std::size_t count = std::min(measured_deg.size(), predicted_deg.size());
  if (count == 0) return stats;
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3 error = measured_deg[i] - predicted_deg[i];
    stats.rmse_deg += error.cwiseAbs2();
    stats.mae_deg += error.cwiseAbs();
    stats.max_abs_deg = stats.max_abs_deg.cwiseMax(error.cwiseAbs());
  }
  stats.rmse_deg = (stats.rmse_deg / static_cast<double>(count)).cwiseSqrt();
  stats.mae_deg /= static_cast<double>(count);
  return stats;
}

ModelComparison compare_model(const Geometry& geometry, const Recording& recording) {
  ModelComparison comparison;
  const std::size_t count = recording.samples.size();
  comparison.predicted_alpha_deg.reserve(count);
  comparison.joint_error_deg.reserve(count);
  comparison.position_error_m.reserve(count);
  std::vector<Vec3> measured;
  measured.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Sample& sample = recording.samples[i];
    const std::size_t line = i < recording.line_numbers.size() ? recording.line_numbers[i] : 0;
    const IkSolution ik = inverse_kinematics(geometry, sample.position_m);
    if (!ik.ok()) throw InputError(recording.path, line, "model inverse kinematics: " + ik.reason());
    const FkSolution fk = forward_kinematics(geometry, sample.alpha_deg);
    if (!fk.ok()) throw InputError(recording.path, line, "model forward kinematics: " + fk.reason());
    comparison.predicted_alpha_deg.push_back(ik.alpha_deg);
    comparison.joint_error_deg.push_back(sample.alpha_deg - ik.alpha_deg);
    const Vec3 position_error = fk.position_m - sample.position_m;
    comparison.position_error_m.push_back(position_error);
    comparison.position_error_min_m = i ? comparison.position_error_min_m.cwiseMin(position_error) : position_error;
    comparison.position_error_max_m = i ? comparison.position_error_max_m.cwiseMax(position_error) : position_error;
    measured.push_back(sample.alpha_deg);
  }
  comparison.joints = joint_error_stats(measured, comparison.predicted_alpha_deg);
  return comparison;
}

}  // namespace delta
