// Closed-form Delta kinematics with per-chain parameters: inverse, forward, Jacobian.
//
// Frames follow docs/contracts.md: base frame at the centre of the base joint circle, z up, chain j
// along its angle about z; alpha_j in degrees, positive with the elbow below the base plane.
// The per-chain inverse kinematics is a template on the scalar type so that automatic
// differentiation (Eigen::AutoDiffScalar) can run through the very same code.
#pragma once

#include <cmath>
#include <string>

#include "delta/geometry.hpp"

namespace delta {

enum class KinematicsError {
  none,
  unreachable,     // the lower arm cannot reach the plate joint at any shaft angle
  not_finite,      // an input was NaN or infinite
  no_intersection  // forward kinematics: the three lower-arm spheres do not meet
};

const char* describe(KinematicsError error);

struct IkSolution {
  Vec3 alpha_deg = Vec3::Zero();
  KinematicsError error = KinematicsError::none;
  int chain = -1;  // the chain that failed, 0-based, when error != none
  bool ok() const { return error == KinematicsError::none; }
  std::string reason() const;
};

struct FkSolution {
  Vec3 position_m = Vec3::Zero();
  KinematicsError error = KinematicsError::none;
  bool ok() const { return error == KinematicsError::none; }
  std::string reason() const { return describe(error); }
};

// Shaft angle of one chain for a plate position; returns false when unreachable.
// Derivation: with a = (R_A - R_B) - x_local, the loop closure
//   (a + L_A cos(alpha))^2 + y_local^2 + (z + L_A sin(alpha))^2 = L_B^2
// reduces to a cos(alpha) + z sin(alpha) = C with C = (L_B^2 - L_A^2 - a^2 - y^2 - z^2) / (2 L_A),
// so alpha = atan2(z, a) + acos(C / sqrt(a^2 + z^2)); the + branch is the knee-out assembly.
template <typename Scalar>
bool chain_inverse_kinematics(const Scalar& upper_arm_m, const Scalar& lower_arm_m, const Scalar& radius_offset_m,
                              const Scalar& chain_angle_deg, const Scalar& x_m, const Scalar& y_m, const Scalar& z_m,
                              Scalar& alpha_deg) {
  using std::acos;
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  const Scalar phi = chain_angle_deg * Scalar(kRadPerDeg);
  const Scalar x_local = cos(phi) * x_m + sin(phi) * y_m;
  const Scalar y_local = -sin(phi) * x_m + cos(phi) * y_m;
  const Scalar a = radius_offset_m - x_local;
  const Scalar c = (lower_arm_m * lower_arm_m - upper_arm_m * upper_arm_m - a * a - y_local * y_local - z_m * z_m) /
                   (Scalar(2) * upper_arm_m);
  const Scalar r = sqrt(a * a + z_m * z_m);
  if (!(r > Scalar(0))) return false;
  const Scalar ratio = c / r;
  if (!(ratio >= Scalar(-1) && ratio <= Scalar(1))) return false;
  alpha_deg = (atan2(z_m, a) + acos(ratio)) * Scalar(kDegPerRad);
  return true;
}

// Shaft angles the robot can physically take (knee out, upper arm not folded over the base).
constexpr double kMinReachableAlphaDeg = -90.0;
constexpr double kMaxReachableAlphaDeg = 120.0;

// All three chains; a pose is unreachable when the plate is not below the base plane (z < 0, SPEC)
// or a chain's angle falls outside [kMinReachableAlphaDeg, kMaxReachableAlphaDeg].
IkSolution inverse_kinematics(const Geometry& geometry, const Vec3& position_m);

// Lower intersection (plate below the elbows) of the three spheres of radius L_B centred on the
// elbows shifted by the plate radius.
FkSolution forward_kinematics(const Geometry& geometry, const Vec3& alpha_deg);

// Elbow position of chain j shifted inwards by the plate radius (the sphere centre of FK).
Vec3 shifted_elbow_m(const ChainGeometry& chain, double alpha_deg);

// d(alpha)/d(position) at a consistent (position, alpha) pair, degrees per metre; row j is chain j.
// The forward Jacobian d(position)/d(alpha) is its inverse.
Eigen::Matrix3d inverse_jacobian_deg_per_m(const Geometry& geometry, const Vec3& position_m, const Vec3& alpha_deg);

}  // namespace delta
