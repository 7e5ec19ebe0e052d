// Golden model, HLS C simulation and Verilated RTL of the three joints: same codes, closed loop.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>

#include "delta/control/closed_loop.hpp"
#include "delta/control/joint_fixed.hpp"
#include "delta/geometry.hpp"
#include "delta/joint_plant.hpp"
#include "delta/rtl/joint_rtl_model.hpp"
#include "joint_top.hpp"

namespace delta::control {
namespace {

std::uint64_t test_seed() {
  const char* text = std::getenv("DELTA_TEST_SEED");
  return text ? std::strtoull(text, nullptr, 10) : 20261121u;
}

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
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);

  const JointControllerParameters parameters;
  const JointFixedCoefficients coefficients = make_fixed_coefficients(parameters);
  std::array<JointPlant, 3> plants{JointPlant(default_plant(), 30.0), JointPlant(default_plant(), 20.0),
                                   JointPlant(default_plant(), 40.0)};
  struct Drive {
    double base_deg, amplitude_deg, frequency_hz, step_deg = 0.0, load_nm = 0.0;
  };
  std::array<Drive, 3> drives;
  for (int j = 0; j < 3; ++j) {
    drives[j] = {plants[j].shaft_angle_deg(), 1.0 + 4.0 * unit(random), 0.1 + 2.0 * unit(random)};
  }

  std::array<JointFixedState, 3> golden;
  hls_joint::joint_top_reset();
  rtl::JointRtlModel rtl;
  const long periods = 100000;
  long limited_periods = 0, glitches = 0;
  int golden_overflows = 0;
  for (long k = 0; k < periods; ++k) {
    const double t = k * parameters.period_s;
    std::array<JointFixedInput, 3> inputs;
    for (int j = 0; j < 3; ++j) {
      Drive& drive = drives[j];
      if (unit(random) < 1e-3) drive.step_deg = 4.0 * (unit(random) - 0.5);
      if (unit(random) < 5e-4) drive.load_nm = 0.1 * (unit(random) - 0.5);
      const double reference = drive.base_deg + drive.step_deg +
                                drive.amplitude_deg * std::sin(2.0 * kPi * drive.frequency_hz * t);
      inputs[j].reference = reference_code(reference, parameters.encoder_resolution_deg);
      if (unit(random) < 2e-4) {
        inputs[j].reference = static_cast<std::int32_t>(random());
        ++glitches;
      }
      inputs[j].encoder = static_cast<std::int16_t>(std::clamp(plants[j].encoder_count(), -32768, 32767));
    }
    if (k == 0) {
      for (int j = 0; j < 3; ++j) golden[j] = fixed_rest_state(inputs[j]);
    }
    std::array<std::int16_t, 3> golden_current;
    std::array<bool, 3> golden_limited;
    for (int j = 0; j < 3; ++j) {
      JointFixedStatus status;
      golden_current[j] = fixed_update(coefficients, golden[j], inputs[j], status);
      golden_limited[j] = status.limited;
      golden_overflows += status.overflow_count;
      limited_periods += status.limited;
    }

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

    const std::uint16_t expected_overflows = static_cast<std::uint16_t>(std::min(golden_overflows, 0xFFFF));
    ASSERT_EQ(hls_overflows.to_uint(), expected_overflows) << "period " << k;
    ASSERT_EQ(rtl_result.overflow_count, expected_overflows) << "period " << k;
    for (int j = 0; j < 3; ++j) {
      ASSERT_EQ(raw(hls_current[j], kCurrentFraction), golden_current[j]) << "HLS period " << k << " joint " << j;
      ASSERT_EQ(rtl_result.current[j], golden_current[j]) << "RTL period " << k << " joint " << j;
      ASSERT_EQ(static_cast<bool>(hls_limited[j]), golden_limited[j]) << "HLS period " << k << " joint " << j;
      ASSERT_EQ(rtl_result.limited[j], golden_limited[j]) << "RTL period " << k << " joint " << j;
      const JointFixedState from_hls = hls_state(j);
      const JointFixedState from_rtl = rtl.state(j);
      ASSERT_TRUE(from_hls == golden[j]) << "HLS period " << k << " joint " << j << " golden " << describe(golden[j])
                                         << " hls " << describe(from_hls);
      ASSERT_TRUE(from_rtl == golden[j]) << "RTL period " << k << " joint " << j << " golden " << describe(golden[j])
                                         << " rtl " << describe(from_rtl);
      ASSERT_EQ(rtl_result.cycles, 892) << "latency, period " << k;
    }
    for (int j = 0; j < 3; ++j) {
      plants[j].step(current_from_code(golden_current[j]), parameters.period_s, drives[j].load_nm);
    }
  }
  std::cout << periods << " periods x 3 joints bit-exact; " << glitches << " reference glitches, " << limited_periods
            << " limited joint-periods, " << golden_overflows << " saturations\n";
  // The random drive must have exercised the limit and the saturation paths.
  EXPECT_GT(limited_periods, 0);
  EXPECT_GT(golden_overflows, 0);
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
