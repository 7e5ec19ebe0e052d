// Identification of the math model's memoryless effects for the hybrid model: per chain the
// geometry (upper and lower arm length, radius offset, chain angle), joint_offset and
// encoder_scale, and the frame misalignment (rx, ry, tx, ty, tz; rz is left at zero because a
// common chain-angle change is the same motion), fitted by Levenberg-Marquardt to a recording.
#pragma once

#include <vector>

#include "delta/effects.hpp"
#include "delta/virtual_robot.hpp"

namespace delta::nn {

struct EffectFit {
  EffectSet effects;
  Vec3 rmse_before_deg = Vec3::Zero();  // nominal math model
  Vec3 rmse_after_deg = Vec3::Zero();   // with the fitted effects
  int iterations = 0;
};

// Fits on all samples (position -> measured angles). Throws std::invalid_argument when the
// nominal model cannot reach a sample.
EffectFit fit_math_model_effects(const std::vector<Sample>& samples, int max_iterations = 100);

}  // namespace delta::nn
