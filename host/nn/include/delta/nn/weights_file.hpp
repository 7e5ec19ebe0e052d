// W.json: the versioned weights file of a trained inverse-kinematics model (pure network or hybrid).
//
// Two model kinds, chosen by "model":
//   "network": alpha_deg = network.evaluate(position_m)                       (the paper's net)
//   "hybrid":  alpha_deg = math_model(effects, position_m) + network.evaluate(position_m)
//              where math_model is the closed-form inverse kinematics of the nominal geometry with
//              the identified geometric effects applied (delta::apply_geometry_effects) plus
//              joint_offset; the network's output is the residual correction in degrees.
// A fixed-point back end evaluating a hybrid file implements the network part only: its outputs
// are then the residual, and the math model is added by whoever owns it.
//
// Text layout (version 1), one key per line, numbers as shortest round-trip decimals so that the
// same weights always give the same bytes:
//   { "format": "delta-nn-weights", "version": 1, "model": "network" | "hybrid",
//     "hidden": H,
//     "input_min": [3] (m), "input_max": [3] (m), "output_min": [3] (deg), "output_max": [3] (deg),
//     "input_weights": [H rows of 3] (IW{1,1}), "hidden_bias": [H] (b{1}),
//     "output_weights": [3 rows of H] (LW{2,1}), "output_bias": [3] (b{2}),
//     "effects": {effect file object, shared/SPEC.md} (hybrid only),
//     "provenance": {"tool", "data", "samples", "seed", "hidden", "epochs", "stop_reason",
//                    "training_mse_deg2", "validation_mse_deg2", ...} }
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "delta/effects.hpp"
#include "delta/nn/network.hpp"

namespace delta::nn {

constexpr int kWeightsFileVersion = 1;
// Most hidden neurons a weights file may have: checked when reading, writing and importing.
constexpr long long kMaxHiddenNeurons = 10000;

struct WeightsFile {
  std::string model = "network";  // "network" or "hybrid"
  Network network;                // full angles ("network") or residual angles ("hybrid"), degrees
  EffectSet effects;              // hybrid: the identified math-model effects (memoryless ones only)
  nlohmann::json provenance = nlohmann::json::object();  // how it was made (free-form, deterministic)

  bool hybrid() const { return model == "hybrid"; }
};

// Throws delta::InputError(file, line, reason): unreadable file, bad JSON, wrong format or version,
// unknown model kind, wrong shapes, non-finite values, an empty or inverted scaling range, or
// effects a pose-wise model cannot apply (backlash, which needs the direction of motion).
WeightsFile read_weights_file(const std::string& path);

// Parses an already-read text; `path` names it in errors.
WeightsFile parse_weights_file(const std::string& text, const std::string& path);

// Deterministic text of the layout above.
std::string weights_file_text(const WeightsFile& weights);

// Writes atomically (delta::OutputFile): no partial file on failure. Throws InputError naming the
// path for a network larger than kMaxHiddenNeurons, which no reader would accept.
void write_weights_file(const std::string& path, const WeightsFile& weights);

}  // namespace delta::nn
