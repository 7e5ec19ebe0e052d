// Tests of the golden fixed-point model: casts, the tanh table's error bound, quantisation checks,
// and agreement with the float network on the 10 mm cube.
#include <cmath>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "delta/golden/fixed_network.hpp"
#include "fixed_point_fixture.hpp"

namespace delta::golden {
namespace {

TEST(Casts, RoundShiftIsRoundHalfUp) {
  EXPECT_EQ(round_shift(3, 1), 2);    // 1.5 -> 2
  EXPECT_EQ(round_shift(-3, 1), -1);  // -1.5 -> -1 (towards +infinity on ties)
  EXPECT_EQ(round_shift(-5, 2), -1);  // -1.25 -> -1
  EXPECT_EQ(round_shift(-6, 2), -1);  // -1.5 -> -1
  EXPECT_EQ(round_shift(-7, 2), -2);  // -1.75 -> -2
  EXPECT_EQ(round_shift(5, 0), 5);
  EXPECT_EQ(round_shift(5, -2), 20);
}

TEST(Casts, SaturateClampsAndFlags) {
  bool clamped = false;
  EXPECT_EQ(saturate(32767, 16, &clamped), 32767);
  EXPECT_FALSE(clamped);
  EXPECT_EQ(saturate(32768, 16, &clamped), 32767);
  EXPECT_TRUE(clamped);
  clamped = false;
  EXPECT_EQ(saturate(-40000, 16, &clamped), -32768);
  EXPECT_TRUE(clamped);
}

// Worst case over every code of the tanh input format, against std::tanh of the code's exact value.
TEST(TanhTable, WorstCaseErrorAtMostOneLsb) {
  const QuantisedNetwork q = quantise(test::cube_network());
  const Formats& f = q.formats;
  const std::int64_t limit = std::int64_t{1} << (f.tanh_input_bits - 1);
  double worst_lsb = 0.0;
  std::int64_t worst_code = 0;
  for (std::int64_t n = -limit; n < limit; ++n) {
    const double exact =
        std::ldexp(std::tanh(std::ldexp(static_cast<double>(n), -f.tanh_input_fraction_bits)), f.hidden_fraction_bits);
    const double error = std::abs(static_cast<double>(tanh_code(q, n)) - exact);
    if (error > worst_lsb) {
      worst_lsb = error;
      worst_code = n;
    }
  }
  std::cout << "tanh table: " << f.tanh_segments() << " segments, worst error " << worst_lsb << " LSB of Q1."
            << f.hidden_fraction_bits << " at n code " << worst_code << " over " << 2 * limit << " codes\n";
  EXPECT_LE(worst_lsb, 1.0);
}

TEST(TanhTable, IsOddAndBounded) {
  const QuantisedNetwork q = quantise(test::cube_network());
  const std::int64_t limit = std::int64_t{1} << (q.formats.tanh_input_bits - 1);
  const std::int64_t h_max = (std::int64_t{1} << q.formats.hidden_fraction_bits) - 1;
  for (std::int64_t n = 0; n < limit; n += 7) {
    const std::int64_t h = tanh_code(q, n);
    ASSERT_EQ(tanh_code(q, -n), -h) << "n = " << n;
    ASSERT_LE(h, h_max) << "n = " << n;
  }
  for (std::int64_t n = 1; n < limit; n += 13) ASSERT_GE(tanh_code(q, n), tanh_code(q, n - 1)) << "monotonic at " << n;
}

TEST(Quantise, CubeScalingMatchesSpec) {
  const QuantisedNetwork q = quantise(test::cube_network());
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(q.input_exponent[j], -7);  // 2^-7 m = 7.8125 mm >= 1.5 * 5 mm
    EXPECT_EQ(q.input_shift[j], 6);
  }
  // The centre of the cube maps to u = 0, so the network sees b1' alone.
  const Vec3 centre = (test::cube_min_m() + test::cube_max_m()) / 2.0;
  const auto code = encode_position(q.formats, centre);
  for (int j = 0; j < 3; ++j) EXPECT_EQ(code[j], q.input_centre[j]);
}

TEST(Quantise, RefusesWeightsThatSaturate) {
  nn::Network network = test::cube_network();
  network.input_weights(4, 1) = 40.0;  // IW' = 40 * 7.8125 / 5 = 62.5, beyond Q5.19
  try {
    quantise(network);
    FAIL() << "a saturating weight was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("IW'(5,2)"), std::string::npos) << error.what();
  }
  network = test::cube_network();
  network.output_bias[2] = 1e4;
  EXPECT_THROW(quantise(network), std::invalid_argument);
}

TEST(GoldenModel, MatchesFloatInsideTheCubeWithoutSaturation) {
  const nn::Network& network = test::cube_network();
  const QuantisedNetwork q = quantise(network);
  const std::uint64_t seed = 20261121;
  std::cout << "seed " << seed << '\n';
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  SaturationCounters counters;
  Vec3 worst = Vec3::Zero();
  for (int i = 0; i < 200000; ++i) {
    Vec3 p;
    for (int j = 0; j < 3; ++j)
      p[j] = test::cube_min_m()[j] + unit(rng) * (test::cube_max_m()[j] - test::cube_min_m()[j]);
    const RawOutput out = evaluate_raw(q, encode_position(q.formats, p), &counters);
    const Vec3 reference = network.evaluate(p);
    for (int o = 0; o < 3; ++o)
      worst[o] = std::max(worst[o], std::abs(decode_angle_deg(q.formats, out.alpha[o]) - reference[o]));
  }
  std::cout << "max |fixed - float| [deg]: " << worst.transpose() << '\n';
  EXPECT_EQ(counters.errors(), 0u);
  EXPECT_EQ(counters.tanh_input, 0u);
  EXPECT_LE(worst.maxCoeff(), 0.001);
  EXPECT_GT(worst.maxCoeff(), 0.0);  // a quantised model is never exact: guards against comparing a model with itself
}

TEST(GoldenModel, CountsSaturationOutsideTheMargin) {
  const QuantisedNetwork q = quantise(test::cube_network());
  SaturationCounters counters;
  const Vec3 inside(0.0, 0.0, -0.0758);
  const Vec3 beyond(0.0, 0.011, -0.0758);  // 11 mm from the centre: u = 1.4
  evaluate_raw(q, encode_position(q.formats, inside), &counters);
  EXPECT_EQ(counters.scaled_input, 0u);
  const RawOutput out = evaluate_raw(q, encode_position(q.formats, beyond), &counters);
  EXPECT_TRUE(out.scaled_input_saturated);
  EXPECT_EQ(counters.scaled_input, 1u);
  EXPECT_EQ(counters.evaluations, 2u);
}

}  // namespace
}  // namespace delta::golden
