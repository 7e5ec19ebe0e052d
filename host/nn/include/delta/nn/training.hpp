// Training of the 3-H-3 tanh network by Levenberg-Marquardt on the sum of squared output errors
// (degrees), with a seeded validation split, early stopping and a multithreaded analytic Jacobian.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "delta/geometry.hpp"
#include "delta/nn/levenberg_marquardt.hpp"
#include "delta/nn/network.hpp"

namespace delta::nn {

// Fewest samples a network is trained on (train_network refuses fewer).
constexpr std::size_t kMinTrainingSamples = 10;

struct TrainingOptions {
  int hidden = 25;
  std::uint64_t seed = 1;             // initial weights (Nguyen-Widrow) and the validation split
  int max_epochs = 1000;              // MATLAB trainlm default
  double validation_fraction = 0.15;  // share of samples held out of the fit for early stopping
  int max_validation_failures = 6;    // MATLAB's max_fail: epochs in a row without a better validation error
  int plateau_epochs = 25;            // converged: training SSE fell by < plateau_fraction over this many epochs
  double plateau_fraction = 0.01;
  int threads = 0;  // 0: all cores. The result does not depend on it.
  // Deployed model (train_model): a joint ripple table when the math model leaves a ripple.
  bool joint_ripple_table = true;
};

struct TrainingEpoch {
  int epoch = 0;
  double training_mse_deg2 = 0.0;  // mean over samples and joints
  double validation_mse_deg2 = 0.0;
  double mu = 0.0;
  double gradient_norm = 0.0;
};

struct TrainingResult {
  Network network;                   // the weights with the best validation error
  int epochs = 0;                    // epochs run
  int best_epoch = 0;                // epoch of the returned weights
  std::string stop_reason;           // max_epochs, plateau, validation (early stop), mu_max, min_gradient
  double training_mse_deg2 = 0.0;    // of the returned weights
  double validation_mse_deg2 = 0.0;  // of the returned weights
  std::size_t training_samples = 0;
  std::size_t validation_samples = 0;
};

// Parameter vector in MATLAB getwb order: [b1; IW(:); b2; LW(:)] (column-major), 7 H + 3 values.
Eigen::VectorXd network_parameters(const Network& network);
void set_network_parameters(Network& network, const Eigen::VectorXd& parameters);

// mapminmax ranges from the data, Nguyen-Widrow initial weights from the seed.
Network initial_network(const std::vector<Vec3>& inputs_m, const std::vector<Vec3>& targets_deg, int hidden,
                        std::uint64_t seed);

// The Levenberg-Marquardt normal equations of the fit in degrees at the network's weights, in
// network_parameters order (what each epoch solves; exposed for tests of the analytic Jacobian).
LeastSquaresProblem::NormalEquations network_normal_equations(const Network& network, const std::vector<Vec3>& inputs_m,
                                                              const std::vector<Vec3>& targets_deg, int threads);

// Fits targets_deg (joint angles, or residual angles for a hybrid) from inputs_m (plate positions).
// Throws std::invalid_argument for fewer than 10 samples or mismatched sizes.
TrainingResult train_network(const std::vector<Vec3>& inputs_m, const std::vector<Vec3>& targets_deg,
                             const TrainingOptions& options,
                             const std::function<void(const TrainingEpoch&)>& progress = {});

}  // namespace delta::nn
