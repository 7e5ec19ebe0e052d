// Each effect of the SPEC vocabulary, alone, changes a validation recording the way SPEC says.
#include "delta/effects.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "delta/kinematics.hpp"
#include "delta/virtual_robot.hpp"

namespace delta {
namespace {

// 2000 samples of the validation trajectory, unquantised so each effect can be checked exactly.
std::vector<Sample> record(const EffectSet& effects, bool quantised = false) {
  RecordingOptions options;
  options.samples = 2000;
  options.quantise = quantised;
  const SimulationReport report = VirtualRobot(effects).record(make_trajectory("validation"), options);
  EXPECT_EQ(report.unreachable, 0u);
  return report.samples;
}

const std::vector<Sample>& nominal_recording() {
  static const std::vector<Sample> samples = record(EffectSet{});
  return samples;
}

Vec3 nominal_alpha(const Vec3& position) { return inverse_kinematics(Geometry::nominal(), position).alpha_deg; }

TEST(Effects, NoEffectRecordsTheNominalInverseKinematics) {
  for (const Sample& s : nominal_recording()) EXPECT_LT((s.alpha_deg - nominal_alpha(s.position_m)).norm(), 1e-12);
}

TEST(Effects, JointOffsetAddsTheOffset) {
  EffectSet effects;
  effects.joint_offset_deg = Vec3(0.5, -0.3, 0.8);
  const auto samples = record(effects);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_LT((samples[i].alpha_deg - nominal_recording()[i].alpha_deg - Vec3(0.5, -0.3, 0.8)).norm(), 1e-12);
    EXPECT_EQ(samples[i].position_m, nominal_recording()[i].position_m);
  }
}

// Geometry effects: angles are the IK of the changed chain; the other chains do not move.
void expect_geometry_effect(const EffectSet& effects, int changed_chain) {
  const Geometry truth = apply_geometry_effects(Geometry::nominal(), effects);
  const auto samples = record(effects);
  double largest_change = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Vec3 expected = inverse_kinematics(truth, samples[i].position_m).alpha_deg;
    EXPECT_LT((samples[i].alpha_deg - expected).norm(), 1e-12);
    for (int j = 0; j < 3; ++j) {
      const double change = std::fabs(samples[i].alpha_deg[j] - nominal_recording()[i].alpha_deg[j]);
      if (j != changed_chain)
        EXPECT_LT(change, 1e-12);
      else
        largest_change = std::max(largest_change, change);
    }
  }
  EXPECT_GT(largest_change, 0.05) << "the effect must move its joint visibly (deg)";
}

TEST(Effects, UpperArmLengthChangesOnlyItsChain) {
  EffectSet effects;
  effects.upper_arm_length_m = Vec3(0.0, 0.0005, 0.0);
  expect_geometry_effect(effects, 1);
  EXPECT_DOUBLE_EQ(apply_geometry_effects(Geometry::nominal(), effects).chains[1].upper_arm_m, 0.0405);
}

TEST(Effects, LowerArmLengthChangesOnlyItsChain) {
  EffectSet effects;
  effects.lower_arm_length_m = Vec3(-0.0004, 0.0, 0.0);
  expect_geometry_effect(effects, 0);
  EXPECT_DOUBLE_EQ(apply_geometry_effects(Geometry::nominal(), effects).chains[0].lower_arm_m, 0.0676);
}

TEST(Effects, RadiusOffsetChangesOnlyItsChain) {
  EffectSet effects;
  effects.radius_offset_m = Vec3(0.0, 0.0, 0.0006);
  expect_geometry_effect(effects, 2);
  EXPECT_DOUBLE_EQ(apply_geometry_effects(Geometry::nominal(), effects).chains[2].radius_offset_m, 0.0106);
}

TEST(Effects, ChainAngleRotatesOnlyItsChain) {
  EffectSet effects;
  effects.chain_angle_deg = Vec3(0.0, 1.5, 0.0);
  expect_geometry_effect(effects, 1);
  EXPECT_DOUBLE_EQ(apply_geometry_effects(Geometry::nominal(), effects).chains[1].angle_deg, 121.5);
}

TEST(Effects, FrameMisalignmentMovesOnlyTheMeasuredPosition) {
  EffectSet effects;
  effects.frame_misalignment = FrameMisalignment{Vec3(0.2, -0.1, 5.0), Vec3(1e-4, -2e-4, 3e-4)};
  const auto samples = record(effects);
  const Eigen::Matrix3d rotation = misalignment_rotation(Vec3(0.2, -0.1, 5.0));
  // Rz Ry Rx order: a point on x rotated by rz only stays in the x-y plane.
  EXPECT_NEAR((misalignment_rotation(Vec3(0, 0, 90)) * Vec3::UnitX() - Vec3::UnitY()).norm(), 0.0, 1e-15);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_EQ(samples[i].alpha_deg, nominal_recording()[i].alpha_deg);
    const Vec3 expected = rotation * nominal_recording()[i].position_m + Vec3(1e-4, -2e-4, 3e-4);
    EXPECT_LT((samples[i].position_m - expected).norm(), 1e-15);
  }
}

