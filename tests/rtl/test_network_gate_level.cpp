// The gate-level netlist (yosys synth_ice40 of delta_network with the shipped weights, simulated
// with yosys's iCE40 cell models) against the golden model: raw codes bit-exact on 1e4 vectors.
// Catches what RTL simulation cannot: yosys mis-synthesis (e.g. `-16'(x)` read as +x in 0.23).
#include <gtest/gtest.h>

#include <iostream>

#include "Vdelta_network_gate.h"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/test_vectors.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/rtl/network_harness.hpp"
#include "rtl_fixture.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

TEST(NetworkGateLevel, BitExactOnTenThousandVectors) {
  constexpr std::uint64_t kSeed = 20260103;
  // The netlist's memories were filled at synthesis from DELTA_NETWORK_WEIGHTS (the shipped weights).
  const std::string weights_path = cache_value("DELTA_NETWORK_WEIGHTS");
  const nn::WeightsFile weights = nn::read_weights_file(weights_path);
  const golden::QuantisedNetwork q = golden::quantise(weights.network);
  std::cout << "weights " << weights_path << ", vector seed " << kSeed << "\n";
  // The netlist ignores +delta_mem_dir; an empty directory proves it needs no .mem file.
  rtl::NetworkHarness<Vdelta_network_gate> netlist(q.formats.scaled_input_bits, q.formats.output_bits,
                                                   fresh_directory("gate_level_no_mem"));
  // Saturation corners first, then random positions in and beyond the range and random codes.
  std::vector<golden::RawInput> vectors = golden::saturation_corners(q);
  InputVectors random(q, kSeed);
  while (vectors.size() < 10'000) vectors.push_back(random.next());
  golden::SaturationCounters counters;
  for (std::size_t v = 0; v < vectors.size(); ++v) {
    const golden::RawOutput expected = golden::evaluate_raw(q, vectors[v], &counters);
    const rtl::NetworkRun run = netlist.run(golden::scale_input(q, vectors[v]).code);
    ASSERT_EQ(run.outputs, expected.alpha)
        << "vector " << v << " x = (" << vectors[v][0] << ", " << vectors[v][1] << ", " << vectors[v][2] << ")";
    ASSERT_EQ(run.latency_cycles, 92) << "vector " << v;
  }
  std::cout << vectors.size() << " vectors; saturations: scaled input " << counters.scaled_input << ", tanh input "
            << counters.tanh_input << ", output " << counters.output << "\n";
  EXPECT_GT(counters.scaled_input, 0u);
}

}  // namespace
}  // namespace delta::test
