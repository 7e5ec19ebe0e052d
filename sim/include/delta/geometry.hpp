// Geometry of the rotary Delta robot: per-chain lengths and angles, SI units (metres, degrees).
#pragma once

#include <array>

#include <Eigen/Core>

namespace delta {

using Vec3 = Eigen::Vector3d;

// One kinematic chain. Base and plate radius enter the kinematics only through their difference
// (R_A - R_B), so the chain stores that difference: the two cannot be told apart from any data.
struct ChainGeometry {
  double upper_arm_m = 0.040;      // L_A: shaft axis to elbow
  double lower_arm_m = 0.068;      // L_B: parallelogram length, elbow to plate joint
  double radius_offset_m = 0.010;  // R_A - R_B
  double angle_deg = 0.0;          // chain direction about z, counter-clockwise seen from above
};

struct Geometry {
  std::array<ChainGeometry, 3> chains;

  // The paper's robot: L_A 40 mm, L_B 68 mm, R_A 40 mm, R_B 30 mm, chains at 0/120/240 deg.
  static Geometry nominal() {
    Geometry geometry;
    for (int j = 0; j < 3; ++j) geometry.chains[j].angle_deg = 120.0 * j;
    return geometry;
  }
};

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPerRad = 180.0 / kPi;
constexpr double kRadPerDeg = kPi / 180.0;

// Encoder resolution referred to the shaft and the XYZ stage resolution (paper, Section 3).
constexpr double kEncoderResolutionDeg = 0.01;
constexpr double kStageResolutionM = 6.87e-9;

}  // namespace delta
