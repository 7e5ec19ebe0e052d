// Synthesis top of the three joint controllers: interface pragmas, the static states and the
// compiled-in coefficient codes.
#include "joint_top.hpp"

#include "joint_coefficients.hpp"  // generated from the golden model: joint_golden_vectors DIR PERIODS

namespace {
// Every state of the block (static storage: zero, not primed, at program start and after reset).
delta_hls::JointMemory<DeltaJointConfig> joint_memory;
const delta_hls::JointCoefficientCodes joint_coefficient_codes = DELTA_JOINT_COEFFICIENT_CODES;
}  // namespace

void joint_top(const DeltaJointConfig::reference_t reference[DeltaJointConfig::joints],
               const DeltaJointConfig::encoder_t encoder[DeltaJointConfig::joints],
               const DeltaJointConfig::shift_t shift[DeltaJointConfig::joints],
               DeltaJointConfig::current_t current[DeltaJointConfig::joints], DeltaJointConfig::limited_t& limited,
               DeltaJointConfig::overflow_count_t& overflow_count) {
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_ctrl_hs port = return )
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_none port = reference)
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_none port = encoder)
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_none port = shift)
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_vld port = current)
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_none port = limited)
  DELTA_HLS_PRAGMA(HLS INTERFACE mode = ap_none port = overflow_count)
  DELTA_HLS_PRAGMA(HLS ARRAY_PARTITION variable = reference type = complete)
  DELTA_HLS_PRAGMA(HLS ARRAY_PARTITION variable = encoder type = complete)
  DELTA_HLS_PRAGMA(HLS ARRAY_PARTITION variable = shift type = complete)
  DELTA_HLS_PRAGMA(HLS ARRAY_PARTITION variable = current type = complete)
  delta_hls::joint_controller<DeltaJointConfig>(joint_memory, joint_coefficient_codes, reference, encoder, shift,
                                                current, limited, overflow_count);
}

#ifndef __SYNTHESIS__
delta_hls::JointState<DeltaJointConfig> joint_top_state(int joint) { return joint_memory.joint[joint]; }

void joint_top_reset() {
  for (int j = 0; j < DeltaJointConfig::joints; ++j)
    delta_hls::joint_rest<DeltaJointConfig>(joint_memory.joint[j], 0, 0, 0);
  joint_memory.primed = false;
  joint_memory.overflow_count = 0;
}

delta_hls::JointCoefficientCodes joint_top_coefficient_codes() { return joint_coefficient_codes; }
#endif
