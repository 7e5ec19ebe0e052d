// Single-joint plant: semi-implicit Euler on the rotor side with sticking Coulomb friction.
#include "delta/joint_plant.hpp"

#include <algorithm>
#include <cmath>

#include "delta/geometry.hpp"

namespace delta {

double rotor_side_inertia(const JointPlantParameters& parameters) {
  return parameters.rotor_inertia_kg_m2 +
         parameters.arm_inertia_kg_m2 / (parameters.gear_ratio * parameters.gear_ratio);
}

JointPlant::JointPlant(const JointPlantParameters& parameters, double shaft_angle_deg)
    : parameters_(parameters),
      inertia_kg_m2_(rotor_side_inertia(parameters)),
      rotor_angle_rad_(shaft_angle_deg * kRadPerDeg * parameters.gear_ratio),
      shaft_rad_(rotor_angle_rad_ / parameters.gear_ratio) {}

double JointPlant::shaft_angle_deg() const { return shaft_rad_ * kDegPerRad; }

std::int32_t JointPlant::encoder_count() const {
  return static_cast<std::int32_t>(std::floor(shaft_angle_deg() / parameters_.encoder_resolution_deg));
}

double JointPlant::motor_nm(double current_a) const {
  const double limit = parameters_.current_limit_a;
  return parameters_.torque_constant_nm_per_a * std::clamp(current_a, -limit, limit);
}

double JointPlant::drive_nm(double motor_nm, double extra_load_shaft_nm) {
  // A joint at rest keeps its angle: its cosine is the last one (the same bits, without libm).
  if (shaft_rad_ != cos_shaft_rad_) {
    cos_shaft_rad_ = shaft_rad_;
    cos_shaft_ = std::cos(shaft_rad_);
  }
  const double load_shaft_nm = parameters_.gravity_nm * cos_shaft_ + extra_load_shaft_nm;
  return motor_nm - load_shaft_nm / parameters_.gear_ratio - parameters_.viscous_nm_s_per_rad * rotor_velocity_rad_s_;
}

void JointPlant::step(double current_a, double period_s, double extra_load_shaft_nm) {
  const double motor = motor_nm(current_a);
  const double dt = period_s / parameters_.substeps;
  for (int n = 0; n < parameters_.substeps; ++n) {
    const double drive_nm = this->drive_nm(motor, extra_load_shaft_nm);
    if (rotor_velocity_rad_s_ == 0.0 && std::abs(drive_nm) <= parameters_.coulomb_nm) continue;  // stuck
    const double direction =
        rotor_velocity_rad_s_ != 0.0 ? std::copysign(1.0, rotor_velocity_rad_s_) : std::copysign(1.0, drive_nm);
    const double acceleration = (drive_nm - direction * parameters_.coulomb_nm) / inertia_kg_m2_;
    const double new_velocity = rotor_velocity_rad_s_ + acceleration * dt;
    // Friction cannot reverse the motion within a step: crossing zero means the joint stops there.
    const bool reversed = rotor_velocity_rad_s_ != 0.0 && new_velocity * rotor_velocity_rad_s_ < 0.0;
    rotor_velocity_rad_s_ = reversed ? 0.0 : new_velocity;
    rotor_angle_rad_ += rotor_velocity_rad_s_ * dt;
    shaft_rad_ = rotor_angle_rad_ / parameters_.gear_ratio;
  }
}

void JointPlant::advance(double current_a, double period_s, double extra_load_shaft_nm) {
  const double drive_nm = this->drive_nm(motor_nm(current_a), extra_load_shaft_nm);  // held over the step
  double remaining = period_s;
  double angle = rotor_angle_rad_;
  double velocity = rotor_velocity_rad_s_;
  // At most three pieces: moving, stopped where friction reversed it, broken away the other way.
  for (int piece = 0; piece < 3 && remaining > 0.0; ++piece) {
    if (velocity == 0.0 && std::abs(drive_nm) <= parameters_.coulomb_nm) break;  // stuck for the rest
    const double direction = velocity != 0.0 ? std::copysign(1.0, velocity) : std::copysign(1.0, drive_nm);
    const double acceleration = (drive_nm - direction * parameters_.coulomb_nm) / inertia_kg_m2_;
    const double to_stop = velocity * acceleration < 0.0 ? -velocity / acceleration : remaining;
    if (to_stop < remaining) {  // friction stops the joint within the step
      angle += 0.5 * velocity * to_stop;
      velocity = 0.0;
      remaining -= to_stop;
      continue;
    }
    angle += (velocity + 0.5 * acceleration * remaining) * remaining;
    velocity += acceleration * remaining;
    remaining = 0.0;
  }
  if (angle != rotor_angle_rad_) {
    rotor_angle_rad_ = angle;
    shaft_rad_ = rotor_angle_rad_ / parameters_.gear_ratio;
  }
  rotor_velocity_rad_s_ = velocity;
}

}  // namespace delta
