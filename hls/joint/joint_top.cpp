// HLS top of the three joint controllers: eq. 5 with reference filter, VOB and DOB, in sc_fixed.
#include "joint_top.hpp"

namespace delta::hls_joint {
namespace {

JointState joint_states[kJoints];
bool primed = false;

// Rest state at an input: previous input = input, every filter and observer state zero.
void rest(JointState& state, const reference_t& reference, const encoder_t& encoder) {
  state.reference = reference;
  state.reference_velocity = 0;
  state.reference_acceleration = 0;
  state.encoder = encoder;
  state.velocity = 0;
  state.disturbance = 0;
  state.current = 0;
}
sc_uint<16> overflows = 0;

void count_overflow(bool saturated) {
  if (saturated && overflows != 0xFFFF) overflows = overflows + 1;
}

// Saturating cast to an operand type, counted.
template <typename Operand, typename Value>
Operand to_operand(const Value& value) {
  const Operand operand = value;
  count_overflow(operand != value);
  return operand;
}

// Rounded, saturating store of a state, counted (the rounding alone never saturates).
template <typename Value>
state_t to_state(const Value& value) {
  const state_t state = value;
  const sc_fixed<64, 40, SC_RND, SC_SAT> rounded = value;  // same rounding, no saturation
  count_overflow(state != rounded);
  return state;
}

template <int Fraction>
coefficient_t<Fraction> coefficient(int code) {
  return coefficient_t<Fraction>(static_cast<double>(code) / static_cast<double>(1LL << Fraction));
}

current_t update_joint(JointState& s, const reference_t& reference, const encoder_t& encoder, bool& limited) {
  const coefficient_t<kReferenceShift> reference_gain = coefficient<kReferenceShift>(kReferenceGain);
  const previous_encoder_t encoder_wide = encoder;

  // Reference filter twice: y' = y + beta ((x' - x) - y), per-period differences.
  const state_t reference_velocity = to_state(
      s.reference_velocity +
      reference_gain * to_operand<operand_t>(reference - s.reference - s.reference_velocity));
  const state_t reference_acceleration = to_state(
      s.reference_acceleration +
      reference_gain * to_operand<operand_t>(reference_velocity - s.reference_velocity - s.reference_acceleration));

  // VOB: v' = v + beta_v ((theta' - theta) - v) + gamma (i - i_dis).
  const state_t velocity = to_state(
      s.velocity +
      coefficient<kVelocityShift>(kVelocityEncoderGain) *
          to_operand<operand_t>(sc_fixed<34, 34>(encoder_wide - s.encoder) - s.velocity) +
      coefficient<kVelocityShift>(kVelocityCurrentGain) * to_operand<operand_t>(s.current - s.disturbance));

  // DOB: d' = d + beta_d (i - d) - beta_d Kacc (v' - v), i the current applied last period.
  const state_t disturbance = to_state(
      s.disturbance +
      coefficient<kDisturbanceShift>(kDisturbanceGain) * to_operand<operand_t>(s.current - s.disturbance) +
      coefficient<kDisturbanceShift>(kDisturbanceVelocityGain) * to_operand<operand_t>(velocity - s.velocity));

  // Eq. 5: i = i_dis + Kacc a_ref - Kacc k_v Ts (v - v_ref) - Kacc k_p Ts^2 (theta - theta_ref).
  const command_t command =
      disturbance +
      coefficient<kLawShift>(kLawAccelerationGain) * to_operand<operand_t>(reference_acceleration) +
      coefficient<kLawShift>(kLawVelocityGain) * to_operand<operand_t>(velocity - reference_velocity) +
      coefficient<kPositionShift>(kLawPositionGain) *
          to_operand<position_operand_t>(sc_fixed<34, 34>(encoder_wide) - reference);
  const current_t limit = current_t(static_cast<double>(kCurrentLimitCode) / 32768.0);
  limited = command > limit || command < -limit;
  const current_t current = command > limit ? limit : command < -limit ? current_t(-limit) : current_t(command);

  s.reference = reference;
  s.reference_velocity = reference_velocity;
  s.reference_acceleration = reference_acceleration;
  s.encoder = encoder_wide;
  s.velocity = velocity;
  s.disturbance = disturbance;
  s.current = current;
  return current;
}

}  // namespace

void joint_top(const reference_t reference[kJoints], const encoder_t encoder[kJoints],
               current_t current[kJoints], sc_uint<kJoints>& limited, sc_uint<16>& overflow_count) {
[[maybe_unused]] joints:  // loop label for HLS directives
  for (int j = 0; j < kJoints; ++j) {
    if (!primed) rest(joint_states[j], reference[j], encoder[j]);
    bool joint_limited = false;
    current[j] = update_joint(joint_states[j], reference[j], encoder[j], joint_limited);
    limited[j] = joint_limited;
  }
  primed = true;
  overflow_count = overflows;
}

#ifndef __SYNTHESIS__
JointState joint_top_state(int joint) { return joint_states[joint]; }

void joint_top_reset() {
  for (JointState& state : joint_states) rest(state, 0, 0);
  primed = false;
  overflows = 0;
}
#endif

}  // namespace delta::hls_joint
