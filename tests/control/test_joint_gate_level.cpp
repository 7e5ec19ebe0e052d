// The yosys synth_ice40 netlist of joint_controller (iCE40 cell models) against the golden model
// in closed loop: yosys 0.23 mis-synthesises some expressions, only this catches it.
#include <gtest/gtest.h>

#include "Vjoint_controller_gate.h"
#include "delta/rtl/joint_handshake.hpp"
#include "random_closed_loop.hpp"
#include "verilated.h"

namespace delta::control {
namespace {

TEST(JointGateLevel, NetlistAgreesWithTheGoldenModelOnClosedLoop) {
  const std::uint64_t seed = test_seed() + 1;  // other random drives than the RTL test
  std::cout << "seed " << seed << " (DELTA_TEST_SEED + 1)\n";
  RandomClosedLoop loop(seed);
  VerilatedContext context;
  Vjoint_controller_gate netlist{&context};
  rtl::reset_model(netlist);
  const long periods = 5000;  // 4.5e6 clock cycles of the netlist
  for (long k = 0; k < periods; ++k) {
    const rtl::JointRtlResult result = rtl::run_period(netlist, loop.next_inputs(k));
    ASSERT_EQ(result.overflow_count, loop.overflow_code()) << "period " << k;
    ASSERT_EQ(result.cycles, 1072) << "period " << k;
    for (int j = 0; j < 3; ++j) {
      ASSERT_EQ(result.current[j], loop.golden_current[j]) << "period " << k << " joint " << j;
      ASSERT_EQ(result.limited[j], loop.golden_limited[j]) << "period " << k << " joint " << j;
    }
    loop.step_plants();
  }
  std::cout << periods << " periods x 3 joints equal; " << loop.glitches << " glitches, " << loop.limited_periods
            << " limited joint-periods, " << loop.overflows << " saturations\n";
  EXPECT_GT(loop.limited_periods, 0);
}

}  // namespace
}  // namespace delta::control
