// The inputs of the commands that run the board RTL (see board_inputs.hpp).
#include "delta/cosim/board_inputs.hpp"

#include "delta/effect_file.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"

namespace delta::cosim {

golden::QuantisedNetwork read_board_network(const std::string& weights_path) {
  return golden::read_board_weights(weights_path).network;
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
