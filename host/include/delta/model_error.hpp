// How far a kinematic model is from a recording: the paper's Table 1 statistics and FK error ranges.
#pragma once

#include <string>
#include <vector>

#include "delta/geometry.hpp"
#include "delta/recording.hpp"

namespace delta {

struct JointErrorStats {
  Vec3 rmse_deg = Vec3::Zero();
  Vec3 mae_deg = Vec3::Zero();
  Vec3 max_abs_deg = Vec3::Zero();
};

// Statistics of measured - predicted over all rows.
JointErrorStats joint_error_stats(const std::vector<Vec3>& measured_deg, const std::vector<Vec3>& predicted_deg);

struct ModelComparison {
  std::vector<Vec3> predicted_alpha_deg;  // model IK of each measured position
  std::vector<Vec3> joint_error_deg;      // measured - predicted, per sample
  std::vector<Vec3> position_error_m;     // FK(measured angles) - measured position, per sample
  JointErrorStats joints;
  Vec3 position_error_min_m = Vec3::Zero();
  Vec3 position_error_max_m = Vec3::Zero();
};

// The nominal (or any given) geometry against a recording. Throws InputError naming the recording
// line of the first sample whose pose the model cannot reach.
ModelComparison compare_model(const Geometry& geometry, const Recording& recording);

}  // namespace delta
