// The inputs every command that runs the board RTL reads the same way: the network weights the
// board is built for, and the virtual robot's effects. Errors are InputError (file, reason; exit 2).
#pragma once

#include <string>

#include "delta/effects.hpp"
#include "delta/golden/fixed_network.hpp"

namespace delta::cosim {

// W.json quantised for the board: a plain network (not hybrid) with the RTL's 25 hidden neurons
// whose weights fit the fixed-point formats.
golden::QuantisedNetwork read_board_network(const std::string& weights_path);

// The effects of E.json ("": the nominal robot), refused if that robot cannot be assembled at the
// board's home pose (30 deg on every joint).
EffectSet read_board_effects(const std::string& effects_path);

}  // namespace delta::cosim
