// The synthesis top of the three joint controllers (Vitis HLS): one call per 10 kHz control period.
#pragma once

#include "joint_controller.hpp"

typedef delta_hls::DefaultJointConfig DeltaJointConfig;

// reference: Q24.8 shaft encoder counts (ports reference_0..2); encoder: counts (encoder_0..2);
// shift: the board's play shift, counts, 10-bit (shift_0..2; the RTL takes it through an idle-time
// write port, shift_write/shift_joint/shift_value, before the period's ap_start);
// current: Q1.15 A (current_0..2 with ap_vld); limited: bit j, joint j's command was clipped;
// overflow_count: saturated operands and states since reset, sticks at 65535; block-level
// ap_ctrl_hs. rtl/joint/joint_controller.sv has these ports. The states are static, as the RTL
// keeps them in its state RAM; the first call starts from rest at its own input. The coefficients
// are compiled in from the header the golden model writes (joint_coefficients.hpp).
void joint_top(const DeltaJointConfig::reference_t reference[DeltaJointConfig::joints],
               const DeltaJointConfig::encoder_t encoder[DeltaJointConfig::joints],
               const DeltaJointConfig::shift_t shift[DeltaJointConfig::joints],
               DeltaJointConfig::current_t current[DeltaJointConfig::joints], DeltaJointConfig::limited_t& limited,
               DeltaJointConfig::overflow_count_t& overflow_count);

#ifndef __SYNTHESIS__
// C-simulation helpers (not synthesised): a joint's state after a call, the restart from reset,
// and the compiled-in coefficient codes.
delta_hls::JointState<DeltaJointConfig> joint_top_state(int joint);
void joint_top_reset();
delta_hls::JointCoefficientCodes joint_top_coefficient_codes();
#endif
