// Double-precision reference of one joint's controller: reference filter, VOB, DOB, eq. 5.
#pragma once

#include "delta/golden/joint_parameters.hpp"

namespace delta::control {

// One control period's measurement and reference, shaft side (the controller converts to the
// rotor side with the gear ratio, as in the paper's Fig. 6a).
struct JointInput {
  double reference_shaft_deg = 0.0;  // alpha_js^ref
  double encoder_shaft_deg = 0.0;    // measured alpha_js (whole encoder counts)
};

struct JointOutput {
  double current_a = 0.0;  // applied current command, after the limit
  bool limited = false;    // the limit clipped the command this period
};

// All filters use backward Euler, s -> (1 - z^-1) / Ts, with the current applied over the
// previous period as the input of the observers (see hls/README.md for the why).
class JointController {
 public:
  explicit JointController(const golden::JointControllerParameters& parameters);

  // Starts at rest at the given input: filters and observers settled, zero current.
  void reset(const JointInput& input);
  JointOutput update(const JointInput& input);

  // Rotor-side states [rad, rad/s, rad/s^2, A] for plots and tests.
  double reference_velocity() const { return reference_velocity_; }
  double reference_acceleration() const { return reference_acceleration_; }
  double velocity_estimate() const { return velocity_estimate_; }
  double disturbance_current() const { return disturbance_current_; }
  const golden::JointControllerParameters& parameters() const { return parameters_; }

 private:
  double rotor_rad(double shaft_deg) const;

  golden::JointControllerParameters parameters_;
  double previous_reference_ = 0.0;  // rotor rad
  double previous_angle_ = 0.0;      // rotor rad
  double reference_velocity_ = 0.0;
  double reference_acceleration_ = 0.0;
  double velocity_estimate_ = 0.0;
  double disturbance_current_ = 0.0;
  double applied_current_ = 0.0;  // applied over the period that just ended
};

}  // namespace delta::control
