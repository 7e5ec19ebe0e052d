// Shared network for the fixed-point tests: fitted once (seed 1) and cached in the build folder,
// because CTest runs every TEST in its own process and a fit takes seconds.
#pragma once

#include <cstdio>
#include <fstream>
#include <string>

#include <unistd.h>

#include "fit_network.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {

inline const nn::Network& cube_network() {
  static const nn::Network network = [] {
    constexpr std::uint32_t kSeed = 1;
    const std::string cache = std::string(DELTA_BINARY_DIR) + "/tests/fixed_point_cube_network_seed1.txt";
    nn::Network net;
    net.input_weights.resize(25, 3);
    net.hidden_bias.resize(25);
    net.output_weights.resize(3, 25);
    auto fields = [&net](auto&& visit) {
      for (int j = 0; j < 3; ++j)
        visit(net.input_min[j]), visit(net.input_max[j]), visit(net.output_min[j]), visit(net.output_max[j]),
            visit(net.output_bias[j]);
      for (int i = 0; i < net.input_weights.size(); ++i) visit(net.input_weights.data()[i]);
      for (int i = 0; i < net.hidden_bias.size(); ++i) visit(net.hidden_bias.data()[i]);
      for (int i = 0; i < net.output_weights.size(); ++i) visit(net.output_weights.data()[i]);
    };
    std::ifstream in(cache);
    bool complete = static_cast<bool>(in);
    if (complete) fields([&](double& value) { complete = complete && static_cast<bool>(in >> value); });
    if (complete) return net;
    net = fit_cube_network(kSeed);
    const std::string temporary = cache + ".tmp" + std::to_string(::getpid());
    {
      std::ofstream out(temporary);
      out.precision(17);
      fields([&](double& value) { out << value << '\n'; });
    }
    std::rename(temporary.c_str(), cache.c_str());
    return net;
  }();
  return network;
}

}  // namespace delta::test
