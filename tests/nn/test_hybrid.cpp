// The hybrid model: effect identification of the math model and pose-wise evaluation.
#include <gtest/gtest.h>

#include "delta/model_error.hpp"
#include "delta/nn/effect_fit.hpp"
#include "delta/nn/trained_model.hpp"
#include "nn_test_data.hpp"
#include "support/tree_paths.hpp"

namespace delta::nn {
namespace {

TEST(EffectFit, IdentifiedMathModelReachesTheEncoderFloorWithoutUnmodelledEffects) {
  // Only effects the hybrid's math model contains: the fit must bring it to the quantisation
  // floor (0.01 deg encoder counts: RMSE 0.0029 deg), from errors of hundredths to tenths of a degree.
  EffectSet effects;
  effects.joint_offset_deg = Vec3(0.4, -0.3, 0.2);
  effects.chain_angle_deg = Vec3(-0.5, 0.3, 0.6);
  effects.lower_arm_length_m = Vec3(0.0003, -0.0002, 0.0001);
  const std::vector<Sample> samples = test::record("validation", effects, 1200);
  const EffectFit fit = fit_math_model_effects(samples);
  std::printf("RMSE nominal %.4f %.4f %.4f, fitted %.5f %.5f %.5f deg\n", fit.rmse_before_deg[0],
              fit.rmse_before_deg[1], fit.rmse_before_deg[2], fit.rmse_after_deg[0], fit.rmse_after_deg[1],
              fit.rmse_after_deg[2]);
  for (int j = 0; j < 3; ++j) EXPECT_GT(fit.rmse_before_deg[j], 5.0 * fit.rmse_after_deg[j]);
  EXPECT_LT(fit.rmse_after_deg.maxCoeff(), 0.0035);
}

TEST(TrainedModel, HybridIsTheMathModelPlusTheNetwork) {
  WeightsFile weights;
  weights.model = "hybrid";
  weights.effects.joint_offset_deg = Vec3(0.5, -0.25, 1.0);
  weights.network.input_weights = Eigen::MatrixXd::Constant(2, 3, 0.3);
  weights.network.hidden_bias = Eigen::VectorXd::Constant(2, 0.1);
  weights.network.output_weights = Eigen::MatrixXd::Constant(3, 2, 0.2);
  weights.network.input_min = Vec3(-0.005, -0.005, -0.081);
  weights.network.input_max = Vec3(0.005, 0.005, -0.07);
  const Vec3 position(0.001, -0.002, -0.075);
  const IkSolution hybrid = evaluate_model(weights, position);
  const IkSolution nominal = inverse_kinematics(Geometry::nominal(), position);
  ASSERT_TRUE(hybrid.ok() && nominal.ok());
  const Vec3 expected = nominal.alpha_deg + *weights.effects.joint_offset_deg + weights.network.evaluate(position);
  EXPECT_LT((hybrid.alpha_deg - expected).cwiseAbs().maxCoeff(), 1e-12);
  // An unreachable pose is an error, never NaN.
  EXPECT_FALSE(evaluate_model(weights, Vec3(0.0, 0.0, -0.5)).ok());
  weights.model = "network";
  EXPECT_EQ(evaluate_model(weights, position).alpha_deg, weights.network.evaluate(position));
}

}  // namespace
}  // namespace delta::nn

namespace delta::nn {
namespace {

// The shipped weights (weights/README.md) on a sweep they never saw. Tolerance: the paper's NN
// column of Table 1 (0.1655, 0.0616, 0.0576 deg) for both; the hybrid also below the pose-wise
// floor plus a margin (half the 0.15 deg backlash of joint 1, 0.03 deg on the others).
TEST(ShippedWeights, BeatThePaperOnAHeldOutSweep) {
  const std::vector<Sample> check = test::record("sweep", test::paper_like_effects(), 2000, 7);
  for (const char* name : {"paper_like.json", "paper_like_hybrid.json"}) {
    SCOPED_TRACE(name);
    const WeightsFile weights = read_weights_file(std::string(DELTA_SOURCE_DIR) + "/weights/" + name);
    std::vector<Vec3> measured, predicted;
    for (const Sample& s : check) {
      const IkSolution solution = evaluate_model(weights, s.position_m);
      ASSERT_TRUE(solution.ok()) << solution.reason();
      measured.push_back(s.alpha_deg);
      predicted.push_back(solution.alpha_deg);
    }
    const Vec3 rmse = joint_error_stats(measured, predicted).rmse_deg;
    std::printf("%s: held-out RMSE %.4f %.4f %.4f deg\n", name, rmse[0], rmse[1], rmse[2]);
    EXPECT_LT(rmse[0], 0.1655);
    EXPECT_LT(rmse[1], 0.0616);
    EXPECT_LT(rmse[2], 0.0576);
    if (weights.hybrid()) {
      EXPECT_LT(rmse.maxCoeff(), 0.08);
    }
  }
}

}  // namespace
}  // namespace delta::nn
