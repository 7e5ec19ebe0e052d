// From a recording to a complete weights file, with provenance: the pure network; the hybrid (fit
// the math-model effects, then train the network on the remaining residual); or the deployed model
// (fit the same effects, train the network on the recording without the identified backlash, keep
// the identified half-play for the time-ordered compensation).
#pragma once

#include <functional>
#include <optional>
#include <string>

#include "delta/nn/effect_fit.hpp"
#include "delta/nn/training.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/recording.hpp"

namespace delta::nn {

struct ModelTraining {
  WeightsFile weights;
  TrainingResult training;
  std::optional<EffectFit> effect_fit;  // hybrid and deployed
};

// model: "deployed", "network" or "hybrid" (std::invalid_argument otherwise).
ModelTraining train_model(const Recording& recording, const std::string& model, const TrainingOptions& options,
                          const std::function<void(const TrainingEpoch&)>& progress = {});

// One progress line: epoch, training and validation MSE (deg^2) and RMSE (deg), damping, gradient.
std::string describe_epoch(const TrainingEpoch& epoch);

}  // namespace delta::nn
