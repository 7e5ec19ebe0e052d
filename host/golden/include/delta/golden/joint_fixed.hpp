// Fixed-point joint controller in plain integers: the golden model of the HLS top and the RTL.
#pragma once

#include <cstdint>

#include "delta/golden/joint_parameters.hpp"

namespace delta::golden {

// Formats (hls/README.md, "Joint controller fixed-point formats"; Q(i.f) with i counting the
// sign bit, as the network's specification). Angles are counted in shaft
// encoder counts (0.01 deg); the gear ratio lives in the coefficients.
//   reference      int32  Q24.8   counts            (input)
//   encoder        int16  Q16.0   counts            (input)
//   velocities     int32  Q8.24   counts / period   (states)
//   acceleration   int32  Q8.24   counts / period^2 (state)
//   disturbance    int32  Q8.24   A                 (state)
//   current        int16  Q1.15   A                 (output, limited to +-limit_code)
constexpr int kReferenceFraction = 8;
constexpr int kStateFraction = 24;
constexpr int kCurrentFraction = 15;
constexpr int kShiftBits = 10;        // play shift input, whole counts, signed (JointFixedInput::shift)
constexpr int kCoefficientBits = 24;  // signed, two's complement
constexpr int kOperandBits = 40;      // signed multiplier operand, saturated
constexpr int kAccumulatorBits = 66;  // exact: 3 products of 40 x 24 bits plus a shifted state

// Shift of each update: the coefficients of one update share its fraction bits (largest that
// keeps every coefficient of the update within 24 bits at the default design).
constexpr int kReferenceShift = 26;
constexpr int kVelocityShift = 25;
constexpr int kDisturbanceShift = 22;
constexpr int kLawShift = 20;  // coefficients of eq. 5; the sum is then at Q.44, the output Q.15

struct JointFixedCoefficients {
  std::int32_t reference_gain;             // g_ref Ts / (1 + g_ref Ts)                << 26
  std::int32_t velocity_encoder_gain;      // g_v Ts / (1 + g_v Ts)                    << 25
  std::int32_t velocity_current_gain;      // 1 / (Kacc (1 + g_v Ts)), counts/period/A << 25
  std::int32_t disturbance_gain;           // g_d Ts / (1 + g_d Ts)                    << 22
  std::int32_t disturbance_velocity_gain;  // -(g_d Ts / (1 + g_d Ts)) Kacc            << 22
  std::int32_t law_acceleration_gain;      // Kacc = m g_r q / (K Ts^2), A per count/period^2 << 20
  std::int32_t law_velocity_gain;          // -Kacc k_v Ts                             << 20
  std::int32_t law_position_gain;          // -Kacc k_p Ts^2 (A per count)             << 36
  std::int16_t current_limit_code;         // limit in Q1.15
};

// Rounds every coefficient to nearest. Throws std::invalid_argument if one does not fit 24 bits.
JointFixedCoefficients make_fixed_coefficients(const JointControllerParameters& parameters);

// shift: the board's play shift s (whole counts, kShiftBits signed; 0 without backlash compensation).
// The controller sees reference + 256 s and encoder + s, as if it read the motor rather than an
// encoder behind the play: the position error is unchanged, and a change of s reaches the
// reference filter and the VOB ((s' - s) << 24 with their gains), so a joint moves with its
// answer while the play is crossed and the encoder cannot see it (setpoint_interpolation.hpp).
struct JointFixedInput {
  std::int32_t reference = 0;  // Q24.8 counts
  std::int16_t encoder = 0;    // counts
  std::int16_t shift = 0;      // counts, kShiftBits signed
};

struct JointFixedState {
  std::int32_t reference = 0;               // previous reference, Q24.8
  std::int32_t reference_velocity = 0;      // Q8.24
  std::int32_t reference_acceleration = 0;  // Q8.24
  std::int32_t encoder = 0;                 // previous encoder count
  std::int32_t shift = 0;                   // previous play shift (counts)
  std::int32_t velocity = 0;                // VOB, Q8.24
  std::int32_t disturbance = 0;             // DOB, Q8.24 A
  std::int32_t current = 0;                 // applied over the last period, Q1.15 (int16 range)
  bool operator==(const JointFixedState& other) const;
};

struct JointFixedStatus {
  bool limited = false;    // the current limit clipped the command
  int overflow_count = 0;  // operands and states saturated this period
};

// At rest at the given input: previous input = input, everything else zero.
JointFixedState fixed_rest_state(const JointFixedInput& input);

// One control period. Returns the applied current code (also stored in state.current).
std::int16_t fixed_update(const JointFixedCoefficients& coefficients, JointFixedState& state,
                          const JointFixedInput& input, JointFixedStatus& status);

// Scaling between engineering units and codes (round to nearest).
std::int32_t reference_code(double shaft_deg, double encoder_resolution_deg);
double current_from_code(std::int32_t code);

}  // namespace delta::golden
