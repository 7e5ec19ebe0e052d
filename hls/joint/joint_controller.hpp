// Header-only HLS templates of the three joint controllers (reference filter, VOB, DOB, eq. 5),
// configured by one struct (joint_config.hpp). Synthesizable: integer codes only, no dynamic
// memory, recursion or division; every loop labelled. Bit-exact to delta::golden::fixed_update.
#pragma once

// Loop labels name loops for Vitis HLS directives; the host compiler does not use them.
#pragma GCC diagnostic ignored "-Wunused-label"

#include "joint_config.hpp"

namespace delta_hls {

// The coefficient codes of one design (delta::golden::JointFixedCoefficients, same order and
// meaning): two's complement integers, at each update's LSB (joint_config.hpp's shifts).
struct JointCoefficientCodes {
  int reference_gain;             // g_ref Ts / (1 + g_ref Ts)                      << reference_shift
  int velocity_encoder_gain;      // g_v Ts / (1 + g_v Ts)                          << velocity_shift
  int velocity_current_gain;      // 1 / (Kacc (1 + g_v Ts)), counts/period per A   << velocity_shift
  int disturbance_gain;           // g_d Ts / (1 + g_d Ts)                          << disturbance_shift
  int disturbance_velocity_gain;  // -(g_d Ts / (1 + g_d Ts)) Kacc                  << disturbance_shift
  int law_acceleration_gain;      // Kacc, A per count/period^2                     << law_shift
  int law_velocity_gain;          // -Kacc k_v Ts                                   << law_shift
  int law_position_gain;          // -Kacc k_p Ts^2, A per count                    << position_shift
  int current_limit;              // Q1.15 A
};

// The same coefficients as values of their fixed-point types.
template <class C>
struct JointCoefficients {
  typename C::reference_coefficient_t reference_gain;
  typename C::velocity_coefficient_t velocity_encoder_gain;
  typename C::velocity_coefficient_t velocity_current_gain;
  typename C::disturbance_coefficient_t disturbance_gain;
  typename C::disturbance_coefficient_t disturbance_velocity_gain;
  typename C::law_coefficient_t law_acceleration_gain;
  typename C::law_coefficient_t law_velocity_gain;
  typename C::position_coefficient_t law_position_gain;
  typename C::current_t current_limit;
};

template <class C>
JointCoefficients<C> joint_coefficients(const JointCoefficientCodes& codes) {
  JointCoefficients<C> c;
  c.reference_gain = fixed_from_code<typename C::reference_coefficient_t, C::coefficient_bits, C::reference_shift>(
      codes.reference_gain);
  c.velocity_encoder_gain = fixed_from_code<typename C::velocity_coefficient_t, C::coefficient_bits, C::velocity_shift>(
      codes.velocity_encoder_gain);
  c.velocity_current_gain = fixed_from_code<typename C::velocity_coefficient_t, C::coefficient_bits, C::velocity_shift>(
      codes.velocity_current_gain);
  c.disturbance_gain =
      fixed_from_code<typename C::disturbance_coefficient_t, C::coefficient_bits, C::disturbance_shift>(
          codes.disturbance_gain);
  c.disturbance_velocity_gain =
      fixed_from_code<typename C::disturbance_coefficient_t, C::coefficient_bits, C::disturbance_shift>(
          codes.disturbance_velocity_gain);
  c.law_acceleration_gain =
      fixed_from_code<typename C::law_coefficient_t, C::coefficient_bits, C::law_shift>(codes.law_acceleration_gain);
  c.law_velocity_gain =
      fixed_from_code<typename C::law_coefficient_t, C::coefficient_bits, C::law_shift>(codes.law_velocity_gain);
  c.law_position_gain = fixed_from_code<typename C::position_coefficient_t, C::coefficient_bits, C::position_shift>(
      codes.law_position_gain);
  c.current_limit = fixed_from_code<typename C::current_t, C::current_bits, C::current_fraction>(codes.current_limit);
  return c;
}

// One joint's state between periods (the RTL keeps it in its state RAM).
template <class C>
struct JointState {
  typename C::reference_t reference;  // previous reference
  typename C::state_t reference_velocity;
  typename C::state_t reference_acceleration;
  typename C::encoder_t encoder;    // previous encoder count
  typename C::shift_t shift;        // previous play shift
  typename C::state_t velocity;     // VOB
  typename C::state_t disturbance;  // DOB, A
  typename C::current_t current;    // applied over the previous period
};

// Everything the block keeps across calls.
template <class C>
struct JointMemory {
  JointState<C> joint[C::joints];
  bool primed;  // an earlier call has filled the states; the first starts from rest at its input
  typename C::overflow_count_t overflow_count;
};

// Rest state at an input: previous input = input, every filter and observer state zero.
template <class C>
void joint_rest(JointState<C>& state, const typename C::reference_t& reference, const typename C::encoder_t& encoder,
                const typename C::shift_t& shift) {
  state.reference = reference;
  state.shift = shift;
  state.reference_velocity = 0;
  state.reference_acceleration = 0;
  state.encoder = encoder;
  state.velocity = 0;
  state.disturbance = 0;
  state.current = 0;
}

// Saturations of one joint-period: operands clamped to 40 bits, states clamped to 32.
struct JointSaturations {
  int count;
};

// Saturating cast of an exact operand to the multiplier's 40 bits, counted.
template <class Operand, class Exact>
Operand joint_operand(const Exact& exact, JointSaturations& saturations) {
  const Operand operand = exact;
  if (operand != exact) ++saturations.count;
  return operand;
}

// Rounding (half up) of an accumulator to the state's LSB, then the saturating store, counted.
template <class C, class Rounded, class Accumulator>
typename C::state_t joint_store(const Accumulator& accumulator, JointSaturations& saturations) {
  const Rounded rounded = accumulator;  // wide enough never to saturate
  const typename C::state_t state = rounded;
  if (state != rounded) ++saturations.count;
  return state;
}

// One control period of one joint: the golden fixed_update, term by term. Returns the current.
template <class C>
typename C::current_t joint_update(JointState<C>& s, const JointCoefficients<C>& c,
                                   const typename C::reference_t& reference, const typename C::encoder_t& encoder,
                                   const typename C::shift_t& shift, bool& limited, JointSaturations& saturations) {
  typedef typename C::operand_t operand_t;
  typedef typename C::operand_exact_t operand_exact_t;

  // Reference filter, twice: y' = y + beta ((x' - x) - y), per-period differences; the first x is
  // the reference plus the play shift (its step a second product, as the RTL's extra MAC).
  const typename C::reference_difference_t reference_step = reference - s.reference;
  const typename C::shift_difference_t shift_step = shift - s.shift;
  const operand_exact_t reference_velocity_error = reference_step - s.reference_velocity;
  const operand_exact_t shift_operand = shift_step;
  typename C::reference_accumulator_t reference_velocity_sum = s.reference_velocity;
  reference_velocity_sum += c.reference_gain * joint_operand<operand_t>(reference_velocity_error, saturations);
  reference_velocity_sum += c.reference_gain * joint_operand<operand_t>(shift_operand, saturations);
  const typename C::state_t reference_velocity =
      joint_store<C, typename C::reference_rounded_t>(reference_velocity_sum, saturations);

  const operand_exact_t reference_acceleration_error =
      reference_velocity - s.reference_velocity - s.reference_acceleration;
  typename C::reference_accumulator_t reference_acceleration_sum = s.reference_acceleration;
  reference_acceleration_sum += c.reference_gain * joint_operand<operand_t>(reference_acceleration_error, saturations);
  const typename C::state_t reference_acceleration =
      joint_store<C, typename C::reference_rounded_t>(reference_acceleration_sum, saturations);

  // VOB: v' = v + beta_v ((theta' - theta) - v) + gamma (i - i_dis), theta plus the play shift.
  const typename C::encoder_difference_t encoder_step = encoder - s.encoder;
  const operand_exact_t velocity_error = encoder_step - s.velocity;
  const operand_exact_t current_error = s.current - s.disturbance;
  typename C::velocity_accumulator_t velocity_sum = s.velocity;
  velocity_sum += c.velocity_encoder_gain * joint_operand<operand_t>(velocity_error, saturations);
  velocity_sum += c.velocity_encoder_gain * joint_operand<operand_t>(shift_operand, saturations);
  velocity_sum += c.velocity_current_gain * joint_operand<operand_t>(current_error, saturations);
  const typename C::state_t velocity = joint_store<C, typename C::velocity_rounded_t>(velocity_sum, saturations);

  // DOB: d' = d + beta_d (i - d) - beta_d Kacc (v' - v), i the current applied last period.
  const operand_exact_t velocity_step = velocity - s.velocity;
  typename C::disturbance_accumulator_t disturbance_sum = s.disturbance;
  disturbance_sum += c.disturbance_gain * joint_operand<operand_t>(current_error, saturations);
  disturbance_sum += c.disturbance_velocity_gain * joint_operand<operand_t>(velocity_step, saturations);
  const typename C::state_t disturbance =
      joint_store<C, typename C::disturbance_rounded_t>(disturbance_sum, saturations);

  // Eq. 5: i = i_dis + Kacc a_ref - Kacc k_v Ts (v - v_ref) - Kacc k_p Ts^2 (theta - theta_ref).
  const operand_exact_t acceleration = reference_acceleration;
  const operand_exact_t velocity_tracking_error = velocity - reference_velocity;
  const typename C::position_exact_t position_error = encoder - reference;
  typename C::command_accumulator_t command_sum = disturbance;
  command_sum += c.law_acceleration_gain * joint_operand<operand_t>(acceleration, saturations);
  command_sum += c.law_velocity_gain * joint_operand<operand_t>(velocity_tracking_error, saturations);
  command_sum += c.law_position_gain * joint_operand<typename C::position_operand_t>(position_error, saturations);
  const typename C::command_t command = command_sum;

  // The limit: |i| <= limit, flagged.
  const typename C::current_t negative_limit = -c.current_limit;
  typename C::current_t current;
  limited = false;
  if (command > c.current_limit) {
    current = c.current_limit;
    limited = true;
  } else if (command < negative_limit) {
    current = negative_limit;
    limited = true;
  } else {
    current = command;
  }

  s.reference = reference;
  s.reference_velocity = reference_velocity;
  s.reference_acceleration = reference_acceleration;
  s.encoder = encoder;
  s.shift = shift;
  s.velocity = velocity;
  s.disturbance = disturbance;
  s.current = current;
  return current;
}

// One control period of every joint: the block's whole behaviour between ap_start and ap_done.
template <class C>
void joint_controller(JointMemory<C>& memory, const JointCoefficientCodes& codes,
                      const typename C::reference_t reference[C::joints],
                      const typename C::encoder_t encoder[C::joints], const typename C::shift_t shift[C::joints],
                      typename C::current_t current[C::joints], typename C::limited_t& limited,
                      typename C::overflow_count_t& overflow_count) {
  const JointCoefficients<C> coefficients = joint_coefficients<C>(codes);
  const int overflow_count_max = (1 << C::overflow_count_bits) - 1;
Joints:
  for (int j = 0; j < C::joints; ++j) {
    if (!memory.primed) joint_rest<C>(memory.joint[j], reference[j], encoder[j], shift[j]);
    bool joint_limited = false;
    JointSaturations saturations = {0};
    current[j] =
        joint_update<C>(memory.joint[j], coefficients, reference[j], encoder[j], shift[j], joint_limited, saturations);
    limited[j] = joint_limited;
    // Saturating sum: the count sticks at its maximum (at most 15 saturations per joint-period).
    const uint_t<C::overflow_count_bits + 1> overflow_sum = memory.overflow_count + saturations.count;
    if (overflow_sum > overflow_count_max) {
      memory.overflow_count = overflow_count_max;
    } else {
      memory.overflow_count = overflow_sum;
    }
  }
  memory.primed = true;
  overflow_count = memory.overflow_count;
}

}  // namespace delta_hls
