// The golden model of the setpoint interpolation (host/golden/include/delta/golden/
// setpoint_interpolation.hpp) against docs/board_link.md: r_0 = B, the next segment starts at
// B + D, r_9 within 1 LSB of B + 0.9 D for small changes, saturation counted and caught up, hold
// and the drives-off reference, and every formula for every k bit for bit against a long double
// reference computed from the physical units (seeds printed).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <random>

#include "delta/golden/fixed_network.hpp"
#include "delta/golden/setpoint_interpolation.hpp"

namespace delta::golden {
namespace {

using interpolation::kPeriods;
using References = SetpointInterpolator::References;
constexpr std::int32_t kAnswerMin = -(1 << 23), kAnswerMax = (1 << 23) - 1;  // 24-bit output codes

// The long double references: every operand is an integer below 2^40, so each product and
// quotient by a power of two is exact in its 64-bit mantissa, and floorl(x + 0.5) is round half up.
long double round_half_up(long double x) { return std::floor(x + 0.5L); }
std::int64_t reference_counts_exact(std::int32_t y) {
  const long double degrees = y / 16384.0L;                                    // Q10.14
  return static_cast<std::int64_t>(round_half_up(degrees * 100.0L * 256.0L));  // 0.01 deg counts, Q.8
}
std::int64_t weight_exact(int k) { return static_cast<std::int64_t>(round_half_up(k * 16384.0L / 10.0L)); }
std::int64_t delta_exact(std::int64_t c, std::int64_t b) {
  return std::max<std::int64_t>(-32768, std::min<std::int64_t>(32767, c - b));
}
std::int64_t interpolated_exact(std::int64_t b, std::int64_t d, int k) {
  return b + static_cast<std::int64_t>(round_half_up(d * static_cast<long double>(weight_exact(k)) / 16384.0L));
}

std::array<std::int32_t, 3> random_answer(std::mt19937_64& random) {
  std::uniform_int_distribution<std::int32_t> code(kAnswerMin, kAnswerMax);
  return {code(random), code(random), code(random)};
}

TEST(SetpointInterpolation, WeightsAreTheRoundedTenths) {
  ASSERT_EQ(kPeriods, 10);
  for (int k = 0; k < kPeriods; ++k) {
    EXPECT_EQ(interpolation::kWeights[k], weight_exact(k)) << k;
    EXPECT_EQ(interpolation::kWeights[k], (k * 16384 + 5) / 10) << k;
  }
}

TEST(SetpointInterpolation, EveryFormulaIsExactForEveryKOnRandomValues) {
  const std::uint64_t seed = 20261202;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  std::uniform_int_distribution<std::int32_t> code(kAnswerMin, kAnswerMax), near(-40000, 40000);
  std::size_t saturated = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    const std::int32_t y = code(random);
    const std::int32_t c = interpolation::reference_counts(y);
    ASSERT_EQ(c, reference_counts_exact(y)) << "y " << y;
    // B near C (small and just saturating changes) or anywhere in the answers' range.
    const std::int32_t b = trial % 2 ? c + near(random) : interpolation::reference_counts(code(random));
    const interpolation::SegmentDelta d = interpolation::segment_delta(c, b);
    ASSERT_EQ(d.value, delta_exact(c, b)) << "c " << c << " b " << b;
    ASSERT_EQ(d.saturated, d.value != std::int64_t{c} - b);
    saturated += d.saturated;
    for (int k = 0; k < kPeriods; ++k) {
      ASSERT_EQ(interpolation::interpolated(b, d.value, k), interpolated_exact(b, d.value, k))
          << "b " << b << " d " << d.value << " k " << k;
    }
    ASSERT_EQ(interpolation::next_start(b, d.value), std::int64_t{b} + d.value);
  }
  std::cout << saturated << " of 200000 segment deltas saturated\n";
  EXPECT_GT(saturated, 1000u);
  // The corners of the answer range and of the delta.
  for (std::int32_t y : {kAnswerMin, kAnswerMin + 1, -1, 0, 1, 7, 8, 9, kAnswerMax}) {
    EXPECT_EQ(interpolation::reference_counts(y), reference_counts_exact(y)) << y;
  }
  for (std::int32_t d : {-32768, -32767, -1, 1, 32767}) {
    for (int k = 0; k < kPeriods; ++k) EXPECT_EQ(interpolation::interpolated(0, d, k), interpolated_exact(0, d, k));
  }
}

TEST(SetpointInterpolation, SegmentStartsAtBAndTheNextAtBPlusD) {
  const std::uint64_t seed = 5;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  SetpointInterpolator interpolator;
  interpolator.follow_encoders({3000, 2990, 3010});
  for (int segment = 0; segment < 5000; ++segment) {
    const References previous_start = interpolator.start(), previous_delta = interpolator.delta();
    if (segment % 7 == 3) {
      interpolator.begin_hold_segment();
    } else {
      interpolator.begin_segment(random_answer(random));
    }
    const References d = interpolator.delta();
    const auto periods = interpolator.segment();
    for (int j = 0; j < 3; ++j) {
      // This segment starts where the one before ended, its B + D, and r_0 is that start.
      ASSERT_EQ(interpolator.start()[j], std::int64_t{previous_start[j]} + previous_delta[j]) << "segment " << segment;
      ASSERT_EQ(periods[0][j], interpolator.start()[j]);
      ASSERT_EQ(periods[0][j], interpolator.reference(0)[j]);
      for (int k = 1; k < kPeriods; ++k) {  // monotonic towards B + D
        ASSERT_TRUE(d[j] >= 0 ? periods[k][j] >= periods[k - 1][j] : periods[k][j] <= periods[k - 1][j]);
      }
    }
  }
}

TEST(SetpointInterpolation, AfterTenPeriodsTheNextSegmentStartsAtBPlusD) {
  SetpointInterpolator interpolator;
  interpolator.follow_encoders({0, 100, -100});
  interpolator.begin_segment({16384, 0, 0});  // +1 deg, 0 deg, 0 deg: 100, 0, 0 counts
  const References b = interpolator.start(), d = interpolator.delta();
  EXPECT_EQ(b, (References{0, 100 << 8, -100 * 256}));
  EXPECT_EQ(d, (References{100 * 256, -100 * 256, 100 * 256}));
  interpolator.begin_hold_segment();
  for (int j = 0; j < 3; ++j) EXPECT_EQ(interpolator.start()[j], b[j] + d[j]);
  EXPECT_EQ(interpolator.start(), (References{100 * 256, 0, 0}));
  EXPECT_EQ(interpolator.delta(), (References{0, 0, 0}));
  for (int k = 0; k < kPeriods; ++k) EXPECT_EQ(interpolator.reference(k), interpolator.start());  // held
}

TEST(SetpointInterpolation, SmallChangesReachNineTenthsWithinOneLsbAtTheLastPeriod) {
  const std::uint64_t seed = 91;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  std::uniform_int_distribution<std::int32_t> start(-2'000'000, 2'000'000), change(-16384, 16384);
  long double worst = 0;
  for (int trial = 0; trial < 100000; ++trial) {
    const std::int32_t b = start(random), c = b + change(random);
    const interpolation::SegmentDelta d = interpolation::segment_delta(c, b);
    ASSERT_FALSE(d.saturated);
    const long double error = std::fabs(interpolation::interpolated(b, d.value, kPeriods - 1) - (b + 0.9L * d.value));
    worst = std::max(worst, error);
    ASSERT_LE(error, 1.0L) << "b " << b << " c " << c;
  }
  std::cout << "worst |r_9 - (B + 0.9 D)|: " << static_cast<double>(worst) << " LSB (1/256 count)\n";
}

TEST(SetpointInterpolation, SaturationIsCountedAndTheReferenceCatchesUp) {
  SetpointInterpolator interpolator;
  interpolator.follow_encoders({0, 0, 0});
  // Joint 0 jumps by 10 deg (1000 counts = 256000 Q.8: about 7.8 segments' worth); the others move 0.1 deg.
  const std::array<std::int32_t, 3> answer = {10 * 16384, 1638, -1638};
  const std::int32_t target = interpolation::reference_counts(answer[0]);
  int segments = 0;
  while (interpolator.start()[0] + interpolator.delta()[0] != target || segments == 0) {
    interpolator.begin_segment(answer);
    ASSERT_LE(++segments, 20);
    if (interpolator.start()[0] + interpolator.delta()[0] != target) {
      EXPECT_EQ(interpolator.delta()[0], interpolation::kDeltaMax) << "segment " << segments;
    }
  }
  EXPECT_EQ(segments, (target + interpolation::kDeltaMax - 1) / interpolation::kDeltaMax);
  EXPECT_EQ(interpolator.saturations()[0], static_cast<std::uint64_t>(segments - 1));
  EXPECT_EQ(interpolator.saturations()[1], 0u);
  EXPECT_EQ(interpolator.saturations()[2], 0u);
  interpolator.begin_segment(answer);  // arrived: D = 0 from now on
  EXPECT_EQ(interpolator.start()[0], target);
  EXPECT_EQ(interpolator.delta()[0], 0);
  EXPECT_EQ(interpolator.saturations()[0], static_cast<std::uint64_t>(segments - 1));
  // Downwards: the negative limit.
  interpolator.begin_segment({-10 * 16384, 0, 0});
  EXPECT_EQ(interpolator.delta()[0], interpolation::kDeltaMin);
  EXPECT_EQ(interpolator.saturations()[0], static_cast<std::uint64_t>(segments));
}

TEST(SetpointInterpolation, DrivesOffTheReferenceIsTheEncoderCountAndEnablingStartsThere) {
  SetpointInterpolator interpolator;
  interpolator.follow_encoders({3000, -5, 32767});
  EXPECT_FALSE(interpolator.enabled());
  for (int k = 0; k < kPeriods; ++k)
    EXPECT_EQ(interpolator.reference(k), (References{3000 << 8, -5 * 256, 32767 << 8}));
  interpolator.begin_segment({0, 0, 0});
  EXPECT_TRUE(interpolator.enabled());
  EXPECT_EQ(interpolator.reference(0), (References{3000 << 8, -5 * 256, 32767 << 8}));  // r_0 = B: no step
  interpolator.follow_encoders({-32768, 0, 1});
  EXPECT_EQ(interpolator.reference(kPeriods - 1), (References{-32768 * 256, 0, 256}));
  EXPECT_EQ(interpolator.delta(), (References{0, 0, 0}));
}

// The deployed model's compensation on the board (play(C - B, H), H = 25 h / 16) against the
// golden compensation of the answers (golden::compensate): seeded random walks of answers with
// steps up to three half-plays and direction reversals, half-plays from 0 to the format's widest.
// While the reference follows (no slew limit, hold or drives off), every segment's target B + D is
// round_shift(25 r, 4) of the golden reference r, bit for bit; and play(d, 0) = d.
TEST(SetpointInterpolation, TheBoardsPlayEqualsTheGoldenCompensationOfTheAnswers) {
  const std::uint64_t seed = 1515;
  std::printf("seed %llu\n", static_cast<unsigned long long>(seed));
  std::mt19937_64 random(seed);
  const Formats formats;
  const std::int64_t widest =
      (std::int64_t{1} << formats.half_play_bits) - (std::int64_t{1} << formats.half_play_step_bits);
  std::int64_t compared = 0, moved = 0, held = 0;
  for (int walk = 0; walk < 200; ++walk) {
    QuantisedCompensation compensation;
    for (int j = 0; j < 3; ++j) {
      std::uniform_int_distribution<std::int64_t> steps(0, widest >> formats.half_play_step_bits);
      compensation.half_play[j] = walk == 0 ? 0 : (walk == 1 ? widest : steps(random) << formats.half_play_step_bits);
    }
    SetpointInterpolator board(interpolation::half_play_counts(compensation));
    CompensationState state;
    state.started = true;  // r = 0 = B: both start at the same reference
    std::array<std::int64_t, 3> answer{};
    for (int n = 0; n < 300; ++n) {
      std::array<std::int32_t, 3> code{};
      for (int j = 0; j < 3; ++j) {
        // steps within +-3 half-plays (at least +-64 LSBs), capped so D never saturates
        const std::int64_t span =
            std::min<std::int64_t>(std::max<std::int64_t>(3 * compensation.half_play[j], 64), 20000);
        std::uniform_int_distribution<std::int64_t> step(-span, span);
        answer[j] += step(random);
        code[j] = static_cast<std::int32_t>(answer[j]);
      }
      const std::array<std::int64_t, 3> golden = compensate(compensation, state, answer);
      board.begin_segment(code);
      for (int j = 0; j < 3; ++j) {
        const std::int64_t target = std::int64_t{board.start()[j]} + board.delta()[j];
        ASSERT_EQ(target, interpolation::reference_counts(static_cast<std::int32_t>(golden[j])))
            << "walk " << walk << " answer " << n << " joint " << j << " h " << compensation.half_play[j];
        ++compared;
        (board.delta()[j] != 0 ? moved : held) += 1;
      }
    }
    EXPECT_EQ(board.saturations(), (std::array<std::uint64_t, 3>{})) << "walk " << walk;
  }
  std::cout << compared << " targets compared, " << moved << " moved, " << held << " held inside the play\n";
  EXPECT_GT(held, compared / 10);
  EXPECT_GT(moved, compared / 4);
  EXPECT_EQ(play(12345, 0), 12345);
  EXPECT_EQ(play(-7, 0), -7);
  EXPECT_EQ(play(100, 100), 0);
  EXPECT_EQ(play(-101, 100), -1);
}

// The play shift against its definition, for every half-play the format can carry
// (whole numbers of 16 output LSBs, H = 25 h / 16): s = floor((clamp(d, -H, H) + g) / 256),
// non-decreasing in d, 0 for H = 0, within 10 bits; and at both ends of the play it does not move
// while the answer wobbles up to a quarter count inward (63 Q.8), so a steady motion, which sits
// at an end, never sees its shift flip. With g = 0 that fails for round plays (0.04 deg: H =
// 1025, one LSB above 4 counts).
TEST(SetpointInterpolation, ThePlayShiftIsStillAtBothEndsOfEveryPlay) {
  const Formats formats;
  const std::int64_t step = std::int64_t{1} << formats.half_play_step_bits;
  std::int64_t plays = 0, flips_without_offset = 0;
  for (std::int64_t code = 0; code < (std::int64_t{1} << formats.half_play_bits); code += step) {
    const std::int32_t h = interpolation::half_play_counts(code);
    const std::int32_t g = interpolation::play_shift_offset(h);
    ASSERT_TRUE(g == 0 || g == 128);
    const std::int16_t top = interpolation::play_shift(h + 1000, h);
    const std::int16_t bottom = interpolation::play_shift(-h - 1000, h);
    ASSERT_EQ(top, (h + g) >> 8) << "h " << code;
    ASSERT_EQ(bottom, (g - h) >> 8) << "h " << code;
    ASSERT_LT(top, 512);
    ASSERT_GE(bottom, -512);
    for (std::int32_t wobble = 0; wobble < 64; ++wobble) {
      ASSERT_EQ(interpolation::play_shift(h - wobble, h), top) << "h " << code << " wobble " << wobble;
      ASSERT_EQ(interpolation::play_shift(-h + wobble, h), bottom) << "h " << code << " wobble " << wobble;
    }
    if ((h >> 8) != ((h - 63) >> 8) || ((-h) >> 8) != ((-h + 63) >> 8)) ++flips_without_offset;
    std::int16_t last = bottom;
    for (std::int64_t d = -h; d <= h; d += 37) {
      const std::int16_t shift = interpolation::play_shift(d, h);
      ASSERT_GE(shift, last) << "h " << code << " d " << d;
      last = shift;
    }
    ++plays;
  }
  std::cout << plays << " half-plays; " << flips_without_offset << " would flip at an end without the grid offset\n";
  EXPECT_EQ(interpolation::play_shift(12345, 0), 0);
  EXPECT_EQ(interpolation::play_shift(-12345, 0), 0);
  EXPECT_GE(flips_without_offset, plays / 4);  // a quarter of all plays: H mod 256 within 63 of a boundary
  EXPECT_EQ(interpolation::play_shift_offset(interpolation::half_play_counts(656)), 128);  // 0.04 deg: H = 1025
}

}  // namespace
}  // namespace delta::golden
