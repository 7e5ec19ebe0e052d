// The network a board runs, host side (see board_network.hpp).
#include "delta/golden/board_network.hpp"

#include <stdexcept>

#include <Eigen/Dense>

#include "delta/golden/fixed_point_backend.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::golden {

BoardWeights read_board_weights(const std::string& weights_path) {
  const nn::WeightsFile weights = nn::read_weights_file(weights_path);
  if (weights.hybrid()) {
    throw InputError(weights_path, 0, "is a hybrid model; the board runs the network alone (train --model network)");
  }
  if (weights.network.hidden() != 25) {
    throw InputError(weights_path, 0,
                     "has " + std::to_string(weights.network.hidden()) + " hidden neurons; the RTL is built for 25");
  }
  BoardWeights board;
  board.network = golden::quantise_file(weights_path, weights);  // a deployed model's half-plays too
  board.trained_min_m = weights.network.input_min;
  board.trained_max_m = weights.network.input_max;
  board.model = weights;
  return board;
}

Vec3 answer_deg(const QuantisedNetwork& network, const Vec3& position_m, bool* clamped) {
  const golden::RawOutput raw =
      golden::evaluate_raw(network, golden::encode_position(network.formats, position_m, clamped));
  Vec3 deg;
  for (int j = 0; j < 3; ++j) deg[j] = golden::decode_angle_deg(network.formats, raw.alpha[j]);
  return deg;
}

Vec3 locate_plate(const QuantisedNetwork& network, const Geometry& nominal, const Vec3& alpha_deg) {
  const FkSolution start = forward_kinematics(nominal, alpha_deg);
  if (!start.ok()) throw std::runtime_error("locate the plate: nominal FK: " + start.reason());
  Vec3 p = start.position_m;
  for (int iteration = 0; iteration < 12; ++iteration) {
    const Vec3 residual = answer_deg(network, p) - alpha_deg;
    const IkSolution ik = inverse_kinematics(nominal, p);
    if (!ik.ok()) throw std::runtime_error("locate the plate: nominal IK: " + ik.reason());
    const Vec3 step = inverse_jacobian_deg_per_m(nominal, p, ik.alpha_deg).inverse() * residual;
    p -= step;
    if (step.norm() < 1e-8) break;
  }
  return p;
}

}  // namespace delta::golden
