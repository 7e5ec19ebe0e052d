// The inputs of the commands that run the board RTL (see board_inputs.hpp).
#include "delta/cosim/board_inputs.hpp"

#include <stdexcept>

#include "delta/effect_file.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::cosim {

golden::QuantisedNetwork read_board_network(const std::string& weights_path) {
  const nn::WeightsFile weights = nn::read_weights_file(weights_path);
  if (weights.hybrid()) {
    throw InputError(weights_path, 0, "is a hybrid model; the board runs the network alone (train --model network)");
  }
  if (weights.network.hidden() != 25) {
    throw InputError(weights_path, 0,
                     "has " + std::to_string(weights.network.hidden()) + " hidden neurons; the RTL is built for 25");
  }
  try {
    return golden::quantise(weights.network);
  } catch (const std::invalid_argument& error) {
    throw InputError(weights_path, 0, std::string("cannot be quantised: ") + error.what());
  }
}

EffectSet read_board_effects(const std::string& effects_path) {
  if (effects_path.empty()) return EffectSet{};
  const EffectSet effects = read_effect_file(effects_path);
  if (!forward_kinematics(apply_geometry_effects(Geometry::nominal(), effects), Vec3::Constant(30.0)).ok()) {
    throw InputError(effects_path, 0, "the robot of these effects cannot be assembled at its home pose (30 deg)");
  }
  return effects;
}

}  // namespace delta::cosim
