// Tests of the diagnosis model: same arithmetic as the virtual robot, exact derivatives, gauge fixing.
#include <gtest/gtest.h>

#include <random>

#include "delta/diagnosis/effect_model.hpp"
#include "delta/diagnosis/fit.hpp"

#include <Eigen/LU>
#include <unsupported/Eigen/AutoDiff>

namespace delta::diagnosis {
namespace {

constexpr std::uint64_t kSeed = 20261121;

// A robot with every library effect at a realistic size.
EffectSet every_effect() {
  EffectSet effects;
  effects.joint_offset_deg = Vec3(0.4, -0.3, 0.2);
  effects.upper_arm_length_m = Vec3(0.2e-3, -0.1e-3, 0.15e-3);
  effects.lower_arm_length_m = Vec3(-0.3e-3, 0.2e-3, 0.1e-3);
  effects.radius_offset_m = Vec3(0.1e-3, 0.2e-3, -0.2e-3);
  effects.chain_angle_deg = Vec3(0.2, -0.1, 0.3);
  FrameMisalignment frame;
  frame.rotation_deg = Vec3(0.2, -0.3, 0.1);
  frame.translation_m = Vec3(0.3e-3, -0.2e-3, 0.1e-3);
  effects.frame_misalignment = frame;
  effects.backlash_deg = Vec3(0.2, 0.05, 0.1);
  TransmissionError transmission;
  transmission.amplitude_deg = Vec3(0.03, 0.02, 0.04);
  transmission.period_deg = Vec3(7.0, 11.0, 5.0);
  transmission.phase_rad = Vec3(0.5, 2.0, -1.0);
  effects.transmission_error = transmission;
  effects.encoder_scale = Vec3(0.004, -0.002, 0.003);
  return effects;
}

std::vector<Sample> record(const EffectSet& effects, std::size_t samples, std::uint64_t seed = 5) {
  RecordingOptions options;
  options.samples = samples;
  return VirtualRobot(effects).record(make_trajectory("sweep", seed), options).samples;
}

TEST(DiagnosisModel, BacklashStateIsTheSimBacklashBitForBit) {
  std::cout << "seed " << kSeed << '\n';
  std::mt19937_64 generator(kSeed);
  std::normal_distribution<double> step(0.0, 0.05);
  for (double width : {0.0, 0.07, 0.3}) {
    Backlash reference(width);
    BacklashState<double> ours;
    double input = 30.0;
    for (int i = 0; i < 20000; ++i) {
      input += step(generator);
      ASSERT_EQ(ours.update(input, width), reference.update(input)) << "row " << i << " width " << width;
    }
  }
}

TEST(DiagnosisModel, ScaleAndTransmissionMatchesTheSimBitForBit) {
  for (double alpha : {-10.0, 0.0, 23.7, 41.25}) {
    EXPECT_EQ(scale_and_transmission_all<double>(alpha, 0.003, 0.04, 7.5, 1.2, true),
              scale_and_transmission(alpha, 0.003, 0.04, 7.5, 1.2));
    EXPECT_EQ(scale_and_transmission_all<double>(alpha, -0.002, 0.0, 360.0, 0.0, false),
              scale_and_transmission(alpha, -0.002, 0.0, 360.0, 0.0));
  }
}

TEST(DiagnosisModel, ModelWithTheTrueEffectsReproducesTheRecordingToQuantisation) {
  const EffectSet effects = every_effect();
  const std::vector<Sample> rows = record(effects, 3000);
  ASSERT_EQ(rows.size(), 3000u);
  const Prediction prediction = predict_recording(effects, rows);
  ASSERT_EQ(prediction.unreachable, 0u);
  const Parameters theta = from_effect_set(effects);
  const FamilySet families = families_of(effects);
  ASSERT_EQ(families.count(), 9u);
  for (int j = 0; j < 3; ++j) {
    std::array<double, kLocalCount> local;
    const auto map = local_parameters(j);
    for (int k = 0; k < kLocalCount; ++k) local[k] = theta[map[k]];
    ASSERT_TRUE(predict_joint<double>(local, families, j, rows, [&](std::size_t i, double predicted) {
      // Half an encoder count of quantisation, plus rounding of the recorded position (6.87 nm).
      ASSERT_LE(std::abs(rows[i].alpha_deg[j] - predicted), 0.005 + 1e-5) << "joint " << j << " row " << i;
      // The templated path and the sim's own code agree to rounding.
      ASSERT_NEAR(predicted, prediction.alpha_deg[i][j], 1e-9) << "joint " << j << " row " << i;
    }));
  }
}

TEST(DiagnosisModel, AutodiffJacobianMatchesCentralDifferences) {
  using Dual = Eigen::AutoDiffScalar<Eigen::Matrix<double, kLocalCount, 1>>;
  const EffectSet effects = every_effect();
  const std::vector<Sample> rows = record(effects, 400);
  const Parameters theta = from_effect_set(effects);
  const FamilySet families = families_of(effects);
  for (int j = 0; j < 3; ++j) {
    const auto map = local_parameters(j);
    std::array<Dual, kLocalCount> local;
    for (int k = 0; k < kLocalCount; ++k) local[k] = Dual(theta[map[k]], kLocalCount, k);
    std::vector<Eigen::Matrix<double, kLocalCount, 1>> derivatives;
    predict_joint<Dual>(local, families, j, rows,
                        [&](std::size_t, const Dual& p) { derivatives.push_back(p.derivatives()); });
    for (int k = 0; k < kLocalCount; ++k) {
      auto predict_with = [&](double delta) {
        std::array<double, kLocalCount> values;
        for (int m = 0; m < kLocalCount; ++m) values[m] = theta[map[m]] + (m == k ? delta : 0.0);
        std::vector<double> out;
        predict_joint<double>(values, families, j, rows, [&](std::size_t, double p) { out.push_back(p); });
        return out;
      };
      const double h = 1e-6 * std::max(1.0, std::abs(theta[map[k]]));
      const std::vector<double> plus = predict_with(h), minus = predict_with(-h);
      for (std::size_t i = 0; i < rows.size(); i += 37) {
        const double numeric = (plus[i] - minus[i]) / (2.0 * h);
        // Backlash switches state at a few rows; away from those the derivative is smooth.
        if (std::abs(numeric - derivatives[i][k]) > 1e-4 * std::max(1.0, std::abs(numeric))) {
          ADD_FAILURE() << "joint " << j << " parameter " << parameter_table()[map[k]].name << " row " << i
                        << ": autodiff " << derivatives[i][k] << " vs central difference " << numeric;
        }
      }
    }
  }
}

TEST(DiagnosisModel, FitRecoversInjectedParameters) {
  EffectSet effects;
  effects.backlash_deg = Vec3(0.2, 0.0, 0.1);
  effects.joint_offset_deg = Vec3(0.3, -0.5, 0.1);
  effects.lower_arm_length_m = Vec3(0.3e-3, -0.2e-3, 0.1e-3);
  const std::vector<Sample> rows = record(effects, 4000);
  const FamilySet families = families_of(effects);
  const FitResult fit = fit_model(rows, families, neutral_parameters(), neutral_parameters());
  ASSERT_TRUE(fit.ok);
  const Parameters truth = from_effect_set(effects);
  // Offsets and lower-arm lengths trade off inside the 10 mm cube; judge each parameter against
  // its standard error from J^T J at the quantisation noise floor.
  const std::vector<int> active = parameter_indices(families);
  Eigen::MatrixXd information(active.size(), active.size());
  for (std::size_t a = 0; a < active.size(); ++a) {
    for (std::size_t b = 0; b < active.size(); ++b) information(a, b) = fit.jtj(active[a], active[b]);
  }
  const Eigen::MatrixXd covariance = information.inverse() * (0.01 * 0.01 / 12.0);
  for (std::size_t a = 0; a < active.size(); ++a) {
    const double standard_error = std::sqrt(covariance(a, a));
    EXPECT_LT(standard_error, 0.02) << parameter_table()[active[a]].name;  // deg or mm: well determined
    EXPECT_NEAR(fit.theta[active[a]], truth[active[a]], 5.0 * standard_error + 1e-6)
        << parameter_table()[active[a]].name;
  }
  EXPECT_LT(fit.fit_rmse_deg.maxCoeff(), 0.00300);
}

TEST(DiagnosisModel, GaugeFreedomsDoNotDrift) {
  // Only a frame yaw: chain_angle and frame_misalignment together could share it in any split.
  EffectSet effects;
  FrameMisalignment frame;
  frame.rotation_deg = Vec3(0.0, 0.0, 0.4);
  effects.frame_misalignment = frame;
  const std::vector<Sample> rows = record(effects, 3000);
  FamilySet families = single(Family::chain_angle) | single(Family::frame_misalignment);
  const FitResult fit = fit_model(rows, families, neutral_parameters(), neutral_parameters());
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.theta.segment<3>(slot::chain_angle).sum(), 0.0, 1e-6);
  EXPECT_NEAR(fit.theta[slot::frame_rotation + 2], 0.4, 2e-3);
  // A nominal robot fitted with every geometric family at once: parameters may only move along
  // directions the data cannot see, so the predictions stay those of the nominal model.
  const std::vector<Sample> nominal_rows = record(EffectSet{}, 3000);
  FamilySet geometry = single(Family::joint_offset) | single(Family::upper_arm_length) |
                       single(Family::lower_arm_length) | single(Family::radius_offset) | single(Family::chain_angle) |
                       single(Family::frame_misalignment) | single(Family::encoder_scale);
  const FitResult nominal_fit = fit_model(nominal_rows, geometry, neutral_parameters(), neutral_parameters());
  ASSERT_TRUE(nominal_fit.ok);
  const std::vector<Sample> check_rows = record(EffectSet{}, 2000, 6);
  const Prediction nominal = predict_recording(EffectSet{}, check_rows);
  const Prediction fitted = predict_recording(to_effect_set(nominal_fit.theta, geometry), check_rows);
  double largest = 0.0;
  for (std::size_t i = 0; i < check_rows.size(); ++i) {
    largest = std::max(largest, (nominal.alpha_deg[i] - fitted.alpha_deg[i]).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(largest, 0.003) << "the over-complete fit changed held-out predictions";
  for (int k : parameter_indices(geometry)) {
    EXPECT_LT(std::abs(nominal_fit.theta[k]), 0.5 * parameter_table()[k].typical) << parameter_table()[k].name;
  }
}

}  // namespace
}  // namespace delta::diagnosis
