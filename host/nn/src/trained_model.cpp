// Evaluation of network, hybrid and deployed weights files.
#include "delta/nn/trained_model.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

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

namespace {

// Shaping moves a setpoint by microns: a handful of Newton steps reach the double's resolution.
constexpr int kShapingSteps = 4;
constexpr double kJacobianStepM = 1e-6;

// dN/dp by central differences (deg per metre).
Eigen::Matrix3d network_jacobian(const Network& network, const Vec3& position_m) {
  Eigen::Matrix3d jacobian;
  for (int k = 0; k < 3; ++k) {
    Vec3 step = Vec3::Zero();
    step[k] = kJacobianStepM;
    jacobian.col(k) =
        (network.evaluate(position_m + step) - network.evaluate(position_m - step)) / (2 * kJacobianStepM);
  }
  return jacobian;
}

bool shapes(const WeightsFile& weights) { return weights.deployed() && !weights.joint_ripple.empty(); }

}  // namespace

Vec3 shape_setpoint(const WeightsFile& weights, const Vec3& position_m) {
  if (!shapes(weights) || !position_m.allFinite()) return position_m;
  const Network& network = weights.network;
  const Vec3 answer = network.evaluate(position_m);
  const Vec3 wanted = answer + weights.joint_ripple.at(answer);
  Vec3 shaped = position_m;
  for (int step = 0; step < kShapingSteps; ++step) {
    shaped += network_jacobian(network, shaped).partialPivLu().solve(wanted - network.evaluate(shaped));
  }
  return shaped.allFinite() ? shaped : position_m;
}

Vec3 unshape_setpoint(const WeightsFile& weights, const Vec3& shaped_m) {
  if (!shapes(weights) || !shaped_m.allFinite()) return shaped_m;
  Vec3 position = shaped_m;
  for (int step = 0; step < kShapingSteps; ++step) position += shaped_m - shape_setpoint(weights, position);
  return position;
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
  solution.alpha_deg += weights.network.evaluate(shape_setpoint(weights, measured_position_m));
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
