// The model as the board takes it over the link (see model_image.hpp).
#include "delta/golden/model_image.hpp"

#include <stdexcept>
#include <string>

#include "delta/board_facts.hpp"
#include "delta/crc32.hpp"
#include "delta/golden/setpoint_interpolation.hpp"

namespace delta::golden {
namespace {

constexpr int kInputs = 3;
constexpr int kHidden = static_cast<int>(board::kModelBias1Frame - board::kModelWeight1Frame) / kInputs;
static_assert(board::kModelBias1Frame - board::kModelWeight1Frame == 3 * kHidden &&
                  board::kModelWeight2Frame - board::kModelBias1Frame == kHidden &&
                  board::kModelBias2Frame - board::kModelWeight2Frame == 3 * kHidden &&
                  board::kModelPlayFrame - board::kModelBias2Frame == 3 &&
                  board::kModelScalingFrame - board::kModelPlayFrame == 3 &&
                  board::kModelCommitFrame - board::kModelScalingFrame == 3 &&
                  board::kModelFrames == board::kModelCommitFrame + 1,
              "the model's frames in the package are not the image written here");
constexpr int kBias2RoundingShift = 19;  // the output cast's rounding half: 2^(output shift - 1)
constexpr int kBias2Bits = 47;
constexpr int kHalfPlayBits = static_cast<int>(board::kHalfPlayBits);

std::uint64_t field(std::int64_t code, int bits, const std::string& what) {
  const std::int64_t low = -(std::int64_t{1} << (bits - 1));
  const std::int64_t high = (std::int64_t{1} << (bits - 1)) - 1;
  if (code < low || code > high) {
    throw std::invalid_argument("model: " + what + " = " + std::to_string(code) + " does not fit " +
                                std::to_string(bits) + " bits");
  }
  return static_cast<std::uint64_t>(code) & ((std::uint64_t{1} << bits) - 1);
}

std::int64_t signed_field(std::uint64_t word, int bits) {
  const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
  const std::uint64_t value = word & mask;
  return (value >> (bits - 1)) & 1 ? static_cast<std::int64_t>(value | ~mask) : static_cast<std::int64_t>(value);
}

// Joint j's play word from H (Q.8 counts): as reference_interpolator.sv derives its ends.
std::uint64_t play_word(std::int32_t half_play) {
  const bool rounds = ((half_play >> 7) & 1) == ((half_play >> 6) & 1);
  const std::int64_t g = rounds ? 128 : 0;
  const std::uint64_t above = static_cast<std::uint64_t>((half_play + g) >> 8) & 0x3FF;
  const std::uint64_t below = static_cast<std::uint64_t>((g - half_play) >> 8) & 0x3FF;  // arithmetic shift
  return static_cast<std::uint64_t>(half_play) | above << 17 | below << 27 | std::uint64_t{rounds} << 37;
}

void check_board_formats(const QuantisedNetwork& q) {
  QuantisedNetwork reference;
  reference.formats = Formats();
  fill_tanh_tables(reference);
  const Formats& f = q.formats;
  const Formats d;
  const bool same =
      f.input_fraction_bits == d.input_fraction_bits && f.input_bits == d.input_bits &&
      f.scaled_input_bits == d.scaled_input_bits && f.input_weight_bits == d.input_weight_bits &&
      f.input_weight_fraction_bits == d.input_weight_fraction_bits && f.tanh_input_bits == d.tanh_input_bits &&
      f.tanh_input_fraction_bits == d.tanh_input_fraction_bits &&
      f.tanh_segments_per_unit_log2 == d.tanh_segments_per_unit_log2 && f.tanh_guard_bits == d.tanh_guard_bits &&
      f.hidden_fraction_bits == d.hidden_fraction_bits && f.output_weight_bits == d.output_weight_bits &&
      f.output_weight_fraction_bits == d.output_weight_fraction_bits && f.output_bits == d.output_bits &&
      f.output_fraction_bits == d.output_fraction_bits;
  if (!same || q.hidden != kHidden || q.tanh_table != reference.tanh_table || q.tanh_slope != reference.tanh_slope) {
    throw std::invalid_argument("model: the board runs the spec's default formats with " + std::to_string(kHidden) +
                                " hidden neurons (this network: " + std::to_string(q.hidden) + ")");
  }
  if (q.input_weights.size() != 3u * kHidden || q.hidden_bias.size() != static_cast<std::size_t>(kHidden) ||
      q.output_weights.size() != 3u * kHidden) {
    throw std::invalid_argument("model: the network's weight arrays are not 3-25-3");
  }
}

}  // namespace

std::vector<std::uint64_t> model_words(const QuantisedNetwork& q) {
  check_board_formats(q);
  const Formats& f = q.formats;
  std::vector<std::uint64_t> words;
  words.reserve(board::kModelCommitFrame);
  for (int i = 0; i < 3 * kHidden; ++i) {
    words.push_back(field(q.input_weights[i], f.input_weight_bits, "IW' word " + std::to_string(i)));
  }
  const int bias1_bits = f.tanh_input_bits + (f.hidden_accumulator_fraction_bits() - f.tanh_input_fraction_bits);
  for (int k = 0; k < kHidden; ++k) words.push_back(field(q.hidden_bias[k], bias1_bits, "b1' " + std::to_string(k)));
  for (int i = 0; i < 3 * kHidden; ++i) {
    words.push_back(field(q.output_weights[i], f.output_weight_bits, "LW' word " + std::to_string(i)));
  }
  for (int o = 0; o < 3; ++o) {
    words.push_back(field(q.output_bias[o] + (std::int64_t{1} << kBias2RoundingShift), kBias2Bits,
                          "b2' " + std::to_string(o) + " + 2^19"));
  }
  const std::array<std::int32_t, 3> half_plays = interpolation::half_play_counts(q.compensation);
  for (int j = 0; j < 3; ++j) {
    if (half_plays[j] >> kHalfPlayBits != 0) {
      throw std::invalid_argument("model: joint " + std::to_string(j + 1) + "'s half-play does not fit " +
                                  std::to_string(kHalfPlayBits) + " bits");
    }
    words.push_back(play_word(half_plays[j]));
  }
  for (int j = 0; j < 3; ++j) {
    if (q.input_shift[j] < 0 || q.input_shift[j] > 255) {
      throw std::invalid_argument("model: input " + std::to_string(j + 1) + "'s shift " +
                                  std::to_string(q.input_shift[j]) + " is not one byte");
    }
    words.push_back(field(q.input_centre[j], 32, "input centre " + std::to_string(j + 1)) |
                    static_cast<std::uint64_t>(q.input_shift[j]) << 32);
  }
  return words;
}

std::vector<std::uint8_t> model_crc_bytes(const QuantisedNetwork& q) {
  std::vector<std::uint8_t> bytes;
  for (std::uint64_t word : model_words(q)) {
    for (int i = 0; i < 6; ++i) bytes.push_back(static_cast<std::uint8_t>(word >> (8 * i)));
  }
  return bytes;
}

std::vector<link::ModelPayload> model_frames(const QuantisedNetwork& q) {
  const std::vector<std::uint64_t> words = model_words(q);
  std::vector<link::ModelPayload> frames;
  for (std::size_t n = 0; n < words.size(); ++n) {
    frames.push_back(link::ModelPayload::of(static_cast<std::uint16_t>(n), words[n]));
  }
  frames.push_back(
      link::ModelPayload::of(static_cast<std::uint16_t>(board::kModelCommitFrame), crc32(model_crc_bytes(q))));
  return frames;
}

QuantisedNetwork network_of_model_words(const std::vector<std::uint64_t>& words) {
  if (words.size() != static_cast<std::size_t>(board::kModelCommitFrame)) {
    throw std::invalid_argument("model: " + std::to_string(words.size()) + " words, a model has " +
                                std::to_string(board::kModelCommitFrame));
  }
  QuantisedNetwork q;
  q.formats = Formats();
  q.hidden = kHidden;
  fill_tanh_tables(q);
  const Formats& f = q.formats;
  const int bias1_bits = f.tanh_input_bits + (f.hidden_accumulator_fraction_bits() - f.tanh_input_fraction_bits);
  for (int i = 0; i < 3 * kHidden; ++i) {
    q.input_weights.push_back(signed_field(words[board::kModelWeight1Frame + i], f.input_weight_bits));
    q.output_weights.push_back(signed_field(words[board::kModelWeight2Frame + i], f.output_weight_bits));
  }
  for (int k = 0; k < kHidden; ++k)
    q.hidden_bias.push_back(signed_field(words[board::kModelBias1Frame + k], bias1_bits));
  for (int o = 0; o < 3; ++o) {
    q.output_bias[o] =
        signed_field(words[board::kModelBias2Frame + o], kBias2Bits) - (std::int64_t{1} << kBias2RoundingShift);
  }
  for (int j = 0; j < 3; ++j) {
    const std::int64_t half_play =
        static_cast<std::int64_t>(words[board::kModelPlayFrame + j] & ((1u << kHalfPlayBits) - 1));
    q.compensation.half_play[j] = half_play / 25 * 16;  // H = 25 h / 16 with h a whole number of 16 LSBs
    const std::uint64_t scaling = words[board::kModelScalingFrame + j];
    q.input_centre[j] = signed_field(scaling, 32);
    q.input_shift[j] = static_cast<int>((scaling >> 32) & 0xFF);
    q.input_exponent[j] = q.input_shift[j] - f.input_fraction_bits + (f.scaled_input_bits - 1);
  }
  return q;
}

}  // namespace delta::golden
