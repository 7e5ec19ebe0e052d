// HLS top of the three joint controllers: one call per 10 kHz control period.
#pragma once

#include "joint_types.hpp"

namespace delta::hls_joint {

struct JointState {
  previous_reference_t reference;
  state_t reference_velocity;
  state_t reference_acceleration;
  previous_encoder_t encoder;
  state_t velocity;
  state_t disturbance;
  current_t current;  // applied over the previous period
};

// Block-level ap_ctrl_hs top (the RTL rtl/joint/joint_controller.sv has the same ports).
// State is static, as a synthesised block keeps it in registers/RAM; the first call starts from
// rest at its own input. overflow_count counts saturated operands and states since the start.
void joint_top(const reference_t reference[kJoints], const encoder_t encoder[kJoints],
               current_t current[kJoints], sc_uint<kJoints>& limited, sc_uint<16>& overflow_count);

#ifndef __SYNTHESIS__
// C-simulation helpers: read a joint's state after a call, and restart from reset.
JointState joint_top_state(int joint);
void joint_top_reset();
#endif

}  // namespace delta::hls_joint
