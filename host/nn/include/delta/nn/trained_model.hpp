// Evaluation of a weights file: pose-wise (the pure network, the hybrid's math model with the
// identified effects plus the network's residual, the deployed model's static network) and the
// deployed model's time-ordered part (backlash compensation of each joint, in row order).
#pragma once

#include <array>

#include "delta/effects.hpp"
#include "delta/ik_backend.hpp"
#include "delta/kinematics.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::nn {

// The math model with memoryless effects, inverting the SPEC measurement chain: the measured
// position is taken back through frame_misalignment, the closed-form inverse kinematics of the
// nominal geometry with the geometric effects gives the true angle, then encoder_scale,
// transmission_error and joint_offset give the measured angle. Backlash is ignored (it needs the
// direction of motion). An unreachable pose is an error value, never NaN.
IkSolution math_model_angles(const EffectSet& effects, const Vec3& measured_position_m);

// Joint angles in degrees the model of `weights` predicts for a measured plate position in metres
// (a deployed model's static angle: the network at the shaped setpoint).
IkSolution evaluate_model(const WeightsFile& weights, const Vec3& measured_position_m);

// The position the host sends for plate position p under a deployed model with a joint ripple
// table (weights_file.hpp): p' with N(p') = N(p) + r(N(p)), by Newton steps (N's Jacobian by
// central differences);
// the network then answers with the ripple in. Without a table (or a model of another kind): p.
// Every back end and the controller shape their positions with this one function.
Vec3 shape_setpoint(const WeightsFile& weights, const Vec3& position_m);

// The inverse: the plate position whose shaped setpoint is `shaped_m` (where the plate is when the
// board holds a setpoint the host sent).
Vec3 unshape_setpoint(const WeightsFile& weights, const Vec3& shaped_m);

// For back ends that evaluate only the network (fixed point, HLS, RTL): with hybrid weights their
// angles are the network's residual, so this adds the math model in double (or sets row.error
// when the model cannot reach the pose). A pure network leaves the row as it is.
void add_hybrid_math_model(const WeightsFile& weights, const Vec3& measured_position_m, IkRow& row);

// The deployed model's time-ordered part in double (weights_file.hpp): one play of half-width h_j
// per joint on the static angles, fed in time order; the first angle passes unchanged.
class BacklashCompensation {
 public:
  explicit BacklashCompensation(const Vec3& half_play_deg);
  Vec3 update(const Vec3& static_deg);

 private:
  std::array<Backlash, 3> play_;
};

}  // namespace delta::nn
