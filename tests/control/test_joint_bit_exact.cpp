// Golden model, HLS C simulation and Verilated RTL of the three joints: same codes, closed loop.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>

#include "delta/control/closed_loop.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/geometry.hpp"
#include "delta/joint_plant.hpp"
#include "delta/rtl/joint_rtl_model.hpp"
#include "random_closed_loop.hpp"
#include "joint_top.hpp"

namespace delta::control {
namespace {

// Raw code of an sc_fixed value with `fraction` fraction bits (exact: at most 32 bits).
template <typename Fixed>
std::int32_t raw(const Fixed& value, int fraction) {
  return static_cast<std::int32_t>(std::llround(std::ldexp(value.to_double(), fraction)));
}

JointFixedState hls_state(int joint) {
  const hls_joint::JointState s = hls_joint::joint_top_state(joint);
  JointFixedState state;
  state.reference = raw(s.reference, kReferenceFraction);
  state.reference_velocity = raw(s.reference_velocity, kStateFraction);
  state.reference_acceleration = raw(s.reference_acceleration, kStateFraction);
  state.encoder = static_cast<std::int32_t>(s.encoder.to_int());
  state.velocity = raw(s.velocity, kStateFraction);
  state.disturbance = raw(s.disturbance, kStateFraction);
  state.current = raw(s.current, kCurrentFraction);
  return state;
}

std::string describe(const JointFixedState& s) {
  std::ostringstream out;
  out << "{r " << s.reference << ", vr " << s.reference_velocity << ", ar " << s.reference_acceleration << ", e "
      << s.encoder << ", v " << s.velocity << ", d " << s.disturbance << ", i " << s.current << "}";
  return out.str();
}

// Random references (sinusoids, steps, rare one-period glitches over the whole int32 range)
// and random load torques drive three plants in closed loop with the golden controller; the
// HLS top and the RTL see the same inputs and must produce the same codes and states.
TEST(JointBitExact, GoldenHlsAndRtlAgreeOnClosedLoopWithRandomReferencesAndLoads) {
  const std::uint64_t seed = test_seed();
  std::cout << "seed " << seed << " (DELTA_TEST_SEED overrides)\n";
  RandomClosedLoop loop(seed);
  hls_joint::joint_top_reset();
  rtl::JointRtlModel rtl;
  const long periods = 100000;
  for (long k = 0; k < periods; ++k) {
    const std::array<JointFixedInput, 3>& inputs = loop.next_inputs(k);
    hls_joint::reference_t hls_reference[3];
    hls_joint::encoder_t hls_encoder[3];
    hls_joint::current_t hls_current[3];
    for (int j = 0; j < 3; ++j) {
      hls_reference[j] = std::ldexp(static_cast<double>(inputs[j].reference), -kReferenceFraction);
      hls_encoder[j] = inputs[j].encoder;
    }
    sc_uint<3> hls_limited;
    sc_uint<16> hls_overflows;
    hls_joint::joint_top(hls_reference, hls_encoder, hls_current, hls_limited, hls_overflows);
    const rtl::JointRtlResult rtl_result = rtl.run(inputs);

    ASSERT_EQ(hls_overflows.to_uint(), loop.overflow_code()) << "period " << k;
    ASSERT_EQ(rtl_result.overflow_count, loop.overflow_code()) << "period " << k;
    ASSERT_EQ(rtl_result.cycles, 892) << "latency, period " << k;
    for (int j = 0; j < 3; ++j) {
      ASSERT_EQ(raw(hls_current[j], kCurrentFraction), loop.golden_current[j]) << "HLS period " << k << " joint " << j;
      ASSERT_EQ(rtl_result.current[j], loop.golden_current[j]) << "RTL period " << k << " joint " << j;
      ASSERT_EQ(static_cast<bool>(hls_limited[j]), loop.golden_limited[j]) << "HLS period " << k << " joint " << j;
      ASSERT_EQ(rtl_result.limited[j], loop.golden_limited[j]) << "RTL period " << k << " joint " << j;
      const JointFixedState from_hls = hls_state(j);
      const JointFixedState from_rtl = rtl.state(j);
      ASSERT_TRUE(from_hls == loop.golden[j]) << "HLS period " << k << " joint " << j << " golden "
                                              << describe(loop.golden[j]) << " hls " << describe(from_hls);
      ASSERT_TRUE(from_rtl == loop.golden[j]) << "RTL period " << k << " joint " << j << " golden "
                                              << describe(loop.golden[j]) << " rtl " << describe(from_rtl);
    }
    loop.step_plants();
  }
  std::cout << periods << " periods x 3 joints bit-exact; " << loop.glitches << " reference glitches, "
            << loop.limited_periods << " limited joint-periods, " << loop.overflows << " saturations\n";
  // The random drive must have exercised the limit and the saturation paths.
  EXPECT_GT(loop.limited_periods, 0);
  EXPECT_GT(loop.overflows, 0);
}

// Coefficient literals in the HLS header and the RTL package equal the golden model's.
TEST(JointBitExact, HlsAndRtlCoefficientsEqualTheGoldenModel) {
  const JointFixedCoefficients c = make_fixed_coefficients(JointControllerParameters{});
  const std::array<std::pair<const char*, std::int32_t>, 9> expected{{
      {"ReferenceGain", c.reference_gain},
      {"VelocityEncoderGain", c.velocity_encoder_gain},
      {"VelocityCurrentGain", c.velocity_current_gain},
      {"DisturbanceGain", c.disturbance_gain},
      {"DisturbanceVelocityGain", c.disturbance_velocity_gain},
      {"LawAccelerationGain", c.law_acceleration_gain},
      {"LawVelocityGain", c.law_velocity_gain},
      {"LawPositionGain", c.law_position_gain},
      {"CurrentLimit", c.current_limit_code}}};
  const std::array<std::int32_t, 9> hls{hls_joint::kReferenceGain,        hls_joint::kVelocityEncoderGain,
                                        hls_joint::kVelocityCurrentGain,  hls_joint::kDisturbanceGain,
                                        hls_joint::kDisturbanceVelocityGain, hls_joint::kLawAccelerationGain,
                                        hls_joint::kLawVelocityGain,      hls_joint::kLawPositionGain,
                                        hls_joint::kCurrentLimitCode};
  std::ifstream file(std::string(DELTA_SOURCE_DIR) + "/rtl/joint/delta_joint_pkg.sv");
  std::stringstream text;
  text << file.rdbuf();
  for (std::size_t n = 0; n < expected.size(); ++n) {
    EXPECT_EQ(hls[n], expected[n].second) << expected[n].first;
    const std::regex pattern(std::string("localparam logic \\[(\\d+):0\\] ") + expected[n].first +
                             "\\s*=\\s*\\d+'h([0-9A-Fa-f]+);");
    std::smatch match;
    const std::string body = text.str();
    ASSERT_TRUE(std::regex_search(body, match, pattern)) << expected[n].first << " missing in delta_joint_pkg.sv";
    const int bits = std::stoi(match[1]) + 1;
    std::int64_t value = std::stoll(match[2], nullptr, 16);
    if (value >= (std::int64_t{1} << (bits - 1))) value -= std::int64_t{1} << bits;  // two's complement
    EXPECT_EQ(value, expected[n].second) << expected[n].first << " in delta_joint_pkg.sv";
  }
}

}  // namespace
}  // namespace delta::control

// libsystemc's main() calls sc_main; GoogleTest's main runs instead, but the symbol must exist.
int sc_main(int, char**) { return 0; }
