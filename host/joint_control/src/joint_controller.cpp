// Double-precision joint controller: backward-Euler filters at Ts, eq. 5 of the paper.
#include "delta/control/joint_controller.hpp"

#include <algorithm>

#include "delta/geometry.hpp"

namespace delta::control {

JointController::JointController(const golden::JointControllerParameters& parameters) : parameters_(parameters) {}

double JointController::rotor_rad(double shaft_deg) const { return shaft_deg * kRadPerDeg * parameters_.gear_ratio; }

void JointController::reset(const JointInput& input) {
  previous_reference_ = rotor_rad(input.reference_shaft_deg);
  previous_angle_ = rotor_rad(input.encoder_shaft_deg);
  reference_velocity_ = reference_acceleration_ = velocity_estimate_ = 0.0;
  disturbance_current_ = applied_current_ = 0.0;
}

JointOutput JointController::update(const JointInput& input) {
  const golden::JointControllerParameters& p = parameters_;
  const double ts = p.period_s;
  const double inertia_per_torque = p.nominal_inertia_kg_m2 / p.nominal_torque_constant_nm_per_a;  // A s^2/rad
  const double reference = rotor_rad(input.reference_shaft_deg);
  const double angle = rotor_rad(input.encoder_shaft_deg);

  // Pseudo-derivative g s / (s + g), backward Euler: y' = y + g Ts / (1 + g Ts) (dx / Ts - y).
  const double beta_ref = p.reference_cutoff_rad_s * ts / (1.0 + p.reference_cutoff_rad_s * ts);
  const double new_reference_velocity =
      reference_velocity_ + beta_ref * ((reference - previous_reference_) / ts - reference_velocity_);
  reference_acceleration_ += beta_ref * ((new_reference_velocity - reference_velocity_) / ts - reference_acceleration_);
  reference_velocity_ = new_reference_velocity;

  // VOB: v = (g_v s theta + a_nom) / (s + g_v), a_nom = (i - i_dis_hat) / (m/K): the encoder
  // derivative at low frequency, the nominal model at high frequency; exact when the model is.
  const double gv_ts = p.velocity_observer_cutoff_rad_s * ts;
  const double nominal_acceleration = (applied_current_ - disturbance_current_) / inertia_per_torque;
  const double new_velocity =
      velocity_estimate_ +
      (gv_ts * ((angle - previous_angle_) / ts - velocity_estimate_) + ts * nominal_acceleration) / (1.0 + gv_ts);

  // DOB: i_dis = g_d / (s + g_d) (i - (m/K) s v_hat), fed the current applied over the last period.
  const double gd_ts = p.disturbance_observer_cutoff_rad_s * ts;
  if (p.disturbance_observer) {
    disturbance_current_ +=
        gd_ts / (1.0 + gd_ts) *
        (applied_current_ - disturbance_current_ - inertia_per_torque * (new_velocity - velocity_estimate_) / ts);
  }
  velocity_estimate_ = new_velocity;

  // Eq. 5 on the rotor side.
  const double acceleration_command = reference_acceleration_ -
                                      p.velocity_gain * (velocity_estimate_ - reference_velocity_) -
                                      p.position_gain * (angle - reference);
  const double command = inertia_per_torque * acceleration_command + disturbance_current_;
  JointOutput output;
  output.current_a = std::clamp(command, -p.current_limit_a, p.current_limit_a);
  output.limited = output.current_a != command;
  applied_current_ = output.current_a;
  previous_reference_ = reference;
  previous_angle_ = angle;
  return output;
}

}  // namespace delta::control
