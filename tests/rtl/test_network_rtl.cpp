// The Verilated network RTL against the golden model: raw output codes bit-exact on 1e6 vectors
// (board configuration, ReuseFactor 75) and on 1e5 at ReuseFactor 25; latency; handshake; .mem errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

#include "Vdelta_network.h"
#include "Vdelta_network_reuse25.h"
#include "delta/golden/export.hpp"
#include "delta/rtl/network_harness.hpp"
#include "rtl_fixture.hpp"

namespace delta::test {
namespace {

constexpr int kInputWidth = 16;   // u: Q1.15 (hls/README.md step 2, the host's: golden::scale_input)
constexpr int kOutputWidth = 24;  // alpha: Q10.14 (step 6)

template <class Model>
void expect_bit_exact(std::uint32_t network_seed, std::uint64_t vector_seed, long vectors, int expected_latency) {
  std::cout << "network seed " << network_seed << ", vector seed " << vector_seed << ", " << vectors << " vectors\n";
  const golden::QuantisedNetwork q = golden::quantise(random_network(network_seed));
  const std::string mem_dir = fresh_directory("rtl_mem");
  golden::write_export(q, mem_dir);
  rtl::NetworkHarness<Model> rtl(kInputWidth, kOutputWidth, mem_dir);
  InputVectors inputs(q, vector_seed);
  golden::SaturationCounters counters;
  long mismatches = 0;
  for (long v = 0; v < vectors; ++v) {
    const std::array<std::int64_t, 3> x = inputs.next();
    const golden::RawOutput expected = golden::evaluate_raw(q, x, &counters);
    const rtl::NetworkRun run = rtl.run(golden::scale_input(q, x).code);
    ASSERT_EQ(run.latency_cycles, expected_latency) << "vector " << v;
    if (run.outputs != expected.alpha && ++mismatches <= 5) {
      ADD_FAILURE() << "vector " << v << " x = (" << x[0] << ", " << x[1] << ", " << x[2] << "): rtl ("
                    << run.outputs[0] << ", " << run.outputs[1] << ", " << run.outputs[2] << ") golden ("
                    << expected.alpha[0] << ", " << expected.alpha[1] << ", " << expected.alpha[2] << ")";
    }
  }
  EXPECT_EQ(mismatches, 0);
  // The vectors must reach every saturating cast, or bit-exactness there is untested.
  std::cout << "saturations: scaled input " << counters.scaled_input << ", tanh input " << counters.tanh_input
            << ", output " << counters.output << " of " << counters.evaluations << "\n";
  EXPECT_GT(counters.scaled_input, 0u);
  EXPECT_GT(counters.tanh_input, 0u);
  std::filesystem::remove_all(mem_dir);
}

TEST(NetworkRtl, BitExactOnOneMillionVectorsAtReuse75) {
  expect_bit_exact<Vdelta_network>(11, 20260101, 1'000'000, 92);
}

TEST(NetworkRtl, BitExactAtReuse25) { expect_bit_exact<Vdelta_network_reuse25>(12, 20260102, 100'000, 40); }

TEST(NetworkRtl, OutputSaturationIsBitExact) {
  // Output half-range 200 deg and |LW| = 0.3 give |LW'| = 60 deg per unit h. With LW(o, k) of
  // the sign of IW(k, o), a large input o drives all 25 terms one way: 1500 deg, far past the
  // 24-bit format's 512 deg.
  nn::Network net = random_network(13);
  net.output_min = Vec3(-200.0, -200.0, -200.0);
  net.output_max = Vec3(200.0, 200.0, 200.0);
  net.output_weights = 0.3 * net.input_weights.transpose().cwiseSign();
  const golden::QuantisedNetwork q = golden::quantise(net);
  const std::string mem_dir = fresh_directory("rtl_mem_sat");
  golden::write_export(q, mem_dir);
  rtl::NetworkHarness<Vdelta_network_reuse25> rtl(kInputWidth, kOutputWidth, mem_dir);
  InputVectors inputs(q, 7);
  golden::SaturationCounters counters;
  for (int v = 0; v < 20'000; ++v) {
    const std::array<std::int64_t, 3> x = inputs.next();
    ASSERT_EQ(rtl.run(golden::scale_input(q, x).code).outputs, golden::evaluate_raw(q, x, &counters).alpha)
        << "vector " << v;
  }
  std::cout << "output saturations: " << counters.output << " of " << counters.evaluations << "\n";
  EXPECT_GT(counters.output, 0u);
}

TEST(NetworkRtl, HandshakeFollowsApCtrlHs) {
  const golden::QuantisedNetwork q = golden::quantise(random_network(14));
  const std::string mem_dir = fresh_directory("rtl_mem_hs");
  golden::write_export(q, mem_dir);
  rtl::NetworkHarness<Vdelta_network_reuse25> rtl(kInputWidth, kOutputWidth, mem_dir);
  // Back-to-back inferences give the same answer as single ones (no state leaks between runs).
  InputVectors inputs(q, 3);
  const std::array<std::int64_t, 3> a = inputs.next(), b = inputs.next();
  const auto first = rtl.run(golden::scale_input(q, a).code).outputs;
  EXPECT_EQ(rtl.run(golden::scale_input(q, b).code).outputs, golden::evaluate_raw(q, b).alpha);
  EXPECT_EQ(rtl.run(golden::scale_input(q, a).code).outputs, first);
  EXPECT_EQ(first, golden::evaluate_raw(q, a).alpha);
}

TEST(NetworkRtl, MissingMemFileIsAnError) {
  const golden::QuantisedNetwork q = golden::quantise(random_network(15));
  const std::string mem_dir = fresh_directory("rtl_mem_missing");
  golden::write_export(q, mem_dir);
  std::filesystem::remove(mem_dir + "/tanh_slope.mem");
  EXPECT_THROW(rtl::NetworkHarness<Vdelta_network_reuse25>(kInputWidth, kOutputWidth, mem_dir), std::runtime_error);
}

TEST(NetworkRtl, WritesFstWaveformOnRequest) {
  const golden::QuantisedNetwork q = golden::quantise(random_network(16));
  const std::string mem_dir = fresh_directory("rtl_mem_fst");
  golden::write_export(q, mem_dir);
  const std::string fst = mem_dir + "/network.fst";
  {
    rtl::NetworkHarness<Vdelta_network_reuse25> rtl(kInputWidth, kOutputWidth, mem_dir, fst);
    InputVectors inputs(q, 5);
    rtl.run(golden::scale_input(q, inputs.next()).code);
  }
  ASSERT_TRUE(std::filesystem::exists(fst));
  EXPECT_GT(std::filesystem::file_size(fst), 1000u);
}

}  // namespace
}  // namespace delta::test
