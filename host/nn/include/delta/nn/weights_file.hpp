// W.json: the versioned weights file of a trained inverse-kinematics model (network, hybrid or
// deployed).
//
// Three model kinds, chosen by "model":
//   "network": alpha_deg = network.evaluate(position_m)                       (the paper's net)
//   "deployed" (version 2): the static angle s = network.evaluate(position_m), trained on targets
//              from which the identified backlash was removed, then, for positions in time order
//              (rows of a recording, setpoints of the board), each joint passes a play of the
//              identified half-width h_j: the first angle passes unchanged; afterwards the output
//              holds until s leaves [out - h, out + h] and then follows at s -/+ h. This is what the
//              encoder reads when the plate is at the pose (it lags the static angle by h in the
//              direction of motion), so it is the joint reference that puts the plate there.
//              Without time order (a pose alone) the model is s.
//              Version 3 adds an optional joint ripple table r_j (what each joint carries beyond a
//              smooth function of the pose: a transmission ripple shorter than a network of tanh
//              ridges can follow). Then the static angle is s = N(p') for the shaped position p'
//              that solves N(p') = N(p) + r(N(p)) (shape_setpoint, trained_model.hpp): the host
//              shapes every setpoint it sends, so the board's network answers with the ripple in.
//   "hybrid":  alpha_deg = math_model(effects, position_m) + network.evaluate(position_m)
//              where math_model is the closed-form inverse kinematics of the nominal geometry with
//              the identified geometric effects applied (delta::apply_geometry_effects) plus
//              joint_offset; the network's output is the residual correction in degrees.
// A fixed-point back end evaluating a hybrid file implements the network part only: its outputs
// are then the residual, and the math model is added by whoever owns it.
//
// Text layout (version 1; version 2 only for "deployed", which adds "compensation"; version 3 only
// for a deployed model with a joint ripple table), one key per line, numbers as
// shortest round-trip decimals so that the same weights always give the same bytes:
//   { "format": "delta-nn-weights", "version": 1 | 2, "model": "network" | "hybrid" | "deployed",
//     "hidden": H,
//     "input_min": [3] (m), "input_max": [3] (m), "output_min": [3] (deg), "output_max": [3] (deg),
//     "input_weights": [H rows of 3] (IW{1,1}), "hidden_bias": [H] (b{1}),
//     "output_weights": [3 rows of H] (LW{2,1}), "output_bias": [3] (b{2}),
//     "effects": {effect file object, docs/contracts.md} (hybrid only),
//     "compensation": {"backlash_half_play_deg": [3] (h_j, >= 0),
//                      "joint_ripple": {"bin_deg": b, "first_deg": [3], "values_deg": [3 arrays]}
//                        (optional, version 3: r_j at angles first_deg[j] + k b, linear between
//                        entries, the end entries beyond)}
//                     (deployed only; any other key is refused: a reader must not run a model it
//                     cannot apply),
//     "provenance": {"tool", "data", "samples", "seed", "hidden", "epochs", "stop_reason",
//                    "training_mse_deg2", "validation_mse_deg2", ...} }
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "delta/effects.hpp"
#include "delta/nn/network.hpp"

namespace delta::nn {

// The newest version this build reads and writes; network and hybrid files stay version 1 (the
// same bytes as before), a deployed model needs version 2.
constexpr int kWeightsFileVersion = 3;
constexpr int kFirstWeightsFileVersion = 1;
// Largest half-play a deployed model may carry, degrees (a play wider than this is not backlash).
constexpr double kMaxBacklashHalfPlayDeg = 2.0;
// Largest joint ripple entry, degrees, and most entries per joint (a quarter-degree table over 500 deg).
constexpr double kMaxJointRippleDeg = 0.25;
constexpr std::size_t kMaxJointRippleEntries = 2000;
// Steepest joint ripple table, degrees of entry per degree of joint angle: successive entries
// differ by at most kMaxJointRippleSlope * bin_deg. The shaping moves a joint by r(alpha) on top of
// the path, so its speed is at most (1 + slope) times the path's and a table cannot chatter (the
// shipped tables reach 0.025; a ripple of amplitude A and period P has a slope 2 pi A / P: 0.25
// allows 0.05 deg at 1.25 deg, 0.25 deg at 6.3 deg). The plan check then checks the shaped joints.
constexpr double kMaxJointRippleSlope = 0.25;
// Most hidden neurons a weights file may have: checked when reading, writing and importing.
constexpr long long kMaxHiddenNeurons = 10000;

// A deployed model's joint ripple table (version 3): per joint, values at equally spaced angles.
struct JointRippleTable {
  double bin_deg = 0.0;
  Vec3 first_deg = Vec3::Zero();                  // the angle of each joint's first entry
  std::array<std::vector<double>, 3> values_deg;  // empty: no table
  bool empty() const { return values_deg[0].empty(); }
  // r_j at alpha_deg: linear between entries, the first or last entry beyond them.
  double at(int joint, double alpha_deg) const;
  Vec3 at(const Vec3& alpha_deg) const;
};

struct WeightsFile {
  std::string model = "network";  // "network", "hybrid" or "deployed"
  Network network;    // full angles ("network", "deployed": the static part) or residual ("hybrid"), degrees
  EffectSet effects;  // hybrid: the identified math-model effects (memoryless ones only)
  Vec3 backlash_half_play_deg = Vec3::Zero();            // deployed: h_j of the time-ordered compensation
  JointRippleTable joint_ripple;                         // deployed, optional: the setpoints' shaping
  nlohmann::json provenance = nlohmann::json::object();  // how it was made (free-form, deterministic)

  bool hybrid() const { return model == "hybrid"; }
  bool deployed() const { return model == "deployed"; }
  // The file format version this model needs (written as such).
  int version() const { return deployed() ? (joint_ripple.empty() ? 2 : 3) : 1; }
};

// Throws delta::InputError(file, line, reason): unreadable file, bad JSON, wrong format or version,
// unknown model kind, wrong shapes, non-finite values, an empty or inverted scaling range,
// effects a pose-wise model cannot apply (backlash, which needs the direction of motion), or a
// compensation this build cannot apply (an unknown key, a negative or too wide half-play).
WeightsFile read_weights_file(const std::string& path);

// Parses an already-read text; `path` names it in errors.
WeightsFile parse_weights_file(const std::string& text, const std::string& path);

// Deterministic text of the layout above.
std::string weights_file_text(const WeightsFile& weights);

// Writes atomically (delta::OutputFile): no partial file on failure. Throws InputError naming the
// path for a network larger than kMaxHiddenNeurons, which no reader would accept.
void write_weights_file(const std::string& path, const WeightsFile& weights);

}  // namespace delta::nn
