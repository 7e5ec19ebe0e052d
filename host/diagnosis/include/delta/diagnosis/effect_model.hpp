// The parametric model the diagnosis fits: the nominal Delta plus the SPEC effect families, all
// parameters in one vector, evaluated by the sim's own kinematics (templated for autodiff).
//
// Internal units of the parameter vector: angles in degrees, lengths in millimetres (better
// conditioned than metres), phases in radians, scales dimensionless. to_effect_set() converts to
// the SI units of the SPEC effect files.
#pragma once

#include <array>
#include <bitset>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "delta/effects.hpp"
#include "delta/kinematics.hpp"
#include "delta/virtual_robot.hpp"

namespace delta::diagnosis {

// The SPEC vocabulary, in SPEC table order.
enum class Family {
  joint_offset,
  upper_arm_length,
  lower_arm_length,
  radius_offset,
  chain_angle,
  frame_misalignment,
  backlash,
  transmission_error,
  encoder_scale
};
constexpr int kFamilyCount = 9;
using FamilySet = std::bitset<kFamilyCount>;

inline int index_of(Family family) { return static_cast<int>(family); }
inline Family family_at(int index) { return static_cast<Family>(index); }
const char* family_name(Family family);
// geometry, measuring frame, transmission or sensor: where in the robot the effect lives.
const char* subsystem_of(Family family);
FamilySet single(Family family);
std::string describe(FamilySet families);  // "backlash + joint_offset", or "nominal"

// Global parameter vector layout.
constexpr int kParameterCount = 36;
using Parameters = Eigen::Matrix<double, kParameterCount, 1>;
namespace slot {
constexpr int joint_offset = 0;        // o_j [deg], 3
constexpr int upper_arm = 3;           // dL_A,j [mm], 3
constexpr int lower_arm = 6;           // dL_B,j [mm], 3
constexpr int radius = 9;              // dr_j [mm], 3
constexpr int chain_angle = 12;        // dphi_j [deg], 3
constexpr int frame_rotation = 15;     // rx, ry, rz [deg]
constexpr int frame_translation = 18;  // tx, ty, tz [mm]
constexpr int backlash = 21;           // b_j [deg], 3
constexpr int amplitude = 24;          // A_j [deg], 3
constexpr int period = 27;             // P_j [deg], 3
constexpr int phase = 30;              // phi_j [rad], 3
constexpr int encoder_scale = 33;      // k_j [-], 3
}  // namespace slot

struct ParameterInfo {
  std::string name;  // e.g. "dL_A,2"
  std::string unit;  // internal unit
  Family family;
  double typical;  // a realistic magnitude in the internal unit (column scaling, weak prior)
};
const std::array<ParameterInfo, kParameterCount>& parameter_table();
std::vector<int> parameter_indices(FamilySet families);  // sorted global indices

// All zero except the transmission periods (360 deg, so that a zero amplitude is harmless).
Parameters neutral_parameters();
EffectSet to_effect_set(const Parameters& theta, FamilySet families);
Parameters from_effect_set(const EffectSet& effects);  // absent effects stay neutral
FamilySet families_of(const EffectSet& effects);

// Per joint, the 16 parameters that act on it, in evaluation order; local k -> global index.
constexpr int kLocalCount = 16;
std::array<int, kLocalCount> local_parameters(int joint);

// Backlash of the SPEC (sim/include/delta/effects.hpp, class Backlash) on any scalar type, so
// that derivatives pass through the hysteresis; for double it is the same arithmetic, tested
// bit-exact against delta::Backlash.
template <typename Scalar>
class BacklashState {
 public:
  Scalar update(const Scalar& input_deg, const Scalar& width_deg) {
    const Scalar half_width = Scalar(0.5) * width_deg;
    if (!started_) {
      started_ = true;
      output_deg_ = input_deg;
    } else if (input_deg > output_deg_ + half_width) {
      output_deg_ = input_deg - half_width;
    } else if (input_deg < output_deg_ - half_width) {
      output_deg_ = input_deg + half_width;
    }
    return output_deg_;
  }

