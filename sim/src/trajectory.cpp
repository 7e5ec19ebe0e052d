// The paper's trajectories (validation run, experiments 1 and 2) and a seeded sweep of the cube.
#include "delta/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <stdexcept>

namespace delta {

const std::vector<std::pair<std::string, std::string>>& trajectory_catalogue() {
  static const std::vector<std::pair<std::string, std::string>> catalogue = {
      {"validation", "paper's trajectory (1): x,y sinusoids of 5 mm, z down 10 mm; 13333 samples at 10 Hz"},
      {"experiment1", "paper's experiment 1: ellipse 4.5 x 3 mm, z +-2 mm about -75 mm, 0.2 Hz; 5000 at 100 Hz"},
      {"experiment2", "paper's experiment 2: figure-eight 3 x 3 mm at z = -75 mm, 0.2 Hz; 5000 at 100 Hz"},
      {"sweep", "Lissajous sweep of the 10 mm cube, frequencies and phases drawn from --seed; 6000 at 10 Hz"},
      {"calibration",
       "slow Lissajous over +-12 mm in x, y and 16 mm of z (the wide angles that separate arm "
       "lengths, radius and encoder scale); 9000 at 10 Hz"},
      {"pick-place",
       "pick and place: 0.5 s dwells at the centre (z -76 mm) and four stations x, y = +-4.5 mm at z -72 "
       "and -80 mm, 0.4 s quintic moves between; 5 s, 500 at 100 Hz"}};
  return catalogue;
}

double quintic_blend(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
}

Trajectory make_trajectory(const std::string& name, std::uint64_t seed) {
  Trajectory trajectory;
  trajectory.name = name;
  const double two_pi = 2.0 * kPi;
  if (name == "validation") {
    trajectory.rate_hz = 10.0;
    trajectory.samples = 13333;
    trajectory.position_m = [two_pi](double t) {
      return Vec3(-0.005 * std::sin(two_pi * 0.0075 * t), 0.005 * std::sin(two_pi * 0.03 * t),
                  -0.07084 - t * 0.01 / 1333.3);
    };
  } else if (name == "experiment1") {
    trajectory.rate_hz = 100.0;
    trajectory.samples = 5000;
    trajectory.position_m = [two_pi](double t) {
      const double f = 0.2;
      return Vec3(0.0045 * std::sin(two_pi * f * t), 0.003 * std::cos(two_pi * f * t),
                  -0.075 + 0.002 * std::sin(two_pi * f * t));
    };
  } else if (name == "experiment2") {
    trajectory.rate_hz = 100.0;
    trajectory.samples = 5000;
    trajectory.position_m = [two_pi](double t) {
      const double f = 0.2;
      return Vec3(0.003 * std::sin(two_pi * f * t), 0.003 * std::cos(2.0 * two_pi * f * t), -0.075);
    };
  } else if (name == "sweep") {
    trajectory.rate_hz = 10.0;
    trajectory.samples = 6000;
    std::mt19937_64 generator(seed);
    std::uniform_real_distribution<double> frequency(0.004, 0.04);
    std::uniform_real_distribution<double> phase(0.0, two_pi);
    const Vec3 f(frequency(generator), frequency(generator), frequency(generator));
    const Vec3 p(phase(generator), phase(generator), phase(generator));
    trajectory.position_m = [two_pi, f, p](double t) {
      return Vec3(0.005 * std::sin(two_pi * f.x() * t + p.x()), 0.005 * std::sin(two_pi * f.y() * t + p.y()),
                  -0.07584 + 0.005 * std::sin(two_pi * f.z() * t + p.z()));
    };
  } else if (name == "calibration") {
    // Wider than the paper's 10 mm cube: the joint angles span about twice the range, so the
    // length, radius and encoder-scale families bend the angles differently enough to be told
    // apart; slow enough (1.3 mm/s at most) for a stage to drag the plate with the drives off.
    trajectory.rate_hz = 10.0;
    trajectory.samples = 9000;
    trajectory.position_m = [two_pi](double t) {
      const double start = quintic_blend(t / 20.0);  // from the middle, without a jump
      return Vec3(start * 0.012 * std::sin(two_pi * 0.0113 * t), start * 0.012 * std::sin(two_pi * 0.0171 * t),
                  -0.080 + start * 0.008 * std::sin(two_pi * 0.0071 * t));
    };
  } else if (name == "pick-place") {
    // Where a positioning robot is judged: the dwells. Each joint turns at some stations, so the
    // stops come from both sides of the play.
    trajectory.rate_hz = 100.0;
    trajectory.samples = 500;
    trajectory.position_m = [](double t) {
      static const Vec3 stations[] = {{0.0, 0.0, -0.076},         {0.0045, 0.0045, -0.072},  {-0.0045, 0.0045, -0.080},
                                      {-0.0045, -0.0045, -0.072}, {0.0045, -0.0045, -0.080}, {0.0, 0.0, -0.076}};
      constexpr double dwell_s = 0.5, move_s = 0.4;
      constexpr int last = static_cast<int>(std::size(stations)) - 1;
      const int k = std::clamp(static_cast<int>(std::floor(t / (dwell_s + move_s))), 0, last);
      const double into_move = t - k * (dwell_s + move_s) - dwell_s;
      if (k == last || into_move <= 0.0) return stations[k];
      return Vec3(stations[k] + quintic_blend(into_move / move_s) * (stations[k + 1] - stations[k]));
    };
  } else {
    std::string names;
    for (const auto& entry : trajectory_catalogue()) names += (names.empty() ? "" : ", ") + entry.first;
    throw std::invalid_argument("unknown trajectory '" + name + "' (choose one of " + names + ")");
  }
  return trajectory;
}

}  // namespace delta
