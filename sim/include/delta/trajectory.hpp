// Plate trajectories of the paper's experiments and held-out sweeps: position (metres) against time.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "delta/geometry.hpp"

namespace delta {

struct Trajectory {
  std::string name;
  double rate_hz = 10.0;    // default sampling rate of a recording along it
  std::size_t samples = 0;  // default number of samples
  std::function<Vec3(double t_s)> position_m;
};

// Names accepted by make_trajectory, with a one-line description each.
const std::vector<std::pair<std::string, std::string>>& trajectory_catalogue();

// "validation": the paper's trajectory (1), 13333 samples at 10 Hz, z descending 10 mm.
// "experiment1", "experiment2": the paper's control experiments at f = 0.2 Hz (10 periods, 100 Hz).
// "sweep": a Lissajous sweep of the 10 mm cube with seed-drawn frequencies and phases (6000 at 10 Hz).
// "calibration": the slow drag over +-12 mm; "pick-place": dwells at five stations (the catalogue).
// Throws std::invalid_argument for an unknown name.
Trajectory make_trajectory(const std::string& name, std::uint64_t seed = 1);

// Weight of a smooth start: 0 at u <= 0, 1 at u >= 1, the quintic u^3 (10 - 15 u + 6 u^2) between
// (zero velocity and acceleration at both ends).
double quintic_blend(double u);

}  // namespace delta
