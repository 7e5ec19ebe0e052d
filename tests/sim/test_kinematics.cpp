// Kinematics against an independent implementation of the SPEC conventions, round trips, Jacobian.
#include "delta/kinematics.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace delta {
namespace {

// Independent reference: SPEC frames built literally (base joint at R_A on the chain direction,
// elbow by rotating the upper arm about the shaft axis, plate joint at R_B on the same direction
// from the plate centre), and the shaft angle found by bracketing plus Newton on the loop closure
// |elbow(alpha) - plate_joint| = L_B. Shares no formula with the closed form.
struct ReferenceChain {
  double base_radius, plate_radius, upper, lower, angle_deg;
};

double reference_ik(const ReferenceChain& chain, const Vec3& plate_centre) {
  const Eigen::Matrix3d to_chain = Eigen::AngleAxisd(chain.angle_deg * kPi / 180.0, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 base_joint = to_chain * Vec3(chain.base_radius, 0, 0);
  const Vec3 plate_joint = plate_centre + to_chain * Vec3(chain.plate_radius, 0, 0);
  const Vec3 shaft_axis = to_chain * Vec3::UnitY();  // arm swings in the chain's x-z plane
  auto closure = [&](double alpha_rad) {
    // Rotating the arm (pointing outwards along x) by +alpha about the shaft axis y moves the
    // elbow down (knee out, elbow below the base plane for positive alpha).
    const Vec3 arm = Eigen::AngleAxisd(alpha_rad, shaft_axis) * (to_chain * Vec3(chain.upper, 0, 0));
    return (base_joint + arm - plate_joint).norm() - chain.lower;
  };
  // From the arm pointing straight up (-90 deg) the elbow is far from the plate; the knee-out
  // solution is the first angle where the closure falls through zero: scan for that sign change,
  // then refine by bisection to machine precision.
  double low = -0.5 * kPi, previous = closure(low);
  const int steps = 2000;
  for (int i = 1; i <= steps; ++i) {
    const double x = -0.5 * kPi + 1.5 * kPi * i / steps;
    const double value = closure(x);
    if (previous > 0 && value <= 0) {
      double high = x;
      for (int k = 0; k < 200; ++k) {
        const double middle = 0.5 * (low + high);
        (closure(middle) > 0 ? low : high) = middle;
      }
      return 0.5 * (low + high) * 180.0 / kPi;
    }
    low = x;
    previous = value;
  }
  return std::nan("");
}

// The design cube: 40 mm on a side about (0, 0, -75 mm), every point reachable.
template <typename Visit>
void for_each_cube_point(int per_axis, Visit visit) {
  for (int i = 0; i < per_axis; ++i)
    for (int j = 0; j < per_axis; ++j)
      for (int k = 0; k < per_axis; ++k) {
        const double step = 0.040 / (per_axis - 1);
        visit(Vec3(-0.020 + step * i, -0.020 + step * j, -0.095 + step * k));
      }
}

TEST(Kinematics, NominalHomePoseMatchesSpec) {
  // SPEC: alpha = (30, 30, 30) deg puts the plate centre at (0, 0, -71.295) mm.
  const FkSolution fk = forward_kinematics(Geometry::nominal(), Vec3(30, 30, 30));
  ASSERT_TRUE(fk.ok());
  EXPECT_NEAR(fk.position_m.x(), 0.0, 1e-12);
  EXPECT_NEAR(fk.position_m.y(), 0.0, 1e-12);
  EXPECT_NEAR(fk.position_m.z(), -0.071295, 0.5e-6);
}

TEST(Kinematics, InverseMatchesIndependentImplementationOverDesignCube) {
  const Geometry geometry = Geometry::nominal();
  double worst = 0.0;
  int points = 0;
  for_each_cube_point(9, [&](const Vec3& p) {
    const IkSolution ik = inverse_kinematics(geometry, p);
    ASSERT_TRUE(ik.ok()) << p.transpose();
    for (int j = 0; j < 3; ++j) {
      const double reference = reference_ik({0.040, 0.030, 0.040, 0.068, 120.0 * j}, p);
      worst = std::max(worst, std::fabs(ik.alpha_deg[j] - reference));
    }
    ++points;
  });
  EXPECT_EQ(points, 729);
  EXPECT_LT(worst, 1e-9) << "worst |closed form - reference| in deg";
}

TEST(Kinematics, InverseMatchesIndependentImplementationForPerturbedChains) {
  Geometry geometry = Geometry::nominal();
  const double base[3] = {0.0402, 0.0398, 0.0401}, plate[3] = {0.0299, 0.0303, 0.0300};
  for (int j = 0; j < 3; ++j) {
    geometry.chains[j].upper_arm_m = 0.040 + 0.0003 * (j - 1);
    geometry.chains[j].lower_arm_m = 0.068 - 0.0002 * j;
    geometry.chains[j].radius_offset_m = base[j] - plate[j];
    geometry.chains[j].angle_deg = 120.0 * j + 0.7 * (j - 1);
  }
  double worst = 0.0;
  for_each_cube_point(5, [&](const Vec3& p) {
    const IkSolution ik = inverse_kinematics(geometry, p);
    ASSERT_TRUE(ik.ok());
    for (int j = 0; j < 3; ++j) {
      const ChainGeometry& c = geometry.chains[j];
      const double reference = reference_ik({base[j], plate[j], c.upper_arm_m, c.lower_arm_m, c.angle_deg}, p);
      worst = std::max(worst, std::fabs(ik.alpha_deg[j] - reference));
    }
  });
  EXPECT_LT(worst, 1e-9);
}

TEST(Kinematics, InverseThenForwardRoundTripsToOneNanometre) {
  Geometry perturbed = Geometry::nominal();
  perturbed.chains[1].lower_arm_m += 0.0004;
  perturbed.chains[2].angle_deg += 0.5;
  for (const Geometry& geometry : {Geometry::nominal(), perturbed}) {
    double worst = 0.0;
    for_each_cube_point(11, [&](const Vec3& p) {
      const IkSolution ik = inverse_kinematics(geometry, p);
      ASSERT_TRUE(ik.ok());
      const FkSolution fk = forward_kinematics(geometry, ik.alpha_deg);
      ASSERT_TRUE(fk.ok());
      worst = std::max(worst, (fk.position_m - p).norm());
    });
    EXPECT_LT(worst, 1e-9) << "worst round-trip error in m";
  }
}

TEST(Kinematics, JacobianMatchesFiniteDifferences) {
  const Geometry geometry = Geometry::nominal();
  const Vec3 p(0.004, -0.003, -0.078);
  const IkSolution ik = inverse_kinematics(geometry, p);
  ASSERT_TRUE(ik.ok());
  const Eigen::Matrix3d jacobian = inverse_jacobian_deg_per_m(geometry, p, ik.alpha_deg);
  const double h = 1e-7;
  for (int k = 0; k < 3; ++k) {
    Vec3 step = Vec3::Zero();
    step[k] = h;
    const Vec3 numeric =
        (inverse_kinematics(geometry, p + step).alpha_deg - inverse_kinematics(geometry, p - step).alpha_deg) / (2 * h);
    EXPECT_LT((jacobian.col(k) - numeric).norm(), 1e-4 * numeric.norm() + 1e-6) << "column " << k;
  }
}

TEST(Kinematics, UnreachablePoseIsAnErrorWithAReasonNeverNaN) {
  const IkSolution far = inverse_kinematics(Geometry::nominal(), Vec3(0.0, 0.0, -0.2));
  EXPECT_FALSE(far.ok());
  EXPECT_EQ(far.error, KinematicsError::unreachable);
  EXPECT_NE(far.reason().find("unreachable"), std::string::npos);
  EXPECT_TRUE(far.alpha_deg.allFinite());
  const IkSolution nan = inverse_kinematics(Geometry::nominal(), Vec3(std::nan(""), 0.0, -0.07));
  EXPECT_EQ(nan.error, KinematicsError::not_finite);
  Geometry short_arms = Geometry::nominal();
  for (ChainGeometry& chain : short_arms.chains) chain.lower_arm_m = 0.005;  // spheres 5 mm, elbows ~40 mm apart
  const FkSolution apart = forward_kinematics(short_arms, Vec3(30, 30, 30));
  EXPECT_FALSE(apart.ok());
  EXPECT_TRUE(apart.position_m.allFinite());
}

}  // namespace
}  // namespace delta
