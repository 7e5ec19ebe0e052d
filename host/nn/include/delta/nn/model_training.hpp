// From a recording to a complete weights file, with provenance: the pure network; the hybrid (fit
// the math-model effects, then train the network on the remaining residual); or the deployed model
// (fit the same effects, train the network on the recording without the identified backlash, keep
// the identified half-play for the time-ordered compensation).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "delta/nn/effect_fit.hpp"
#include "delta/nn/training.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/recording.hpp"

namespace delta::nn {

// What the identified math model leaves of one joint's angles, as a function of that angle (in
// bins of a quarter degree, a straight line removed): its RMS over the joint's travel and, where it
// crosses zero twice or more, its period (twice the mean spacing of the crossings). A transmission
// ripple shows here; a network of tanh ridges in x, y, z cannot follow one much shorter than the
// joint's travel (docs/lab_loop.md).
struct ResidualRipple {
  double rms_deg = 0.0;
  double period_deg = 0.0;  // 0: fewer than two zero crossings
  int crossings = 0;
};

// Per joint, for the math model's angles model_deg and the recorded (static) angles targets_deg.
std::array<ResidualRipple, 3> residual_ripple(const std::vector<Vec3>& model_deg, const std::vector<Vec3>& targets_deg);

struct ModelTraining {
  WeightsFile weights;
  TrainingResult training;
  std::optional<EffectFit> effect_fit;  // hybrid and deployed
  // Deployed: the encoder floor read from the recording (its quantisation step / sqrt(12), 0 if
  // the readings are not on a grid: no restart then) and, when the first training stalled above kStallFloors of it,
  // the seed of the one restart (the better of the two by validation error is kept).
  double floor_deg = 0.0;
  std::optional<std::uint64_t> restart_seed;
  bool restart_kept = false;  // the restart's weights were better (and are the result)
  // Deployed: the network's RMSE per joint on the recording's rows it learnt from (the recorded
  // angles without the identified play; degrees), and what the math model leaves per joint.
  Vec3 recording_rmse_deg = Vec3::Zero();
  std::array<ResidualRipple, 3> ripple{};
};

// A deployed network whose validation RMSE ends above this many encoder floors stalled in a slow
// valley (1 seed in 4 on the paper-like robot ends at 1.8 floors, the others at 1.2-1.4): it is
// trained once more from another seed.
constexpr double kStallFloors = 1.5;
constexpr std::uint64_t kRestartSeedOffset = 1'000'000'007;

// model: "deployed", "network" or "hybrid" (std::invalid_argument otherwise).
ModelTraining train_model(const Recording& recording, const std::string& model, const TrainingOptions& options,
                          const std::function<void(const TrainingEpoch&)>& progress = {});

// One progress line: epoch, training and validation MSE (deg^2) and RMSE (deg), damping, gradient.
std::string describe_epoch(const TrainingEpoch& epoch);

}  // namespace delta::nn
