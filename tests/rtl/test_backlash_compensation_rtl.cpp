// backlash_compensation.sv (Verilated RTL and the yosys gate-level netlist) against the golden
// model (delta::golden::compensate) on seeded random walks of answers: every reference code.
#include <gtest/gtest.h>

#include "delta/golden/fixed_network.hpp"
#include "delta/golden/test_vectors.hpp"
#include "delta/rtl/compensation_harness.hpp"

#ifdef DELTA_COMPENSATION_GATE_LEVEL
#include "Vbacklash_compensation_gate.h"
using Model = Vbacklash_compensation_gate;
constexpr const char* kWhat = "gate-level netlist";
constexpr int kWalks = 10;
#define COMPENSATION_SUITE BacklashCompensationGateLevel
#else
#include "Vbacklash_compensation.h"
using Model = Vbacklash_compensation;
constexpr const char* kWhat = "RTL";
constexpr int kWalks = 40;
#define COMPENSATION_SUITE BacklashCompensationRtl
#endif

namespace delta::rtl {
namespace {

TEST(COMPENSATION_SUITE, EqualsTheGoldenModelOnRandomWalksToTheFormatsEdges) {
  const std::uint64_t seed = 16;
  std::printf("%s, seed %llu\n", kWhat, static_cast<unsigned long long>(seed));
  const golden::Formats formats;
  std::size_t steps = 0, mismatches = 0;
  int latency = 0;
  for (const golden::CompensationWalk& walk : golden::compensation_walks(formats, kWalks, 2500, seed)) {
    CompensationHarness<Model> rtl(formats.output_bits, formats.half_play_bits, walk.compensation.half_play);
    golden::CompensationState golden;
    for (std::size_t i = 0; i < walk.answers.size(); ++i, ++steps) {
      if (i == 1000) {  // a restart mid-walk: the next answer passes, as after reset
        rtl.restart();
        golden = golden::CompensationState{};
      }
      const std::array<std::int64_t, 3> expected = golden::compensate(walk.compensation, golden, walk.answers[i]);
      const std::array<std::int64_t, 3> got = rtl.step(walk.answers[i]);
      latency = rtl.latency_cycles();
      if (got != expected && ++mismatches <= 5) {
        ADD_FAILURE() << "step " << i << ": " << kWhat << " " << got[0] << " " << got[1] << " " << got[2] << " golden "
                      << expected[0] << " " << expected[1] << " " << expected[2];
      }
    }
  }
  std::printf("%zu answers, %zu mismatches, %d cycles from answer to references\n", steps, mismatches, latency);
  EXPECT_EQ(mismatches, 0u);
  EXPECT_EQ(latency, 3);  // one joint per cycle
}

}  // namespace
}  // namespace delta::rtl
