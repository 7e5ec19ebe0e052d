// Golden model, HLS C simulation and Verilated RTL of the three joints: same codes, closed loop.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>

#include "delta/control/closed_loop.hpp"
#include "delta/geometry.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/joint_plant.hpp"
#include "delta/rtl/joint_rtl_model.hpp"
#include "joint_top.hpp"
#include "random_closed_loop.hpp"
#include "support/tree_paths.hpp"

namespace delta::control {
namespace {

typedef DeltaJointConfig HlsConfig;

// The integer code of an HLS value with `Fraction` fraction bits in `Bits` bits.
template <int Bits, int Fraction, class Fixed>
std::int32_t code(const Fixed& value) {
  return static_cast<std::int32_t>(delta_hls::fixed_to_code<Bits, Fraction>(value));
}

golden::JointFixedState hls_state(int joint) {
  const delta_hls::JointState<HlsConfig> s = joint_top_state(joint);
  golden::JointFixedState state;
  state.reference = code<HlsConfig::reference_bits, golden::kReferenceFraction>(s.reference);
  state.reference_velocity = code<HlsConfig::state_bits, golden::kStateFraction>(s.reference_velocity);
  state.reference_acceleration = code<HlsConfig::state_bits, golden::kStateFraction>(s.reference_acceleration);
  state.encoder = code<HlsConfig::encoder_bits, 0>(s.encoder);
  state.velocity = code<HlsConfig::state_bits, golden::kStateFraction>(s.velocity);
  state.disturbance = code<HlsConfig::state_bits, golden::kStateFraction>(s.disturbance);
  state.current = code<HlsConfig::current_bits, golden::kCurrentFraction>(s.current);
  state.shift = code<HlsConfig::shift_bits, 0>(s.shift);
  return state;
}

std::string describe(const golden::JointFixedState& s) {
  std::ostringstream out;
  out << "{r " << s.reference << ", vr " << s.reference_velocity << ", ar " << s.reference_acceleration << ", e "
      << s.encoder << ", v " << s.velocity << ", d " << s.disturbance << ", i " << s.current << ", s " << s.shift
      << "}";
  return out.str();
}

// Random references (sinusoids, steps, rare one-period glitches over the whole int32 range),
// random play shifts and random load torques drive three plants in closed loop with the golden controller; the
// HLS top and the RTL see the same inputs and must produce the same codes and states.
TEST(JointBitExact, GoldenHlsAndRtlAgreeOnClosedLoopWithRandomReferencesAndLoads) {
  const std::uint64_t seed = test_seed();
  std::cout << "seed " << seed << " (DELTA_TEST_SEED overrides)\n";
  RandomClosedLoop loop(seed);
  joint_top_reset();
  rtl::JointRtlModel rtl;
  const long periods = 100000;
  for (long k = 0; k < periods; ++k) {
    const std::array<golden::JointFixedInput, 3>& inputs = loop.next_inputs(k);
    HlsConfig::reference_t hls_reference[3];
    HlsConfig::encoder_t hls_encoder[3];
    HlsConfig::shift_t hls_shift[3];
    HlsConfig::current_t hls_current[3];
    for (int j = 0; j < 3; ++j) {
      hls_reference[j] =
          delta_hls::fixed_from_code<HlsConfig::reference_t, HlsConfig::reference_bits, golden::kReferenceFraction>(
              inputs[j].reference);
      hls_encoder[j] = delta_hls::fixed_from_code<HlsConfig::encoder_t, HlsConfig::encoder_bits, 0>(inputs[j].encoder);
      hls_shift[j] = delta_hls::fixed_from_code<HlsConfig::shift_t, HlsConfig::shift_bits, 0>(inputs[j].shift);
    }
    HlsConfig::limited_t hls_limited;
    HlsConfig::overflow_count_t hls_overflows;
    joint_top(hls_reference, hls_encoder, hls_shift, hls_current, hls_limited, hls_overflows);
    const rtl::JointRtlResult rtl_result = rtl.run(inputs);

    ASSERT_EQ(hls_overflows.to_uint(), loop.overflow_code()) << "period " << k;
    ASSERT_EQ(rtl_result.overflow_count, loop.overflow_code()) << "period " << k;
    ASSERT_EQ(rtl_result.cycles, 1072) << "latency, period " << k;
    for (int j = 0; j < 3; ++j) {
      ASSERT_EQ((code<HlsConfig::current_bits, golden::kCurrentFraction>(hls_current[j])), loop.golden_current[j])
          << "HLS period " << k << " joint " << j;
      ASSERT_EQ(rtl_result.current[j], loop.golden_current[j]) << "RTL period " << k << " joint " << j;
      ASSERT_EQ(static_cast<bool>(hls_limited[j]), loop.golden_limited[j]) << "HLS period " << k << " joint " << j;
      ASSERT_EQ(rtl_result.limited[j], loop.golden_limited[j]) << "RTL period " << k << " joint " << j;
      const golden::JointFixedState from_hls = hls_state(j);
      const golden::JointFixedState from_rtl = rtl.state(j);
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

// The coefficient codes compiled into the HLS top (the generated header) and the literals of the
// RTL package, its play-shift width too, equal the golden model's.
TEST(JointBitExact, HlsAndRtlCoefficientsEqualTheGoldenModel) {
  const golden::JointFixedCoefficients c = golden::make_fixed_coefficients(golden::JointControllerParameters{});
  const std::array<std::pair<const char*, std::int32_t>, 9> expected{
      {{"ReferenceGain", c.reference_gain},
       {"VelocityEncoderGain", c.velocity_encoder_gain},
       {"VelocityCurrentGain", c.velocity_current_gain},
       {"DisturbanceGain", c.disturbance_gain},
       {"DisturbanceVelocityGain", c.disturbance_velocity_gain},
       {"LawAccelerationGain", c.law_acceleration_gain},
       {"LawVelocityGain", c.law_velocity_gain},
       {"LawPositionGain", c.law_position_gain},
       {"CurrentLimit", c.current_limit_code}}};
  const delta_hls::JointCoefficientCodes h = joint_top_coefficient_codes();
  const std::array<std::int32_t, 9> hls{h.reference_gain,    h.velocity_encoder_gain,     h.velocity_current_gain,
                                        h.disturbance_gain,  h.disturbance_velocity_gain, h.law_acceleration_gain,
                                        h.law_velocity_gain, h.law_position_gain,         h.current_limit};
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
  std::smatch match;
  const std::string body = text.str();
  ASSERT_TRUE(std::regex_search(body, match, std::regex("localparam int unsigned ShiftBits = (\\d+);")))
      << "ShiftBits missing in delta_joint_pkg.sv";
  EXPECT_EQ(std::stoi(match[1]), golden::kShiftBits) << "ShiftBits in delta_joint_pkg.sv";
}

// The chosen widths of the HLS config are the golden model's formats.
TEST(JointBitExact, HlsConfigFormatsEqualTheGoldenModel) {
  EXPECT_EQ(HlsConfig::reference_fraction, golden::kReferenceFraction);
  EXPECT_EQ(HlsConfig::state_fraction, golden::kStateFraction);
  EXPECT_EQ(HlsConfig::current_fraction, golden::kCurrentFraction);
  EXPECT_EQ(HlsConfig::coefficient_bits, golden::kCoefficientBits);
  EXPECT_EQ(HlsConfig::operand_bits, golden::kOperandBits);
  EXPECT_EQ(HlsConfig::reference_shift, golden::kReferenceShift);
  EXPECT_EQ(HlsConfig::velocity_shift, golden::kVelocityShift);
  EXPECT_EQ(HlsConfig::disturbance_shift, golden::kDisturbanceShift);
  EXPECT_EQ(HlsConfig::law_shift, golden::kLawShift);
  EXPECT_EQ(HlsConfig::shift_bits, golden::kShiftBits);
  // The golden accumulator (66 bits) also holds the rounding half-LSB; the HLS casts round instead.
  EXPECT_LE(HlsConfig::command_accumulator_bits, golden::kAccumulatorBits);
}

}  // namespace
}  // namespace delta::control

// libsystemc's main() calls sc_main; GoogleTest's main runs instead, but the symbol must exist.
int sc_main(int, char**) { return 0; }
