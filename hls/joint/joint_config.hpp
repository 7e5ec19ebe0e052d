// The one configuration struct of the HLS joint controllers: sizes, the chosen formats, every
// other width derived from them, and every type (hls/README.md, "Joint controller fixed-point formats").
#pragma once

#include "fixed_types.hpp"

namespace delta_hls {

// Chosen widths are the golden model's (delta::control, joint_fixed.hpp); a test checks they agree.
// Q(i.f) counts the sign bit in i. Angles are shaft encoder counts (0.01 deg), per-period units.
struct DefaultJointConfig {
  static constexpr int joints = 3;

  // Chosen formats: total bits and fraction bits.
  static constexpr int reference_bits = 32, reference_fraction = 8;  // Q24.8 counts (input)
  static constexpr int encoder_bits = 16;                            // counts (input)
  static constexpr int shift_bits = 10;                              // play shift, counts (input)
  static constexpr int state_bits = 32, state_fraction = 24;         // Q8.24: velocities, acceleration, disturbance
  static constexpr int current_bits = 16, current_fraction = 15;     // Q1.15 A (output)
  static constexpr int operand_bits = 40;                            // signed multiplier operand, saturated
  static constexpr int coefficient_bits = 24;                        // signed coefficient codes
  static constexpr int overflow_count_bits = 16;                     // saturations since reset, sticks at its maximum
  // Fraction bits of the coefficients of each update (the largest that keeps them in 24 bits).
  static constexpr int reference_shift = 26;    // reference filter
  static constexpr int velocity_shift = 25;     // velocity observer (VOB)
  static constexpr int disturbance_shift = 22;  // disturbance observer (DOB)
  static constexpr int law_shift = 20;          // eq. 5, the terms in per-period units

  // Derived widths.
  static constexpr int reference_integer = reference_bits - reference_fraction;
  static constexpr int state_integer = state_bits - state_fraction;
  // The position term of eq. 5 multiplies a Q.8 count difference: its coefficient carries the 16
  // fraction bits the operand lacks, so its products share the law's accumulator LSB.
  static constexpr int position_shift = law_shift + state_fraction - reference_fraction;
  // Operands before saturation. The widest is a reference difference (Q(r+1).8) less a state.
  static constexpr int operand_exact_integer = max_bits(reference_integer, state_integer) + 2;
  static constexpr int operand_exact_bits = operand_exact_integer + state_fraction;
  // (encoder << 8) - reference: encoder counts at the reference's LSB, less the reference.
  static constexpr int position_exact_integer = max_bits(reference_integer, encoder_bits) + 1;
  static constexpr int position_exact_bits = position_exact_integer + reference_fraction;
  // |product| <= 2^(operand - 1) 2^(coefficient - 1) (both at their most negative code).
  static constexpr int product_magnitude_bits = operand_bits + coefficient_bits - 2;
  // An update's accumulator, y + the sum of its T products (T = 2, 3, 2, 3), at the coefficient's
  // LSB times the state's: there |y| <= 2^(state - 1 + shift), so T + 1 magnitudes never wrap.
  static constexpr int reference_accumulator_bits =
      1 + max_bits(product_magnitude_bits, state_bits - 1 + reference_shift) + ceil_log2(2 + 1);
  static constexpr int velocity_accumulator_bits =
      1 + max_bits(product_magnitude_bits, state_bits - 1 + velocity_shift) + ceil_log2(3 + 1);
  static constexpr int disturbance_accumulator_bits =
      1 + max_bits(product_magnitude_bits, state_bits - 1 + disturbance_shift) + ceil_log2(2 + 1);
  static constexpr int command_accumulator_bits =
      1 + max_bits(product_magnitude_bits, state_bits - 1 + law_shift) + ceil_log2(3 + 1);
  static constexpr int command_accumulator_fraction = law_shift + state_fraction;

  // Types: fixed<bits, integer bits>.
  typedef fixed_exact<reference_bits, reference_integer> reference_t;
  typedef fixed_exact<encoder_bits, encoder_bits> encoder_t;
  typedef fixed_exact<shift_bits, shift_bits> shift_t;                           // the board's play shift, whole counts
  typedef fixed_exact<current_bits, current_bits - current_fraction> current_t;  // limited before the store
  typedef uint_t<joints> limited_t;                                              // bit j: joint j's command was clipped
  typedef uint_t<overflow_count_bits> overflow_count_t;
  // States: rounded (half up) and saturated on every store.
  typedef fixed_round_sat<state_bits, state_integer> state_t;
  // Differences of two inputs: exact.
  typedef fixed_exact<reference_bits + 1, reference_integer + 1> reference_difference_t;
  typedef fixed_exact<encoder_bits + 1, encoder_bits + 1> encoder_difference_t;
  typedef fixed_exact<shift_bits + 1, shift_bits + 1> shift_difference_t;
  // Multiplier operands: exact, then saturated to 40 bits (the binary point follows the unit).
  typedef fixed_exact<operand_exact_bits, operand_exact_integer> operand_exact_t;
  typedef fixed_trunc_sat<operand_bits, operand_bits - state_fraction> operand_t;  // Q16.24
  typedef fixed_exact<position_exact_bits, position_exact_integer> position_exact_t;
  typedef fixed_trunc_sat<operand_bits, operand_bits - reference_fraction> position_operand_t;  // Q32.8
  // Coefficients: the 24-bit codes at each update's LSB (integer bits 24 - shift, negative allowed).
  typedef fixed_exact<coefficient_bits, coefficient_bits - reference_shift> reference_coefficient_t;
  typedef fixed_exact<coefficient_bits, coefficient_bits - velocity_shift> velocity_coefficient_t;
  typedef fixed_exact<coefficient_bits, coefficient_bits - disturbance_shift> disturbance_coefficient_t;
  typedef fixed_exact<coefficient_bits, coefficient_bits - law_shift> law_coefficient_t;
  typedef fixed_exact<coefficient_bits, coefficient_bits - position_shift> position_coefficient_t;
  // Accumulators (exact) and the rounded results before the saturating store (never saturate).
  typedef fixed_exact<reference_accumulator_bits, reference_accumulator_bits - reference_shift - state_fraction>
      reference_accumulator_t;
  typedef fixed_round_sat<reference_accumulator_bits - reference_shift,
                          reference_accumulator_bits - reference_shift - state_fraction>
      reference_rounded_t;
  typedef fixed_exact<velocity_accumulator_bits, velocity_accumulator_bits - velocity_shift - state_fraction>
      velocity_accumulator_t;
  typedef fixed_round_sat<velocity_accumulator_bits - velocity_shift,
                          velocity_accumulator_bits - velocity_shift - state_fraction>
      velocity_rounded_t;
  typedef fixed_exact<disturbance_accumulator_bits, disturbance_accumulator_bits - disturbance_shift - state_fraction>
      disturbance_accumulator_t;
  typedef fixed_round_sat<disturbance_accumulator_bits - disturbance_shift,
                          disturbance_accumulator_bits - disturbance_shift - state_fraction>
      disturbance_rounded_t;
  typedef fixed_exact<command_accumulator_bits, command_accumulator_bits - command_accumulator_fraction>
      command_accumulator_t;
  // The command rounded (half up) to the current's LSB, before the limit.
  typedef fixed_round_sat<command_accumulator_bits - (command_accumulator_fraction - current_fraction),
                          command_accumulator_bits - command_accumulator_fraction>
      command_t;
};

}  // namespace delta_hls