TEST(Effects, EncoderScaleScalesAboutZero) {
  EffectSet effects;
  effects.encoder_scale = Vec3(0.01, 0.0, -0.02);
  const auto samples = record(effects);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Vec3 a = nominal_recording()[i].alpha_deg;
    EXPECT_LT((samples[i].alpha_deg - Vec3(1.01 * a[0], a[1], 0.98 * a[2])).norm(), 1e-12);
  }
}

TEST(Effects, TransmissionErrorAddsItsRipple) {
  EffectSet effects;
  effects.transmission_error = TransmissionError{Vec3(0.05, 0.0, 0.02), Vec3(7.5, 360.0, 2.0), Vec3(0.3, 0.0, -1.0)};
  const auto samples = record(effects);
  double largest = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Vec3 a = nominal_recording()[i].alpha_deg;
    EXPECT_NEAR(samples[i].alpha_deg[0], a[0] + 0.05 * std::sin(2 * kPi * a[0] / 7.5 + 0.3), 1e-12);
    EXPECT_NEAR(samples[i].alpha_deg[1], a[1], 1e-12);
    EXPECT_NEAR(samples[i].alpha_deg[2], a[2] + 0.02 * std::sin(2 * kPi * a[2] / 2.0 - 1.0), 1e-12);
    largest = std::max(largest, std::fabs(samples[i].alpha_deg[0] - a[0]));
  }
  EXPECT_GT(largest, 0.049);
}

TEST(Effects, BacklashLagsByHalfThePlayAndHoldsOnReversal) {
  Backlash play(0.4);
  EXPECT_DOUBLE_EQ(play.update(10.0), 10.0);   // first sample passes unchanged
  EXPECT_DOUBLE_EQ(play.update(10.15), 10.0);  // inside the play: output holds
  EXPECT_DOUBLE_EQ(play.update(10.5), 10.3);   // moved past b/2: follows, lagging by b/2
  EXPECT_DOUBLE_EQ(play.update(10.2), 10.3);   // reversal: holds until the play is crossed
  EXPECT_NEAR(play.update(9.9), 10.1, 1e-12);  // then follows from the other side

  EffectSet effects;
  effects.backlash_deg = Vec3(0.3, 0.0, 0.1);
  const auto samples = record(effects);
  int lagging = 0;
  EXPECT_EQ(samples.front().alpha_deg, nominal_recording().front().alpha_deg);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Vec3 error = samples[i].alpha_deg - nominal_recording()[i].alpha_deg;
    EXPECT_LE(std::fabs(error[0]), 0.15 + 1e-12);
    EXPECT_LE(std::fabs(error[2]), 0.05 + 1e-12);
    EXPECT_EQ(error[1], 0.0);
    if (std::fabs(std::fabs(error[0]) - 0.15) < 1e-9) ++lagging;
  }
  EXPECT_GT(lagging, 1000) << "while the joint moves one way the output lags by exactly b/2";
}

TEST(Effects, SensorChainComposesInSpecOrder) {
  EffectSet effects;
  effects.encoder_scale = Vec3(0.01, 0.01, 0.01);
  effects.transmission_error = TransmissionError{Vec3(0.05, 0.05, 0.05), Vec3(7.5, 7.5, 7.5), Vec3(0.3, 0.3, 0.3)};
  effects.backlash_deg = Vec3(0.2, 0.2, 0.2);
  effects.joint_offset_deg = Vec3(0.5, 0.5, 0.5);
  const auto samples = record(effects);
  Backlash play(0.2);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double a = nominal_recording()[i].alpha_deg[0];
    const double scaled = 1.01 * a;
    const double rippled = scaled + 0.05 * std::sin(2 * kPi * scaled / 7.5 + 0.3);
    EXPECT_NEAR(samples[i].alpha_deg[0], play.update(rippled) + 0.5, 1e-12);
  }
}

TEST(Effects, QuantisationToEncoderAndStageCounts) {
  EffectSet effects;
  effects.joint_offset_deg = Vec3(0.123456, 0, 0);
  for (const Sample& s : record(effects, true)) {
    for (int k = 0; k < 3; ++k) {
      const double counts = s.alpha_deg[k] / kEncoderResolutionDeg;
      EXPECT_NEAR(counts, std::round(counts), 1e-6);
      const double stage = s.position_m[k] / kStageResolutionM;
      EXPECT_NEAR(stage, std::round(stage), 1e-6);
    }
  }
}

TEST(Effects, VocabularyIsTheSpecTable) {
  EXPECT_EQ(effect_vocabulary().size(), 9u);
  EffectSet effects;
  EXPECT_TRUE(effects.empty());
  effects.backlash_deg = Vec3::Zero();
  EXPECT_EQ(effects.names(), std::vector<std::string>{"backlash"});
}

}  // namespace
}  // namespace delta
