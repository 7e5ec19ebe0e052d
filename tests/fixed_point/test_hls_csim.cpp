// HLS C-simulation (sc_fixed) against the golden model: every raw output code and saturation flag.
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "delta/golden/test_vectors.hpp"
#include "delta/nn/weights_file.hpp"
#include "fixed_point_fixture.hpp"
#include "network_csim.hpp"
#include "support/tree_paths.hpp"

namespace delta_hls {
namespace {

using Config = DefaultNetworkConfig;

TEST(HlsConfig, MatchesGoldenDefaultFormats) {
  EXPECT_TRUE(same_formats(golden_formats<Config>(), delta::golden::Formats()));
  EXPECT_EQ(Config::hidden_accumulator_bits, 41);  // hls/README.md step 3
  EXPECT_EQ(Config::output_accumulator_bits, 47);  // step 5
  EXPECT_EQ(Config::tanh_segments, 1024);
}

// CTest runs 80000 vectors on the shipped weights (about 12 s on an idle core, 140 us per vector)
// plus a quarter of that on each other network; scripts/bench_hls_csim.sh sets DELTA_CSIM_VECTORS=1000000.
std::size_t vector_count() {
  const char* text = std::getenv("DELTA_CSIM_VECTORS");
  return text ? std::strtoull(text, nullptr, 10) : 80000;
}

unsigned golden_flags(const delta::golden::RawOutput& out) {
  return (out.scaled_input_saturated ? unsigned{kScaledInputSaturated} : 0u) |
         (out.tanh_input_saturated ? unsigned{kTanhInputSaturated} : 0u) |
         (out.output_saturated ? unsigned{kOutputSaturated} : 0u);
}

// Returns how many vectors set each saturation bit (scaled input, tanh input, output).
std::array<std::size_t, 3> expect_hls_equals_golden(const delta::nn::Network& network, std::size_t count,
                                                    std::uint64_t seed) {
  const delta::golden::QuantisedNetwork q = delta::golden::quantise(network, golden_formats<Config>());
  const auto weights = load_weights<Config>(q);
  const auto vectors = delta::golden::csim_vectors(q, network.input_min, network.input_max, count, seed);
  std::cout << "seed " << seed << ", " << vectors.size() << " vectors\n";
  const auto start = std::chrono::steady_clock::now();
  std::size_t mismatches = 0;
  std::array<std::size_t, 3> saturated{};
  for (std::size_t i = 0; i < vectors.size(); ++i) {
    unsigned hls_flags = 0;
    const auto hls = evaluate_codes<Config>(*weights, vectors[i], &hls_flags);
    const delta::golden::RawOutput golden = delta::golden::evaluate_raw(q, vectors[i]);
    if (hls != golden.alpha || hls_flags != golden_flags(golden)) {
      if (++mismatches <= 5) {
        ADD_FAILURE() << "vector " << i << " (" << vectors[i][0] << ", " << vectors[i][1] << ", " << vectors[i][2]
                      << "): HLS " << hls[0] << " " << hls[1] << " " << hls[2] << " flags " << hls_flags << ", golden "
                      << golden.alpha[0] << " " << golden.alpha[1] << " " << golden.alpha[2] << " flags "
                      << golden_flags(golden);
      }
    }
    for (int b = 0; b < 3; ++b) saturated[b] += (hls_flags >> b) & 1u;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << vectors.size() << " vectors, " << mismatches << " mismatches, saturations (scaled input, tanh input, "
            << "output): " << saturated[0] << ", " << saturated[1] << ", " << saturated[2] << "; "
            << 1e6 * seconds / vectors.size() << " us per vector\n";
  EXPECT_EQ(mismatches, 0u);
  return saturated;
}

TEST(HlsCsim, EveryRawCodeMatchesGoldenOnFittedNetwork) {
  const auto saturated = expect_hls_equals_golden(delta::test::cube_network(), vector_count() / 4, 20261121);
  // The vectors must reach the input and tanh clamps, or they do not test those casts. (This
  // network's outputs stay within +-120 deg, far from the +-512 deg limit: see the stress test.)
  EXPECT_GT(saturated[0], 0u);
  EXPECT_GT(saturated[1], 0u);
}

// Weights near the limits of their formats, so every accumulator swings wide and outputs saturate.
TEST(HlsCsim, EveryRawCodeMatchesGoldenOnStressNetwork) {
  const std::uint64_t seed = 99;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  delta::nn::Network network = delta::test::cube_network();
  network.output_min = Eigen::Vector3d::Constant(-50.0);
  network.output_max = Eigen::Vector3d::Constant(50.0);  // half range R = 50 deg
  for (int k = 0; k < network.hidden(); ++k) {
    for (int j = 0; j < 3; ++j) network.input_weights(k, j) = 9.5 * unit(rng);  // IW' up to 14.8 of 16
    network.hidden_bias(k) = 7.9 * unit(rng);
    for (int o = 0; o < 3; ++o) network.output_weights(o, k) = 1.25 * unit(rng);  // LW' up to 62.5 of 64
  }
  for (int o = 0; o < 3; ++o) network.output_bias[o] = 8.0 * unit(rng);  // b2' within +-450 deg
  const auto saturated = expect_hls_equals_golden(network, vector_count() / 4, seed);
  EXPECT_GT(saturated[0], 0u);
  EXPECT_GT(saturated[1], 0u);
  EXPECT_GT(saturated[2], 0u);
}

// The shipped weights.
TEST(HlsCsim, EveryRawCodeMatchesGoldenOnShippedWeights) {
  const std::string path = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";
  if (!std::ifstream(path)) GTEST_SKIP() << path << " not present";
  expect_hls_equals_golden(delta::nn::read_weights_file(path).network, vector_count(), 7);
}

}  // namespace
}  // namespace delta_hls
