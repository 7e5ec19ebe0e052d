// Closed-form Delta kinematics: inverse per chain, forward by sphere intersection, Jacobian.
#include "delta/kinematics.hpp"

#include <Eigen/Dense>

namespace delta {

const char* describe(KinematicsError error) {
  switch (error) {
    case KinematicsError::none:
      return "ok";
    case KinematicsError::unreachable:
      return "pose unreachable: the lower arm cannot reach the plate joint";
    case KinematicsError::not_finite:
      return "input is not a finite number";
    case KinematicsError::no_intersection:
      return "the three lower-arm spheres do not intersect";
  }
  return "unknown kinematics error";
}

std::string IkSolution::reason() const {
  if (ok()) return "ok";
  std::string text = describe(error);
  if (chain >= 0) text += " (chain " + std::to_string(chain + 1) + ")";
  return text;
}

IkSolution inverse_kinematics(const Geometry& geometry, const Vec3& position_m) {
  IkSolution solution;
  if (!position_m.allFinite()) {
    solution.error = KinematicsError::not_finite;
    return solution;
  }
  for (int j = 0; j < 3; ++j) {
    const ChainGeometry& chain = geometry.chains[j];
    double alpha = 0.0;
    if (!chain_inverse_kinematics(chain.upper_arm_m, chain.lower_arm_m, chain.radius_offset_m, chain.angle_deg,
                                  position_m.x(), position_m.y(), position_m.z(), alpha)) {
      solution.error = KinematicsError::unreachable;
      solution.chain = j;
      return solution;
    }
    // The closure also has solutions the robot cannot take: the plate at or above the base plane,
    // or an upper arm folded back over the base (the knee-out branch ends near 120 deg).
    if (!(position_m.z() < 0.0) || !(alpha >= kMinReachableAlphaDeg && alpha <= kMaxReachableAlphaDeg)) {
      solution.error = KinematicsError::unreachable;
      solution.chain = j;
      return solution;
    }
    solution.alpha_deg[j] = alpha;
  }
  return solution;
}

Vec3 shifted_elbow_m(const ChainGeometry& chain, double alpha_deg) {
  const double phi = chain.angle_deg * kRadPerDeg;
  const double alpha = alpha_deg * kRadPerDeg;
  const double radial = chain.radius_offset_m + chain.upper_arm_m * std::cos(alpha);
  return Vec3(radial * std::cos(phi), radial * std::sin(phi), -chain.upper_arm_m * std::sin(alpha));
}

FkSolution forward_kinematics(const Geometry& geometry, const Vec3& alpha_deg) {
  FkSolution solution;
  if (!alpha_deg.allFinite()) {
    solution.error = KinematicsError::not_finite;
    return solution;
  }
  Vec3 centre[3];
  double radius_sq[3];
  for (int j = 0; j < 3; ++j) {
    centre[j] = shifted_elbow_m(geometry.chains[j], alpha_deg[j]);
    radius_sq[j] = geometry.chains[j].lower_arm_m * geometry.chains[j].lower_arm_m;
  }
  // Subtracting sphere 0 from spheres 1 and 2 leaves two planes n_k . p = d_k; their line is
  // p = p0 + s * direction, and sphere 0 then gives a quadratic in s.
  Eigen::Matrix<double, 2, 3> normals;
  Eigen::Vector2d offsets;
  for (int k = 0; k < 2; ++k) {
    normals.row(k) = 2.0 * (centre[k + 1] - centre[0]).transpose();
    offsets[k] = centre[k + 1].squaredNorm() - centre[0].squaredNorm() - radius_sq[k + 1] + radius_sq[0];
  }
  const Vec3 direction = Vec3(normals.row(0)).cross(Vec3(normals.row(1)));
  const double direction_sq = direction.squaredNorm();
  if (!(direction_sq > 1e-30)) {
    solution.error = KinematicsError::no_intersection;
    return solution;
  }
  // Point on the line closest to the origin: minimum-norm solution of the 2x3 system.
  const Vec3 point = normals.transpose() * (normals * normals.transpose()).inverse() * offsets;
  const Vec3 to_point = point - centre[0];
  const double b = direction.dot(to_point);
  const double c = to_point.squaredNorm() - radius_sq[0];
  const double discriminant = b * b - direction_sq * c;
  if (!(discriminant >= 0.0)) {
    solution.error = KinematicsError::no_intersection;
    return solution;
  }
  const double root = std::sqrt(discriminant);
  const Vec3 first = point + direction * ((-b + root) / direction_sq);
  const Vec3 second = point + direction * ((-b - root) / direction_sq);
  solution.position_m = first.z() < second.z() ? first : second;
  return solution;
}

Eigen::Matrix3d inverse_jacobian_deg_per_m(const Geometry& geometry, const Vec3& position_m, const Vec3& alpha_deg) {
  // Differentiating |e_j(alpha_j) - p|^2 = L_B^2 gives (e_j - p) . (de_j/dalpha dalpha - dp) = 0.
  Eigen::Matrix3d jacobian;
  for (int j = 0; j < 3; ++j) {
    const ChainGeometry& chain = geometry.chains[j];
    const double phi = chain.angle_deg * kRadPerDeg;
    const double alpha = alpha_deg[j] * kRadPerDeg;
    const Vec3 arm = shifted_elbow_m(chain, alpha_deg[j]) - position_m;
    const Vec3 elbow_rate(-chain.upper_arm_m * std::sin(alpha) * std::cos(phi),
                          -chain.upper_arm_m * std::sin(alpha) * std::sin(phi), -chain.upper_arm_m * std::cos(alpha));
    jacobian.row(j) = arm.transpose() / arm.dot(elbow_rate) * kDegPerRad;
  }
  return jacobian;
}

}  // namespace delta
