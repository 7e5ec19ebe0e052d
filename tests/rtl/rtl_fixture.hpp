// Shared pieces of the RTL tests: a seeded random network whose hidden layer spans the whole tanh
// range, input vectors in, beyond and at the edges of the trained range, and the .mem export.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include "delta/golden/fixed_network.hpp"
#include "delta/nn/network.hpp"

namespace delta::test {

// Trained range of the random network: the paper's 10 mm cube (metres).
inline Vec3 rtl_cube_min_m() { return Vec3(-0.005, -0.005, -0.08084); }
inline Vec3 rtl_cube_max_m() { return Vec3(0.005, 0.005, -0.07084); }

// Weights drawn so that hidden pre-activations reach |n| > 8 (tanh and its saturation) for inputs
// inside the cube, and outputs span tens of degrees: every cast of the spec is exercised.
inline nn::Network random_network(std::uint32_t seed, int hidden = 25) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  nn::Network net;
  net.input_min = rtl_cube_min_m();
  net.input_max = rtl_cube_max_m();
  net.output_min = Vec3(10.0, 12.0, 14.0);
  net.output_max = Vec3(50.0, 48.0, 46.0);
  net.input_weights = Eigen::MatrixXd(hidden, 3);
  net.hidden_bias = Eigen::VectorXd(hidden);
  net.output_weights = Eigen::MatrixXd(3, hidden);
  for (int k = 0; k < hidden; ++k) {
    for (int j = 0; j < 3; ++j) net.input_weights(k, j) = 2.5 * normal(rng);
    net.hidden_bias(k) = normal(rng);
  }
  for (int o = 0; o < 3; ++o) {
    for (int k = 0; k < hidden; ++k) net.output_weights(o, k) = 0.3 * normal(rng);
    net.output_bias[o] = 0.2 * normal(rng);
  }
  return net;
}

// Raw input codes: 80 % uniform over the cube plus 50 % margin each side (scaled-input saturation
// starts at 28 %), 15 % uniform over all 32-bit codes, 5 % from a set of corner codes.
class InputVectors {
 public:
  InputVectors(const golden::QuantisedNetwork& q, std::uint64_t seed) : q_(q), rng_(seed) {}

  std::array<std::int64_t, 3> next() {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double pick = unit(rng_);
    std::array<std::int64_t, 3> codes{};
    if (pick < 0.80) {
      Vec3 p;
      for (int j = 0; j < 3; ++j) {
        const double low = rtl_cube_min_m()[j], high = rtl_cube_max_m()[j], margin = 0.5 * (high - low);
        p[j] = low - margin + unit(rng_) * (high - low + 2 * margin);
      }
      codes = golden::encode_position(q_.formats, p);
    } else if (pick < 0.95) {
      std::uniform_int_distribution<std::int64_t> any(INT32_MIN, INT32_MAX);
      for (auto& code : codes) code = any(rng_);
    } else {
      const std::int64_t corners[] = {INT32_MIN, INT32_MAX, 0, -1, 1};
      std::uniform_int_distribution<int> which(0, 4 + 3);
      for (int j = 0; j < 3; ++j) {
        const int c = which(rng_);
        // Beside the centre, or on either side of the scaled input's saturation edge.
        codes[j] =
            c < 5 ? corners[c]
                  : q_.input_centre[j] + (c - 6) + ((c == 5 ? -1 : 1) * (std::int64_t{1} << (q_.input_shift[j] + 15)));
      }
    }
    return codes;
  }

 private:
  const golden::QuantisedNetwork& q_;
  std::mt19937_64 rng_;
};

// A fresh directory under the system's temp dir, unique per process.
inline std::string fresh_directory(const std::string& name) {
  const std::string path =
      (std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()))).string();
  std::filesystem::remove_all(path);
  std::filesystem::create_directories(path);
  return path;
}

}  // namespace delta::test
