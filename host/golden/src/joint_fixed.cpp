// Golden fixed-point joint controller: every update is acc = state << f + sum(c * x), y = round(acc >> S).
#include "delta/golden/joint_fixed.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "delta/geometry.hpp"

namespace delta::golden {
namespace {

using Wide = __int128;  // holds the 66-bit accumulator exactly

std::int32_t coefficient(double value, int shift, const char* name) {
  const double scaled = std::nearbyint(std::ldexp(value, shift));
  const double limit = std::ldexp(1.0, kCoefficientBits - 1);
  if (!(scaled >= -limit && scaled < limit)) {
    throw std::invalid_argument(std::string("joint coefficient ") + name + " does not fit 24 bits");
  }
  return static_cast<std::int32_t>(scaled);
}

// Multiplier operand ((a - b) << shift) - c, saturated to kOperandBits.
std::int64_t operand(std::int64_t a, std::int64_t b, int shift, std::int64_t c, JointFixedStatus& status) {
  const Wide value = (static_cast<Wide>(a - b) << shift) - c;
  const Wide high = (static_cast<Wide>(1) << (kOperandBits - 1)) - 1;
  const Wide low = -high - 1;
  if (value > high) return ++status.overflow_count, static_cast<std::int64_t>(high);
  if (value < low) return ++status.overflow_count, static_cast<std::int64_t>(low);
  return static_cast<std::int64_t>(value);
}

// Accumulator preloaded with the state and the rounding half-LSB of the final shift.
Wide preload(std::int64_t state, int fraction_shift, int result_shift) {
  return (static_cast<Wide>(state) << fraction_shift) + (static_cast<Wide>(1) << (result_shift - 1));
}

Wide product(std::int32_t coefficient, std::int64_t operand) { return static_cast<Wide>(coefficient) * operand; }

// Round (the half-LSB is already in the accumulator) and saturate to int32.
std::int32_t store_state(Wide accumulator, int shift, JointFixedStatus& status) {
  const Wide value = accumulator >> shift;  // arithmetic: floor
  if (value > INT32_MAX) return ++status.overflow_count, INT32_MAX;
  if (value < INT32_MIN) return ++status.overflow_count, INT32_MIN;
  return static_cast<std::int32_t>(value);
}

}  // namespace

bool JointFixedState::operator==(const JointFixedState& o) const {
  return reference == o.reference && reference_velocity == o.reference_velocity &&
         reference_acceleration == o.reference_acceleration && encoder == o.encoder && velocity == o.velocity &&
         disturbance == o.disturbance && current == o.current && shift == o.shift;
}

JointFixedCoefficients make_fixed_coefficients(const JointControllerParameters& p) {
  const double ts = p.period_s;
  const double count_rad = p.encoder_resolution_deg * kRadPerDeg * p.gear_ratio;  // rotor rad per count
  // Current per unit of acceleration in counts / period^2.
  const double kacc = p.nominal_inertia_kg_m2 * count_rad / (p.nominal_torque_constant_nm_per_a * ts * ts);
  const double gref = p.reference_cutoff_rad_s * ts;
  const double gv = p.velocity_observer_cutoff_rad_s * ts;
  const double gd = p.disturbance_observer ? p.disturbance_observer_cutoff_rad_s * ts : 0.0;
  JointFixedCoefficients c{};
  c.reference_gain = coefficient(gref / (1.0 + gref), kReferenceShift, "reference_gain");
  c.velocity_encoder_gain = coefficient(gv / (1.0 + gv), kVelocityShift, "velocity_encoder_gain");
  c.velocity_current_gain = coefficient(1.0 / (kacc * (1.0 + gv)), kVelocityShift, "velocity_current_gain");
  c.disturbance_gain = coefficient(gd / (1.0 + gd), kDisturbanceShift, "disturbance_gain");
  c.disturbance_velocity_gain = coefficient(-gd / (1.0 + gd) * kacc, kDisturbanceShift, "disturbance_velocity_gain");
  c.law_acceleration_gain = coefficient(kacc, kLawShift, "law_acceleration_gain");
  c.law_velocity_gain = coefficient(-kacc * p.velocity_gain * ts, kLawShift, "law_velocity_gain");
  c.law_position_gain = coefficient(-kacc * p.position_gain * ts * ts, kLawShift + kStateFraction - kReferenceFraction,
                                    "law_position_gain");
  const double limit = std::nearbyint(std::ldexp(p.current_limit_a, kCurrentFraction));
  if (!(limit > 0 && limit < 32768)) throw std::invalid_argument("current limit outside Q1.15");
  c.current_limit_code = static_cast<std::int16_t>(limit);
  return c;
}

JointFixedState fixed_rest_state(const JointFixedInput& input) {
  JointFixedState state;
  state.reference = input.reference;
  state.encoder = input.encoder;
  state.shift = input.shift;
  return state;
}

std::int16_t fixed_update(const JointFixedCoefficients& c, JointFixedState& s, const JointFixedInput& in,
                          JointFixedStatus& status) {
  status = JointFixedStatus{};
  constexpr int kCountToState = kStateFraction;                           // counts -> Q.24
  constexpr int kReferenceToState = kStateFraction - kReferenceFraction;  // Q.8 -> Q.24
  constexpr int kCurrentToState = kStateFraction - kCurrentFraction;      // Q.15 -> Q.24
  constexpr int kLawResult = kLawShift + kStateFraction - kCurrentFraction;

  // Reference filter, twice: y' = y + beta ((x' - x) - y), x' - x per period (Q.24); the first
  // input is the reference plus the play shift: x' - x = (r' - r) << 16 + (s' - s) << 24.
  Wide acc = preload(s.reference_velocity, kReferenceShift, kReferenceShift);
  acc += product(c.reference_gain, operand(in.reference, s.reference, kReferenceToState, s.reference_velocity, status));
  acc += product(c.reference_gain, operand(in.shift, s.shift, kCountToState, 0, status));
  const std::int32_t reference_velocity = store_state(acc, kReferenceShift, status);

  acc = preload(s.reference_acceleration, kReferenceShift, kReferenceShift);
  acc +=
      product(c.reference_gain, operand(reference_velocity, s.reference_velocity, 0, s.reference_acceleration, status));
  const std::int32_t reference_acceleration = store_state(acc, kReferenceShift, status);

  // VOB: v' = v + beta_v ((theta' - theta) - v) + gamma (i - i_dis), theta the encoder plus the
  // play shift.
  acc = preload(s.velocity, kVelocityShift, kVelocityShift);
  acc += product(c.velocity_encoder_gain, operand(in.encoder, s.encoder, kCountToState, s.velocity, status));
  acc += product(c.velocity_encoder_gain, operand(in.shift, s.shift, kCountToState, 0, status));
  acc += product(c.velocity_current_gain, operand(s.current, 0, kCurrentToState, s.disturbance, status));
  const std::int32_t velocity = store_state(acc, kVelocityShift, status);

  // DOB: d' = d + beta_d (i - d) - beta_d Kacc (v' - v), i the current applied last period.
  acc = preload(s.disturbance, kDisturbanceShift, kDisturbanceShift);
  acc += product(c.disturbance_gain, operand(s.current, 0, kCurrentToState, s.disturbance, status));
  acc += product(c.disturbance_velocity_gain, operand(velocity, s.velocity, 0, 0, status));
  const std::int32_t disturbance = store_state(acc, kDisturbanceShift, status);

  // Eq. 5: i = Kacc (a_ref - k_v Ts (v - v_ref) - k_p Ts^2 (theta - theta_ref)) + i_dis.
  acc = preload(disturbance, kLawShift, kLawResult);
  acc += product(c.law_acceleration_gain, operand(reference_acceleration, 0, 0, 0, status));
  acc += product(c.law_velocity_gain, operand(velocity, reference_velocity, 0, 0, status));
  acc += product(c.law_position_gain, operand(in.encoder, 0, kReferenceFraction, in.reference, status));
  const Wide command = acc >> kLawResult;
  const Wide limit = c.current_limit_code;
  status.limited = command > limit || command < -limit;
  const std::int32_t current = static_cast<std::int32_t>(command > limit ? limit : command < -limit ? -limit : command);

  s.reference = in.reference;
  s.reference_velocity = reference_velocity;
  s.reference_acceleration = reference_acceleration;
  s.encoder = in.encoder;
  s.shift = in.shift;
  s.velocity = velocity;
  s.disturbance = disturbance;
  s.current = current;
  return static_cast<std::int16_t>(current);
}

std::int32_t reference_code(double shaft_deg, double encoder_resolution_deg) {
  return static_cast<std::int32_t>(std::nearbyint(std::ldexp(shaft_deg / encoder_resolution_deg, kReferenceFraction)));
}

double current_from_code(std::int32_t code) { return std::ldexp(static_cast<double>(code), -kCurrentFraction); }

}  // namespace delta::golden
