// The network a board runs, as the host reads it from W.json (what the board's identify must match:
// delta::weights_crc of its quantised codes) and uses it: the golden answer for a position, and
// where the plate is when the encoders read given angles (the host's only view of the pose).
#pragma once

#include <string>

#include "delta/geometry.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::golden {

struct BoardWeights {
  QuantisedNetwork network;           // as the board's ROMs hold it
  Vec3 trained_min_m = Vec3::Zero();  // the network's input range (W.json input_min, input_max)
  Vec3 trained_max_m = Vec3::Zero();
  // The file as read: a deployed model's joint ripple table shapes every setpoint the host sends
  // (nn::shape_setpoint; the board's network is the same with or without one).
  nn::WeightsFile model;
};

// W.json for the board: a plain network (not hybrid) with the RTL's 25 hidden neurons whose
// weights fit the fixed-point formats. Errors are InputError (file, reason; exit 2).
BoardWeights read_board_weights(const std::string& weights_path);

// The network's answer [deg] for a position [m] (the golden model, code for code the board's).
Vec3 answer_deg(const QuantisedNetwork& network, const Vec3& position_m, bool* clamped = nullptr);

// Where the network answers `alpha_deg`: Newton's method on the golden network with the nominal
// model's Jacobian, from the nominal forward kinematics (to ~0.1 um). Throws std::runtime_error
// when the nominal model has no pose there.
Vec3 locate_plate(const QuantisedNetwork& network, const Geometry& nominal, const Vec3& alpha_deg);

}  // namespace delta::golden
