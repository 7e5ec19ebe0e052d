// All quantisation choices of the three-joint controller HLS top (formats: hls/README.md).
//
// Written for SystemC's sc_fixed (the same source maps to Vitis ap_fixed: sc_fixed<W, I, Q, O>
// -> ap_fixed<W, I, AP_RND, AP_SAT>; SC_RND and AP_RND both round half towards plus infinity).
// Values mirror host/control/include/delta/golden/joint_fixed.hpp, the golden model.
#pragma once

#define SC_INCLUDE_FX
#include <systemc.h>

namespace delta::hls_joint {

constexpr int kJoints = 3;

// Ports.
using reference_t = sc_fixed<32, 24>;  // Q24.8 shaft encoder counts (0.01 deg)
using encoder_t = sc_int<16>;          // shaft encoder counts
using current_t = sc_fixed<16, 1>;     // Q1.15 A, applied current

// States: Q8.24, rounded (half up) and saturated on every store.
using state_t = sc_fixed<32, 8, SC_RND, SC_SAT>;
using previous_reference_t = reference_t;
using previous_encoder_t = sc_int<32>;

// Multiplier operands: 40 bits, saturated; the binary point follows the operand's unit.
using operand_t = sc_fixed<40, 16, SC_TRN, SC_SAT>;           // Q16.24 (per-period units, A)
using position_operand_t = sc_fixed<40, 32, SC_TRN, SC_SAT>;  // Q32.8 counts

// Coefficients: 24 bits signed; the fraction bits F of each update give sc_fixed<24, 24 - F>.
template <int Fraction>
using coefficient_t = sc_fixed<24, 24 - Fraction>;
constexpr int kReferenceShift = 26;
constexpr int kVelocityShift = 25;
constexpr int kDisturbanceShift = 22;
constexpr int kLawShift = 20;
constexpr int kPositionShift = kLawShift + 16;  // position error is Q.8, not Q.24

// Raw coefficient codes at the default design; a test checks them against the golden model.
constexpr int kReferenceGain = 7190235;
constexpr int kVelocityEncoderGain = 5592405;
constexpr int kVelocityCurrentGain = 4484972;
constexpr int kDisturbanceGain = 699051;
constexpr int kDisturbanceVelocityGain = -4358304;
constexpr int kLawAccelerationGain = 6537456;
constexpr int kLawVelocityGain = -65375;
constexpr int kLawPositionGain = -4284387;
constexpr int kCurrentLimitCode = 16384;  // 0.5 A

// The command before the limit: wide enough that no value of the accumulator wraps.
using command_t = sc_fixed<64, 49, SC_RND, SC_SAT>;

}  // namespace delta::hls_joint
