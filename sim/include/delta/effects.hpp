// The unmodelled effects of a real Delta robot (docs/contracts.md vocabulary), one definition shared
// by the virtual robot (which injects them) and the diagnosis (which identifies them).
//
// Lengths in metres, angles in degrees, phases in radians, scales dimensionless.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "delta/geometry.hpp"

namespace delta {

struct TransmissionError {
  Vec3 amplitude_deg = Vec3::Zero();        // A_j
  Vec3 period_deg = Vec3::Constant(360.0);  // P_j: shaft angle per ripple period
  Vec3 phase_rad = Vec3::Zero();            // phi_j
};

struct FrameMisalignment {
  Vec3 rotation_deg = Vec3::Zero();   // rx, ry, rz: p_meas = Rz Ry Rx p_true + t
  Vec3 translation_m = Vec3::Zero();  // tx, ty, tz
};

// Every field is optional: an absent effect is not part of the robot (or of the model).
struct EffectSet {
  std::optional<Vec3> joint_offset_deg;
  std::optional<Vec3> upper_arm_length_m;  // dL_A per chain
  std::optional<Vec3> lower_arm_length_m;  // dL_B per chain
  std::optional<Vec3> radius_offset_m;     // d(R_A - R_B) per chain
  std::optional<Vec3> chain_angle_deg;     // dphi per chain
  std::optional<FrameMisalignment> frame_misalignment;
  std::optional<Vec3> backlash_deg;  // play width b_j
  std::optional<TransmissionError> transmission_error;
  std::optional<Vec3> encoder_scale;  // k_j

  bool empty() const;
  std::vector<std::string> names() const;  // the effects present, in vocabulary order
};

// The vocabulary's names in SPEC table order.
const std::vector<std::string>& effect_vocabulary();

// Nominal geometry with the geometric effects (arm lengths, radius offset, chain angle) applied.
Geometry apply_geometry_effects(const Geometry& nominal, const EffectSet& effects);

// Rotation of frame_misalignment, Rz(rz) Ry(ry) Rx(rx).
Eigen::Matrix3d misalignment_rotation(const Vec3& rotation_deg);

// Measured position (before stage quantisation) for a true plate position.
Vec3 apply_frame_misalignment(const EffectSet& effects, const Vec3& true_position_m);

// apply_frame_misalignment with its rotation computed once (the same bits), for loops over samples.
class StageFrame {
 public:
  explicit StageFrame(const EffectSet& effects);
  Vec3 operator()(const Vec3& true_position_m) const {
    return misaligned_ ? Vec3(rotation_ * true_position_m + translation_m_) : true_position_m;
  }

 private:
  bool misaligned_ = false;
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
  Vec3 translation_m_ = Vec3::Zero();
};

// Memoryless part of the joint sensor chain before backlash: encoder_scale then
// transmission_error, for one joint. Templated for automatic differentiation.
template <typename Scalar>
Scalar scale_and_transmission(const Scalar& true_alpha_deg, double scale, double amplitude_deg, double period_deg,
                              double phase_rad) {
  using std::sin;
  Scalar alpha = (Scalar(1) + Scalar(scale)) * true_alpha_deg;
  if (amplitude_deg != 0.0) {
    alpha = alpha + Scalar(amplitude_deg) * sin(Scalar(2.0 * kPi / period_deg) * alpha + Scalar(phase_rad));
  }
  return alpha;
}

// Play of width b: the output follows the input only once the input has moved b/2 past it.
class Backlash {
 public:
  explicit Backlash(double width_deg = 0.0) : half_width_deg_(0.5 * width_deg) {}
  double update(double input_deg) {
    if (!started_) {
      started_ = true;
      output_deg_ = input_deg;
    } else if (input_deg > output_deg_ + half_width_deg_) {
      output_deg_ = input_deg - half_width_deg_;
    } else if (input_deg < output_deg_ - half_width_deg_) {
      output_deg_ = input_deg + half_width_deg_;
    }
    return output_deg_;
  }
  void reset() { started_ = false; }

 private:
  double half_width_deg_;
  double output_deg_ = 0.0;
  bool started_ = false;
};

// The joint sensor chain of SPEC, in its order: encoder_scale, transmission_error, backlash,
// joint_offset (quantisation is separate). Stateful because of backlash: feed samples in time order.
class JointSensorChain {
 public:
  explicit JointSensorChain(const EffectSet& effects);
  Vec3 update(const Vec3& true_alpha_deg);
  void reset();
  // Joint j's reading of a true angle without the backlash (which depends on the history):
  // encoder_scale, transmission_error, joint_offset. Monotonic for the vocabulary's small effects.
  double reading_without_backlash(int joint, double true_alpha_deg) const;

 private:
  double scaled_and_transmitted(int joint, double true_alpha_deg) const;

  EffectSet effects_;
  std::array<Backlash, 3> backlash_;
  // update()'s last scaled and transmitted angles and their true angles (NaN: none yet).
  Vec3 last_true_alpha_deg_ = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  Vec3 last_transmitted_deg_ = Vec3::Zero();
};

// Round to the nearest multiple of a resolution (encoder counts, stage counts).
inline double quantise(double value, double resolution) { return std::round(value / resolution) * resolution; }

}  // namespace delta
