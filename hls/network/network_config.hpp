// The one configuration struct of the HLS network: sizes, reuse factor, table size and every type,
// each width derived from the few chosen ones (hls/README.md, "Fixed-point specification").
#pragma once

#include "fixed_types.hpp"

namespace delta_hls {

// Chosen widths are the golden model's defaults (delta::golden::Formats); a test checks they agree.
struct DefaultNetworkConfig {
  // Sizes and schedule.
  static constexpr int inputs = 3;
  static constexpr int hidden = 25;
  static constexpr int outputs = 3;
  static constexpr int reuse_factor = 75;  // multiplications per multiplier per inference (hls4ml's meaning)

  // Chosen formats: total bits and fraction bits.
  static constexpr int input_bits = 32, input_fraction = 28;                // metres
  static constexpr int scaled_input_bits = 16;                              // Q1.15
  static constexpr int input_weight_bits = 24, input_weight_fraction = 19;  // IW'
  static constexpr int tanh_input_bits = 21, tanh_input_fraction = 17;      // n in [-8, 8)
  static constexpr int tanh_segments_per_unit_log2 = 7;                     // table step 2^-7
  static constexpr int tanh_guard_bits = 3;
  static constexpr int hidden_fraction = 17;                                  // h: Q1.17
  static constexpr int output_weight_bits = 24, output_weight_fraction = 17;  // LW', degrees
  static constexpr int output_bits = 24, output_fraction = 14;                // alpha, degrees
  static constexpr int half_play_bits = 16;  // backlash half-play h, unsigned, output LSBs: [0, 4) deg
  // Input gains 2^-e_j are powers of two in [2^-3, 2^12] (half ranges from 0.17 mm to 5.3 m).
  static constexpr int input_gain_bits = 16, input_gain_integer = 13;

  // Derived widths. An accumulator holds its terms' largest possible sum, |product| <= 2^magnitude
  // (both operands at their most negative code) and |bias| < 2^(bias bits - 1): no wrap-around.
  static constexpr int offset_bits = input_bits + 1;  // x - centre
  static constexpr int hidden_accumulator_fraction = scaled_input_bits - 1 + input_weight_fraction;
  static constexpr int hidden_bias_bits = tanh_input_bits + hidden_accumulator_fraction - tanh_input_fraction;
  static constexpr int product1_magnitude_bits = scaled_input_bits + input_weight_bits - 2;
  static constexpr int hidden_accumulator_bits =
      1 + ceil_log2(inputs * (1LL << product1_magnitude_bits) + (1LL << (hidden_bias_bits - 1)));
  static constexpr int tanh_range_log2 = tanh_input_bits - 1 - tanh_input_fraction;
  static constexpr int tanh_segments = 1 << (tanh_range_log2 + tanh_segments_per_unit_log2);
  static constexpr int tanh_index_bits = tanh_range_log2 + tanh_segments_per_unit_log2;
  static constexpr int tanh_fraction_bits = tanh_input_fraction - tanh_segments_per_unit_log2;
  static constexpr int tanh_entry_fraction = hidden_fraction + tanh_guard_bits;
  static constexpr int hidden_bits = hidden_fraction + 1;
  static constexpr int output_accumulator_fraction = hidden_fraction + output_weight_fraction;
  static constexpr int output_bias_bits = output_bits + output_accumulator_fraction - output_fraction;
  static constexpr int product2_magnitude_bits = hidden_bits + output_weight_bits - 2;
  static constexpr int output_accumulator_bits =
      1 + ceil_log2(hidden * (1LL << product2_magnitude_bits) + (1LL << (output_bias_bits - 1)));

  // Types: fixed<bits, integer bits>.
  typedef fixed_exact<input_bits, input_bits - input_fraction> input_t;
  typedef fixed_exact<offset_bits, offset_bits - input_fraction> offset_t;
  typedef ufixed_exact<input_gain_bits, input_gain_integer> input_gain_t;
  typedef fixed_round_sat<scaled_input_bits, 1> scaled_input_t;
  typedef fixed_exact<input_weight_bits, input_weight_bits - input_weight_fraction> input_weight_t;
  typedef fixed_exact<hidden_bias_bits, hidden_bias_bits - hidden_accumulator_fraction> hidden_bias_t;
  typedef fixed_exact<hidden_accumulator_bits, hidden_accumulator_bits - hidden_accumulator_fraction>
      hidden_accumulator_t;
  // n rounded but not yet saturated: tells whether the saturating cast clamped.
  typedef fixed_round_sat<hidden_accumulator_bits - (hidden_accumulator_fraction - tanh_input_fraction),
                          hidden_accumulator_bits - hidden_accumulator_fraction>
      tanh_input_wide_t;
  typedef fixed_round_sat<tanh_input_bits, tanh_input_bits - tanh_input_fraction> tanh_input_t;
  typedef ufixed_trunc_sat<tanh_input_bits - 1, tanh_range_log2> tanh_magnitude_t;  // [0, 2^range)
  typedef ufixed_exact<tanh_index_bits, tanh_index_bits> tanh_index_t;
  typedef ufixed_exact<tanh_fraction_bits, 0> tanh_fraction_t;  // position inside a segment, [0, 1)
  typedef ufixed_exact<tanh_entry_fraction, 0> tanh_entry_t;    // T[i] and D[i] (D >= 0)
  typedef ufixed_exact<tanh_entry_fraction + tanh_fraction_bits, 1> tanh_interpolation_t;
  typedef ufixed_round_sat<hidden_fraction, 0> hidden_magnitude_t;
  typedef fixed_exact<hidden_bits, 1> hidden_t;
  typedef fixed_exact<output_weight_bits, output_weight_bits - output_weight_fraction> output_weight_t;
  typedef fixed_exact<output_bias_bits, output_bias_bits - output_accumulator_fraction> output_bias_t;
  typedef fixed_exact<output_accumulator_bits, output_accumulator_bits - output_accumulator_fraction>
      output_accumulator_t;
  typedef fixed_round_sat<output_accumulator_bits - (output_accumulator_fraction - output_fraction),
                          output_accumulator_bits - output_accumulator_fraction>
      output_wide_t;
  typedef fixed_round_sat<output_bits, output_bits - output_fraction> output_t;
  // Backlash compensation (deployed model): s - r and s -/+ h need one bit above the output; the
  // new reference itself always fits the output format (hls/README.md, "Backlash compensation").
  static constexpr int compensation_difference_bits = output_bits + 1;
  typedef ufixed_exact<half_play_bits, half_play_bits - output_fraction> half_play_t;
  typedef fixed_exact<compensation_difference_bits, compensation_difference_bits - output_fraction>
      compensation_difference_t;
  typedef uint_t<3> saturation_t;  // bit 0 scaled input, bit 1 tanh input, bit 2 output
};

}  // namespace delta_hls
