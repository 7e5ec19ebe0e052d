// Training of a complete model (network or hybrid) from a recording, with provenance.
#include "delta/nn/model_training.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "delta/effect_file.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/trained_model.hpp"

namespace delta::nn {

ModelTraining train_model(const Recording& recording, const std::string& model, const TrainingOptions& options,
                          const std::function<void(const TrainingEpoch&)>& progress) {
  if (model != "network" && model != "hybrid") {
    throw std::invalid_argument("unknown model '" + model + "' (choose network or hybrid)");
  }
  ModelTraining result;
  result.weights.model = model;
  std::vector<Vec3> inputs, targets;
  for (const Sample& sample : recording.samples) {
    inputs.push_back(sample.position_m);
    targets.push_back(sample.alpha_deg);
  }
  // What the data cannot support (too few rows, an axis that does not vary, a pose the math
  // model cannot reach) is a fault of the recording: name it.
  try {
    if (model == "hybrid") {
      result.effect_fit = fit_math_model_effects(recording.samples);
      // The network learns what the identified model, backlash included, leaves: a residual that
      // depends on the pose alone. The weights file keeps the pose-wise effects (no backlash).
      const std::vector<Vec3> predicted = predict_recording(result.effect_fit->effects, recording.samples);
      for (std::size_t i = 0; i < inputs.size(); ++i) targets[i] -= predicted[i];
      result.weights.effects = result.effect_fit->effects;
      result.weights.effects.backlash_deg.reset();
    }
    result.training = train_network(inputs, targets, options, progress);
  } catch (const std::invalid_argument& error) {
    throw InputError(recording.path, 0, error.what());
  }
  result.weights.network = result.training.network;
  const TrainingResult& training = result.training;
  nlohmann::json& provenance = result.weights.provenance;
  provenance["tool"] = "deltactl train";
  provenance["data"] = recording.path;
  provenance["samples"] = recording.samples.size();
  provenance["seed"] = options.seed;
  provenance["hidden"] = options.hidden;
  provenance["max_epochs"] = options.max_epochs;
  provenance["validation_fraction"] = options.validation_fraction;
  provenance["training_samples"] = training.training_samples;
  provenance["validation_samples"] = training.validation_samples;
  provenance["epochs"] = training.epochs;
  provenance["best_epoch"] = training.best_epoch;
  provenance["stop_reason"] = training.stop_reason;
  provenance["training_mse_deg2"] = training.training_mse_deg2;
  provenance["validation_mse_deg2"] = training.validation_mse_deg2;
  if (result.effect_fit) {
    const Vec3& before = result.effect_fit->rmse_before_deg;
    const Vec3& after = result.effect_fit->rmse_after_deg;
    provenance["math_model_rmse_nominal_deg"] = {before[0], before[1], before[2]};
    provenance["math_model_rmse_fitted_deg"] = {after[0], after[1], after[2]};
    const Vec3& backlash = *result.effect_fit->effects.backlash_deg;
    provenance["identified_backlash_deg"] = {backlash[0], backlash[1], backlash[2]};
  }
  return result;
}

std::string describe_epoch(const TrainingEpoch& epoch) {
  char line[200];
  std::snprintf(line, sizeof line,
                "epoch %4d  mse %.4e deg^2 (rmse %.5f deg)  validation %.4e (rmse %.5f)  mu %.1e  |J'e| %.3e",
                epoch.epoch, epoch.training_mse_deg2, std::sqrt(epoch.training_mse_deg2), epoch.validation_mse_deg2,
                std::sqrt(epoch.validation_mse_deg2), epoch.mu, epoch.gradient_norm);
  return line;
}

}  // namespace delta::nn
