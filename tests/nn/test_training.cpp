// Levenberg-Marquardt and network training: convergence, the analytic normal equations against
// finite differences, determinism (seed and thread count), accuracy on a small recording.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

#include "delta/model_error.hpp"
#include "delta/nn/levenberg_marquardt.hpp"
#include "delta/nn/training.hpp"
#include "delta/nn/weights_file.hpp"
#include "nn_test_data.hpp"

namespace delta::nn {
namespace {

// y = a exp(b t) sampled at 20 points; a Gauss-Newton step alone diverges from the start (0.1, 0).
class ExponentialFit : public LeastSquaresProblem {
 public:
  ExponentialFit() {
    for (int i = 0; i < 20; ++i) {
      t_.push_back(0.25 * i);
      y_.push_back(2.0 * std::exp(-0.7 * 0.25 * i));
    }
  }
  double sum_squared_error(const Eigen::VectorXd& x) override {
    double sse = 0.0;
    for (std::size_t i = 0; i < t_.size(); ++i) sse += std::pow(y_[i] - x[0] * std::exp(x[1] * t_[i]), 2);
    return sse;
  }
  NormalEquations normal_equations(const Eigen::VectorXd& x) override {
    Eigen::MatrixXd jacobian(t_.size(), 2);
    Eigen::VectorXd errors(t_.size());
    for (std::size_t i = 0; i < t_.size(); ++i) {
      const double e = std::exp(x[1] * t_[i]);
      jacobian.row(static_cast<Eigen::Index>(i)) << e, x[0] * t_[i] * e;
      errors[static_cast<Eigen::Index>(i)] = y_[i] - x[0] * e;
    }
    return {jacobian.transpose() * jacobian, jacobian.transpose() * errors};
  }

