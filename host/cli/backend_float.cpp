// The `float` inverse-kinematics back end: a W.json (network, hybrid or deployed) evaluated in double.
#include <memory>

#include "delta/ik_backend.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::nn {
namespace {

class FloatIkBackend : public IkBackend {
 public:
  explicit FloatIkBackend(WeightsFile weights) : weights_(std::move(weights)) {}

  bool has_time_ordered_parts() const override { return weights_.deployed(); }

  std::vector<IkRow> evaluate(const std::vector<Vec3>& positions_m, bool in_time_order) override {
    std::vector<IkRow> rows(positions_m.size());
    BacklashCompensation compensation(weights_.backlash_half_play_deg);
    const bool compensate = in_time_order && weights_.deployed();
    for (std::size_t i = 0; i < positions_m.size(); ++i) {
      const IkSolution solution = evaluate_model(weights_, positions_m[i]);
      if (solution.ok())
        rows[i].alpha_deg = compensate ? compensation.update(solution.alpha_deg) : solution.alpha_deg;
      else
        rows[i].error = solution.reason();
      // Positions outside the training range make the network extrapolate: count them.
      const Network& network = weights_.network;
      if ((positions_m[i].array() < network.input_min.array()).any() ||
          (positions_m[i].array() > network.input_max.array()).any()) {
        ++outside_training_range_;
      }
    }
    return rows;
  }

  std::vector<std::string> report() const override {
    return {"model: " + weights_.model + " (3-" + std::to_string(weights_.network.hidden()) + "-3 tanh network" +
                (weights_.hybrid() ? " on the math model's residual)" : "") +
                (weights_.deployed() ? ", static part, + backlash compensation in time order)" : "") +
                (weights_.hybrid() || weights_.deployed() ? "" : ")") +
                (weights_.joint_ripple.empty() ? "" : "; positions shaped by its joint ripple table first"),
            "positions outside the training range (extrapolated): " + std::to_string(outside_training_range_)};
  }

 private:
  WeightsFile weights_;
  std::size_t outside_training_range_ = 0;
};

const RegisterIkBackend float_backend("float",
                                      "the network of W.json in double precision (pure network or hybrid); the default",
                                      [](const std::string& weights_path) {
                                        return std::make_unique<FloatIkBackend>(read_weights_file(weights_path));
                                      });

}  // namespace
}  // namespace delta::nn
