// The deployed model's backlash compensation on output codes: the golden model against its
// definition (hls/README.md, "Backlash compensation") and the HLS C++ against the golden model.
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "delta/golden/fixed_network.hpp"
#include "delta/golden/test_vectors.hpp"
#include "delta/nn/trained_model.hpp"
#include "network_csim.hpp"

namespace delta::golden {
namespace {

using Codes = std::array<std::int64_t, 3>;

TEST(GoldenCompensation, FirstAnswerPassesThenTheReferenceHoldsInsideThePlayAndFollowsOutside) {
  QuantisedCompensation compensation;
  compensation.half_play = {100, 0, 7};
  CompensationState state;
  // Joint 1 (h = 100): start at 1000, rise to 1150 (leaves the play: 1150 - 100), fall to 1030
  // (inside), fall to 900 (leaves downwards: 900 + 100), stay. Joint 2 (h = 0) follows exactly.
  const std::vector<std::pair<Codes, Codes>> steps = {{{1000, -5, 0}, {1000, -5, 0}},
                                                      {{1150, 3, 7}, {1050, 3, 0}},
                                                      {{1030, -2, 8}, {1050, -2, 1}},
                                                      {{900, -2, -6}, {1000, -2, 1}},
                                                      {{900, 40, -7}, {1000, 40, 0}}};
  for (const auto& [input, expected] : steps) {
    EXPECT_EQ(compensate(compensation, state, input), expected) << input[0] << " " << input[1] << " " << input[2];
  }
}

// The golden play on codes is the float play (delta::Backlash, the virtual robot's) on the decoded
// angles, to within one output LSB, on a seeded random walk.
TEST(GoldenCompensation, IsTheVirtualRobotsPlayOnCodes) {
  const std::uint64_t seed = 151;
  std::printf("seed %llu\n", static_cast<unsigned long long>(seed));
  std::mt19937_64 generator(seed);
  std::normal_distribution<double> step_deg(0.0, 0.02);
  const Formats formats;
  const Vec3 half_play_deg(0.075, 0.015, 0.2);
  const QuantisedCompensation q = quantise_compensation(half_play_deg);
  Vec3 quantised_half_play;
  for (int j = 0; j < 3; ++j) quantised_half_play[j] = decode_angle_deg(formats, q.half_play[j]);
  nn::BacklashCompensation play(quantised_half_play);
  CompensationState state;
  Vec3 angle(30.0, 25.0, 35.0);
  double worst = 0.0;
  for (int i = 0; i < 20000; ++i) {
    for (int j = 0; j < 3; ++j) angle[j] += step_deg(generator);
    Codes codes{};
    for (int j = 0; j < 3; ++j) codes[j] = static_cast<std::int64_t>(std::llround(std::ldexp(angle[j], 14)));
    Vec3 decoded;
    for (int j = 0; j < 3; ++j) decoded[j] = decode_angle_deg(formats, codes[j]);
    const Vec3 expected = play.update(decoded);
    const Codes got = compensate(q, state, codes);
    for (int j = 0; j < 3; ++j) worst = std::max(worst, std::abs(decode_angle_deg(formats, got[j]) - expected[j]));
  }
  EXPECT_LT(worst, 1e-9);  // both are exact on the same grid
}

TEST(GoldenCompensation, QuantisesHalfPlaysAndRefusesWhatTheFormatCannotHold) {
  const QuantisedCompensation q = quantise_compensation(Vec3(0.075, 0.015, 0.0));
  // Whole numbers of 16 output LSBs (2^-10 deg), so the board's reference shift 25 h / 16 is exact.
  EXPECT_EQ(q.half_play[0], 1232);  // 0.075 * 2^10 = 76.8 -> 77 x 16
  EXPECT_EQ(q.half_play[1], 240);   // 15.36 -> 15 x 16
  EXPECT_EQ(q.half_play[2], 0);
  EXPECT_EQ(quantise_compensation(Vec3(0.0, 0.0, 0.0078125)).half_play[2], 128);       // 8 x 16 exactly
  EXPECT_EQ(quantise_compensation(Vec3(0.0, 0.0, 0.00048828125)).half_play[2], 16);    // 0.5 x 16: half up
  EXPECT_THROW(quantise_compensation(Vec3(4.0, 0.0, 0.0)), std::invalid_argument);     // 2^16 LSBs
  EXPECT_THROW(quantise_compensation(Vec3(3.9999, 0.0, 0.0)), std::invalid_argument);  // rounds up to 2^16
  EXPECT_EQ(quantise_compensation(Vec3(3.999, 0.0, 0.0)).half_play[0], 65520);         // the widest: 2^16 - 16
  EXPECT_THROW(quantise_compensation(Vec3(-0.001, 0.0, 0.0)), std::invalid_argument);
}

}  // namespace
}  // namespace delta::golden

namespace delta_hls {
namespace {

using Config = DefaultNetworkConfig;

// Seeded random walks of network answers (delta::golden::compensation_walks: steps of up to three
// half-plays, jumps to the format's edges, the widest half-play) through the HLS compensation and
// the golden one: every reference code equal, and every reference inside the output format.
TEST(HlsCompensation, EqualsTheGoldenModelOnRandomWalksToTheFormatsEdges) {
  const std::uint64_t seed = 15;
  std::printf("seed %llu\n", static_cast<unsigned long long>(seed));
  const delta::golden::Formats formats = golden_formats<Config>();
  const std::int64_t top = (std::int64_t{1} << (formats.output_bits - 1)) - 1;
  const std::int64_t bottom = -(std::int64_t{1} << (formats.output_bits - 1));
  std::size_t steps = 0, mismatches = 0, holds = 0, edges = 0;
  for (const delta::golden::CompensationWalk& walk : delta::golden::compensation_walks(formats, 40, 2500, seed)) {
    CompensationCodes<Config> hls(walk.compensation);
    delta::golden::CompensationState golden;
    for (const std::array<std::int64_t, 3>& s : walk.answers) {
      const std::array<std::int64_t, 3> previous = golden.reference;
      const bool started = golden.started;
      const std::array<std::int64_t, 3> expected = delta::golden::compensate(walk.compensation, golden, s);
      const std::array<std::int64_t, 3> got = hls.step(s);
      holds += started && expected[0] == previous[0] && expected[0] != s[0];
      for (int j = 0; j < 3; ++j) {
        edges += s[j] == top || s[j] == bottom;
        EXPECT_TRUE(expected[j] >= bottom && expected[j] <= top);
      }
      if (got != expected && ++mismatches <= 5) {
        ADD_FAILURE() << "step " << steps << ": HLS " << got[0] << " " << got[1] << " " << got[2] << " golden "
                      << expected[0] << " " << expected[1] << " " << expected[2];
      }
      ++steps;
    }
  }
  std::printf("%zu steps, %zu mismatches, %zu answers at the format's edges, %zu joint-1 references held\n", steps,
              mismatches, edges, holds);
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(edges, steps / 100);  // the walks reach the format's edges
  EXPECT_GT(holds, steps / 10);   // and the play holds often
}

}  // namespace
}  // namespace delta_hls
