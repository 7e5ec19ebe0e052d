// Single-joint plant for controller tests: motor, gearbox, arm, friction, gravity-like load, encoder.
#pragma once

#include <cstdint>
#include <limits>

namespace delta {

// Physical figures of one Delta joint. The motor figures are datasheet-like values for a
// Faulhaber 1628 024 B with a 15A-type planetary gearhead; they are ASSUMPTIONS (the paper
// gives none). Rotor side = motor shaft; shaft side = upper-arm axis; rotor = gear_ratio * shaft.
struct JointPlantParameters {
  double torque_constant_nm_per_a = 0.0194;  // K_T of the real motor [N m / A]
  double rotor_inertia_kg_m2 = 1.0e-7;       // motor rotor + gearhead input stage [kg m^2]
  double arm_inertia_kg_m2 = 2.0e-5;         // upper arm + share of lower arms and plate, shaft side
  double gear_ratio = 66.0;                  // g_r: rotor angle / shaft angle
  double viscous_nm_s_per_rad = 5.0e-8;      // rotor side [N m s / rad]
  double coulomb_nm = 2.0e-4;                // rotor side [N m] (also the breakaway torque)
  double gravity_nm = 6.0e-3;                // shaft side, times cos(shaft angle) [N m]
  double current_limit_a = 0.5;              // drive current limit [A]
  double encoder_resolution_deg = 0.01;      // shaft side, paper Section 5
  int substeps = 20;                         // integration steps per control period
};

// Rotor-side inertia seen by the motor: rotor plus arm through the gearbox (J_arm / g_r^2).
double rotor_side_inertia(const JointPlantParameters& parameters);

// One joint driven by a current held constant over each control period (zero-order hold).
// Coulomb friction sticks: at rest the joint stays put while |drive torque| <= coulomb_nm.
class JointPlant {
 public:
  JointPlant(const JointPlantParameters& parameters, double shaft_angle_deg);

  // Advances by period_s with the commanded current (clipped to the current limit) and an
  // external load torque on the shaft [N m] (positive opposes positive motion like gravity).
  void step(double current_a, double period_s, double extra_load_shaft_nm = 0.0);
  // The same motion solved exactly over period_s for a current held over it (no substeps): the
  // drive torque (motor, the gravity load at the present angle, viscous friction at the present
  // velocity) is held, so each piece of the step is a constant acceleration against Coulomb
  // friction; where the velocity reaches zero the joint stops there and sticks, or breaks away
  // the other way if the drive exceeds the friction, and the rest of the step goes on from there.
  void advance(double current_a, double period_s, double extra_load_shaft_nm = 0.0);

  double shaft_angle_deg() const;
  double rotor_angle_rad() const { return rotor_angle_rad_; }
  double rotor_velocity_rad_s() const { return rotor_velocity_rad_s_; }
  // Encoder reading: shaft angle floored to whole counts of encoder_resolution_deg.
  std::int32_t encoder_count() const;
  const JointPlantParameters& parameters() const { return parameters_; }

 private:
  double motor_nm(double current_a) const;  // the current clipped to the limit, as torque
  // Everything except Coulomb friction, referred to the rotor: the motor, the gravity load at the
  // present angle (its cosine kept while the angle holds), viscous friction at the present velocity.
  double drive_nm(double motor_nm, double extra_load_shaft_nm);

  JointPlantParameters parameters_;
  double inertia_kg_m2_;
  double rotor_angle_rad_;
  double shaft_rad_;  // rotor_angle_rad_ / gear_ratio, divided once per change
  double rotor_velocity_rad_s_ = 0.0;
  double cos_shaft_rad_ = std::numeric_limits<double>::quiet_NaN();  // the last cosine's argument (NaN: none)
  double cos_shaft_ = 0.0;
};

}  // namespace delta
