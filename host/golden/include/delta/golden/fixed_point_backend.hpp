// The fixed-point inverse-kinematics back end shared by `ik --backend fixed` (golden integer model)
// and `ik --backend hls` (HLS C simulation): raw output codes beside the angles (for a deployed
// model in time order: the compensated references), saturation counts in the report. Only the
// evaluator of raw codes and the compensation step differ between them.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "delta/golden/fixed_network.hpp"
#include "delta/ik_backend.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::golden {

using RawEvaluator = std::function<RawOutput(const std::array<std::int64_t, 3>&)>;
// The deployed model's compensation of one back end, stateful: `first` restarts it (the first row
// of a recording), then each call takes the network's next raw answer in time order.
using CompensationStep = std::function<std::array<std::int64_t, 3>(const std::array<std::int64_t, 3>&, bool first)>;

// The golden model's compensation as a CompensationStep.
inline CompensationStep golden_compensation(const QuantisedCompensation& compensation) {
  return [compensation, state = CompensationState{}](const std::array<std::int64_t, 3>& codes, bool first) mutable {
    if (first) state = CompensationState{};
    return compensate(compensation, state, codes);
  };
}

// Reads and quantises W.json (a deployed model's half-plays too, in q.compensation); a weight that
// would saturate its format is bad input.
inline QuantisedNetwork quantise_file(const std::string& weights_path, const nn::WeightsFile& weights) {
  try {
    QuantisedNetwork q = quantise(weights.network, Formats{});  // the HLS config's formats (a test checks they agree)
    if (weights.deployed()) q.compensation = quantise_compensation(weights.backlash_half_play_deg, Formats{});
    return q;
  } catch (const std::invalid_argument& error) {
    throw InputError(weights_path, 0, std::string("cannot be quantised: ") + error.what());
  }
}

class FixedPointIkBackend : public IkBackend {
 public:
  // `compensation` is the back end's own compensation (the deployed model's time-ordered part).
  FixedPointIkBackend(std::string name, nn::WeightsFile weights, QuantisedNetwork quantised, RawEvaluator evaluator,
                      CompensationStep compensation)
      : name_(std::move(name)),
        weights_(std::move(weights)),
        quantised_(std::move(quantised)),
        evaluator_(std::move(evaluator)),
        compensation_(std::move(compensation)) {}

  bool has_raw_codes() const override { return true; }
  bool has_time_ordered_parts() const override { return weights_.deployed(); }

  std::vector<IkRow> evaluate(const std::vector<Vec3>& positions_m, bool in_time_order) override {
    std::vector<IkRow> rows(positions_m.size());
    const bool compensate = in_time_order && weights_.deployed();
    const nn::Network& network = weights_.network;
    for (std::size_t i = 0; i < positions_m.size(); ++i) {
      bool input_clamped = false;
      // The host's setpoint shaping (a deployed model's joint ripple table) comes before the board.
      const auto codes =
          encode_position(quantised_.formats, nn::shape_setpoint(weights_, positions_m[i]), &input_clamped);
      raw_input_clamped_ += input_clamped;
      const RawOutput out = evaluator_(codes);
      counters_.scaled_input += out.scaled_input_saturated;
      counters_.tanh_input += out.tanh_input_saturated;
      counters_.output += out.output_saturated;
      ++counters_.evaluations;
      if ((positions_m[i].array() < network.input_min.array()).any() ||
          (positions_m[i].array() > network.input_max.array()).any()) {
        ++outside_training_range_;
      }
      rows[i].raw = out.alpha;
      if (compensate) {
        rows[i].raw = compensation_(out.alpha, i == 0);
      }
      for (int o = 0; o < 3; ++o) rows[i].alpha_deg[o] = decode_angle_deg(quantised_.formats, rows[i].raw[o]);
      nn::add_hybrid_math_model(weights_, positions_m[i], rows[i]);  // raw codes: the residual
    }
    return rows;
  }

  std::vector<std::string> report() const override {
    return {name_ + ": 3-" + std::to_string(quantised_.hidden) + "-3 network in fixed point (hls/README.md)" +
                (weights_.hybrid() ? "; raw codes are the residual added to the math model" : "") +
                (weights_.deployed() ? "; deployed model: + backlash compensation in time order" : "") +
                (weights_.joint_ripple.empty() ? "" : "; positions shaped by its joint ripple table first"),
            "positions outside the training range: " + std::to_string(outside_training_range_),
            "saturations: scaled input " + std::to_string(counters_.scaled_input) + ", tanh input " +
                std::to_string(counters_.tanh_input) + " (harmless), output " + std::to_string(counters_.output) +
                ", raw input " + std::to_string(raw_input_clamped_)};
  }

 private:
  std::string name_;
  nn::WeightsFile weights_;
  QuantisedNetwork quantised_;
  RawEvaluator evaluator_;
  CompensationStep compensation_;
  SaturationCounters counters_;
  std::size_t outside_training_range_ = 0;
  std::size_t raw_input_clamped_ = 0;
};

}  // namespace delta::golden
