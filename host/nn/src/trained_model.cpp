// Evaluation of network, hybrid and deployed weights files.
#include "delta/nn/trained_model.hpp"

#include <Eigen/Geometry>

namespace delta::nn {

IkSolution math_model_angles(const EffectSet& effects, const Vec3& measured_position_m) {
  Vec3 true_position_m = measured_position_m;
  if (effects.frame_misalignment) {
    const FrameMisalignment& frame = *effects.frame_misalignment;
    true_position_m =
        misalignment_rotation(frame.rotation_deg).transpose() * (measured_position_m - frame.translation_m);
  }
  IkSolution solution = inverse_kinematics(apply_geometry_effects(Geometry::nominal(), effects), true_position_m);
  if (!solution.ok()) return solution;
  for (int j = 0; j < 3; ++j) {
    const double scale = effects.encoder_scale ? (*effects.encoder_scale)[j] : 0.0;
    const TransmissionError transmission = effects.transmission_error.value_or(TransmissionError{});
    solution.alpha_deg[j] = scale_and_transmission(solution.alpha_deg[j], scale, transmission.amplitude_deg[j],
                                                   transmission.period_deg[j], transmission.phase_rad[j]);
  }
  if (effects.joint_offset_deg) solution.alpha_deg += *effects.joint_offset_deg;
  return solution;
}

IkSolution evaluate_model(const WeightsFile& weights, const Vec3& measured_position_m) {
  IkSolution solution;
  if (!measured_position_m.allFinite()) {
    solution.error = KinematicsError::not_finite;
    return solution;
  }
  if (weights.hybrid()) {
    solution = math_model_angles(weights.effects, measured_position_m);
    if (!solution.ok()) return solution;
  }
  solution.alpha_deg += weights.network.evaluate(measured_position_m);
  return solution;
}

void add_hybrid_math_model(const WeightsFile& weights, const Vec3& measured_position_m, IkRow& row) {
  if (!weights.hybrid()) return;
  const IkSolution model = math_model_angles(weights.effects, measured_position_m);
  if (model.ok())
    row.alpha_deg += model.alpha_deg;
  else
    row.error = model.reason();
}

BacklashCompensation::BacklashCompensation(const Vec3& half_play_deg) {
  for (int j = 0; j < 3; ++j) play_[j] = Backlash(2.0 * half_play_deg[j]);
}

Vec3 BacklashCompensation::update(const Vec3& static_deg) {
  Vec3 out;
  for (int j = 0; j < 3; ++j) out[j] = play_[j].update(static_deg[j]);
  return out;
}

}  // namespace delta::nn