 private:
  std::vector<double> t_, y_;
};

TEST(LevenbergMarquardt, ReducesTheErrorToTheExactFit) {
  ExponentialFit problem;
  const Eigen::Vector2d start(0.1, 0.0);
  const double initial = problem.sum_squared_error(start);
  LmOptions options;
  options.max_epochs = 200;
  const LmResult result = levenberg_marquardt(problem, start, options);
  EXPECT_LT(result.sse, 1e-20 * initial) << "stopped by " << result.stop_reason << " after " << result.epochs;
  EXPECT_NEAR(result.x[0], 2.0, 1e-9);
  EXPECT_NEAR(result.x[1], -0.7, 1e-9);
}

TEST(Training, AnalyticNormalEquationsMatchFiniteDifferences) {
  const std::uint64_t seed = 5;
  std::printf("seed %llu\n", static_cast<unsigned long long>(seed));
  const std::vector<Sample> samples = test::record("sweep", test::paper_like_effects(), 300, seed);
  std::vector<Vec3> inputs, targets;
  for (const Sample& s : samples) {
    inputs.push_back(s.position_m);
    targets.push_back(s.alpha_deg);
  }
  const Network network = initial_network(inputs, targets, 4, seed);
  const auto equations = network_normal_equations(network, inputs, targets, 2);
  // Central differences of the predictions give J; build J^T J and J^T e the plain way.
  const Eigen::VectorXd x = network_parameters(network);
  Eigen::MatrixXd jacobian(3 * inputs.size(), x.size());
  Eigen::VectorXd errors(3 * inputs.size());
  for (Eigen::Index p = 0; p < x.size(); ++p) {
    Network plus = network, minus = network;
    Eigen::VectorXd shifted = x;
    shifted[p] += 1e-6;
    set_network_parameters(plus, shifted);
    shifted[p] -= 2e-6;
    set_network_parameters(minus, shifted);
    for (std::size_t n = 0; n < inputs.size(); ++n) {
      jacobian.block(3 * static_cast<Eigen::Index>(n), p, 3, 1) =
          (plus.evaluate(inputs[n]) - minus.evaluate(inputs[n])) / 2e-6;
    }
  }
  for (std::size_t n = 0; n < inputs.size(); ++n) {
    errors.segment<3>(3 * static_cast<Eigen::Index>(n)) = targets[n] - network.evaluate(inputs[n]);
  }
  const Eigen::MatrixXd jtj = jacobian.transpose() * jacobian;
  const Eigen::VectorXd jte = jacobian.transpose() * errors;
  EXPECT_LT((equations.jtj - jtj).norm(), 1e-6 * jtj.norm());
  EXPECT_LT((equations.jte - jte).norm(), 1e-6 * jte.norm());
  EXPECT_EQ((equations.jtj - equations.jtj.transpose()).norm(), 0.0);
}

struct SmallSet {
  std::vector<Vec3> inputs, targets;
};

SmallSet small_set(std::size_t samples) {
  SmallSet set;
  for (const Sample& s : test::record("validation", test::paper_like_effects(), samples)) {
    set.inputs.push_back(s.position_m);
    set.targets.push_back(s.alpha_deg);
  }
  return set;
}

TEST(Training, SameSeedGivesBitIdenticalWeightsWithAnyThreadCount) {
  // 2500 samples: three blocks of the threaded sums, so the thread split matters.
  const SmallSet set = small_set(2500);
  TrainingOptions options;
  options.hidden = 8;
  options.max_epochs = 8;
  options.seed = 3;
  std::printf("seed %llu\n", static_cast<unsigned long long>(options.seed));
  options.threads = 1;
  const TrainingResult one = train_network(set.inputs, set.targets, options);
  options.threads = 2;
  const TrainingResult two = train_network(set.inputs, set.targets, options);
  options.threads = 3;
  const TrainingResult three = train_network(set.inputs, set.targets, options);
  WeightsFile a, b, c;
  a.network = one.network;
  b.network = two.network;
  c.network = three.network;
  EXPECT_EQ(weights_file_text(a), weights_file_text(b));
  EXPECT_EQ(weights_file_text(a), weights_file_text(c));
  const Eigen::VectorXd pa = network_parameters(one.network), pb = network_parameters(two.network);
  EXPECT_EQ(0, std::memcmp(pa.data(), pb.data(), sizeof(double) * pa.size()));
  options.seed = 4;
  const TrainingResult other = train_network(set.inputs, set.targets, options);
  EXPECT_NE(network_parameters(other.network), pa);
}

TEST(Training, LevenbergMarquardtReducesTheNetworkErrorManyFold) {
  const SmallSet set = small_set(1500);
  TrainingOptions options;
  options.hidden = 10;
  options.max_epochs = 20;
  std::printf("seed %llu\n", static_cast<unsigned long long>(options.seed));
  std::vector<TrainingEpoch> epochs;
  const TrainingResult result =
      train_network(set.inputs, set.targets, options, [&](const TrainingEpoch& e) { epochs.push_back(e); });
  ASSERT_EQ(static_cast<int>(epochs.size()), result.epochs);
  ASSERT_GE(epochs.size(), 2u);
  for (std::size_t i = 1; i < epochs.size(); ++i)
    EXPECT_LT(epochs[i].training_mse_deg2, epochs[i - 1].training_mse_deg2);
  // Initial weights are far off (degrees); 20 epochs bring the RMSE to hundredths of a degree.
  EXPECT_LT(std::sqrt(result.training_mse_deg2), 0.05);
  EXPECT_LT(100.0 * result.training_mse_deg2, epochs.front().training_mse_deg2);
}

TEST(Training, PaperLikeSmallRecordingBeatsThePaperOnHeldOutData) {
  // Tolerance: the paper's NN column of Table 1 (0.1655, 0.0616, 0.0576 deg) on a sweep the net never saw.
  const SmallSet set = small_set(3000);
  TrainingOptions options;
  options.max_epochs = 30;
  std::printf("seed %llu\n", static_cast<unsigned long long>(options.seed));
  const TrainingResult result = train_network(set.inputs, set.targets, options);
  const std::vector<Sample> check = test::record("sweep", test::paper_like_effects(), 1500, 7);
  std::vector<Vec3> measured, predicted;
  for (const Sample& s : check) {
    measured.push_back(s.alpha_deg);
    predicted.push_back(result.network.evaluate(s.position_m));
  }
  const Vec3 rmse = joint_error_stats(measured, predicted).rmse_deg;
  std::printf("held-out RMSE %.4f %.4f %.4f deg\n", rmse[0], rmse[1], rmse[2]);
  EXPECT_LT(rmse[0], 0.1655);
  EXPECT_LT(rmse[1], 0.0616);
  EXPECT_LT(rmse[2], 0.0576);
}

}  // namespace
}  // namespace delta::nn