 private:
  Scalar output_deg_ = Scalar(0);
  bool started_ = false;
};

// scale_and_transmission of effects.hpp with every parameter a Scalar (the sim's version takes
// the parameters as double, so only the angle could carry derivatives there).
template <typename Scalar>
Scalar scale_and_transmission_all(const Scalar& true_alpha_deg, const Scalar& scale, const Scalar& amplitude_deg,
                                  const Scalar& period_deg, const Scalar& phase_rad, bool with_transmission) {
  using std::sin;
  Scalar alpha = (Scalar(1) + scale) * true_alpha_deg;
  if (with_transmission) alpha = alpha + amplitude_deg * sin(Scalar(2.0 * kPi) / period_deg * alpha + phase_rad);
  return alpha;
}

// Predicted measured angle of `joint` for every row, in time order (backlash), on Scalar. `local`
// holds the 16 local parameters (see local_parameters). `visit(i, predicted)` is called per row.
// Returns false (and stops) at the first row the model cannot reach.
template <typename Scalar, typename Visitor>
bool predict_joint(const std::array<Scalar, kLocalCount>& local, FamilySet families, int joint,
                   const std::vector<Sample>& rows, Visitor&& visit, std::size_t* failed_row = nullptr) {
  using std::cos;
  using std::sin;
  const Scalar& offset = local[0];
  const Scalar upper = Scalar(0.040) + local[1] * Scalar(1e-3);
  const Scalar lower = Scalar(0.068) + local[2] * Scalar(1e-3);
  const Scalar radius = Scalar(0.010) + local[3] * Scalar(1e-3);
  const Scalar angle = Scalar(120.0 * joint) + local[4];
  const bool frame = families[index_of(Family::frame_misalignment)];
  const bool play = families[index_of(Family::backlash)];
  const bool transmission = families[index_of(Family::transmission_error)];
  // Inverse of p_meas = Rz Ry Rx p_true + t: p_true = Rx^T Ry^T Rz^T (p_meas - t).
  Scalar cx(1), sx(0), cy(1), sy(0), cz(1), sz(0);
  if (frame) {
    cx = cos(local[5] * Scalar(kRadPerDeg));
    sx = sin(local[5] * Scalar(kRadPerDeg));
    cy = cos(local[6] * Scalar(kRadPerDeg));
    sy = sin(local[6] * Scalar(kRadPerDeg));
    cz = cos(local[7] * Scalar(kRadPerDeg));
    sz = sin(local[7] * Scalar(kRadPerDeg));
  }
  BacklashState<Scalar> backlash;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Vec3& p = rows[i].position_m;
    Scalar x(p.x()), y(p.y()), z(p.z());
    if (frame) {
      const Scalar qx = x - local[8] * Scalar(1e-3), qy = y - local[9] * Scalar(1e-3),
                   qz = z - local[10] * Scalar(1e-3);
      const Scalar ux = cz * qx + sz * qy, uy = -sz * qx + cz * qy, uz = qz;  // Rz^T
      const Scalar vx = cy * ux - sy * uz, vy = uy, vz = sy * ux + cy * uz;   // Ry^T
      x = vx;
      y = cx * vy + sx * vz;  // Rx^T
      z = -sx * vy + cx * vz;
    }
    Scalar alpha;
    if (!chain_inverse_kinematics<Scalar>(upper, lower, radius, angle, x, y, z, alpha)) {
      if (failed_row) *failed_row = i;
      return false;
    }
    alpha = scale_and_transmission_all<Scalar>(alpha, local[15], local[12], local[13], local[14], transmission);
    if (play) alpha = backlash.update(alpha, local[11]);
    alpha = alpha + offset;
    visit(i, alpha);
  }
  return true;
}

struct Prediction {
  std::vector<Vec3> alpha_deg;
  std::size_t unreachable = 0;  // rows the model cannot reach (their true angle is held)
  std::size_t first_unreachable = 0;
};

// The angles the model (nominal + `effects`) predicts for a recording, through the very code of
// the virtual robot: apply_geometry_effects, inverse_kinematics, JointSensorChain; the measured
// position is taken back to the base frame by the inverse of frame_misalignment.
Prediction predict_recording(const EffectSet& effects, const std::vector<Sample>& rows);

}  // namespace delta::diagnosis
