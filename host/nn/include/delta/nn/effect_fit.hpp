// Identification of the math model's memoryless effects for the hybrid model: per chain the
// geometry (upper and lower arm length, radius offset, chain angle), joint_offset and
// encoder_scale, the frame misalignment (rx, ry, tx, ty, tz; rz is left at zero because a
// common chain-angle change is the same motion) and backlash, fitted by Levenberg-Marquardt to a
// recording in time order. Backlash needs the direction of motion, so a pose-wise model cannot use
// it; the fit identifies it so that the hybrid's network learns a residual free of it.
#pragma once

#include <vector>

#include "delta/effects.hpp"
#include "delta/virtual_robot.hpp"

namespace delta::nn {

struct EffectFit {
  EffectSet effects;                    // including backlash_deg
  Vec3 rmse_before_deg = Vec3::Zero();  // nominal math model
  Vec3 rmse_after_deg = Vec3::Zero();   // with the fitted effects, backlash included (in time order)
  int iterations = 0;
};

// Fits on all samples (position -> measured angles). Throws std::invalid_argument when the
// nominal model cannot reach a sample.
// Angles the math model with `effects` predicts along a recording in time order (backlash is
// stateful); false when a pose is unreachable.
bool predict_in_time_order(const EffectSet& effects, const std::vector<Sample>& samples, std::vector<Vec3>& predicted);
// The same, throwing std::invalid_argument for an unreachable pose.
std::vector<Vec3> predict_recording(const EffectSet& effects, const std::vector<Sample>& samples);

EffectFit fit_math_model_effects(const std::vector<Sample>& samples, int max_iterations = 100);

}  // namespace delta::nn
