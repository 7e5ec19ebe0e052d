// The effect vocabulary of docs/contracts.md: geometry, measuring frame and joint sensor chain.
#include "delta/effects.hpp"

#include <Eigen/Geometry>

namespace delta {

const std::vector<std::string>& effect_vocabulary() {
  static const std::vector<std::string> names = {"joint_offset",  "upper_arm_length",   "lower_arm_length",
                                                 "radius_offset", "chain_angle",        "frame_misalignment",
                                                 "backlash",      "transmission_error", "encoder_scale"};
  return names;
}

bool EffectSet::empty() const { return names().empty(); }

std::vector<std::string> EffectSet::names() const {
  std::vector<std::string> present;
  if (joint_offset_deg) present.push_back("joint_offset");
  if (upper_arm_length_m) present.push_back("upper_arm_length");
  if (lower_arm_length_m) present.push_back("lower_arm_length");
  if (radius_offset_m) present.push_back("radius_offset");
  if (chain_angle_deg) present.push_back("chain_angle");
  if (frame_misalignment) present.push_back("frame_misalignment");
  if (backlash_deg) present.push_back("backlash");
  if (transmission_error) present.push_back("transmission_error");
  if (encoder_scale) present.push_back("encoder_scale");
  return present;
}

Geometry apply_geometry_effects(const Geometry& nominal, const EffectSet& effects) {
  Geometry geometry = nominal;
  for (int j = 0; j < 3; ++j) {
    ChainGeometry& chain = geometry.chains[j];
    if (effects.upper_arm_length_m) chain.upper_arm_m += (*effects.upper_arm_length_m)[j];
    if (effects.lower_arm_length_m) chain.lower_arm_m += (*effects.lower_arm_length_m)[j];
    if (effects.radius_offset_m) chain.radius_offset_m += (*effects.radius_offset_m)[j];
    if (effects.chain_angle_deg) chain.angle_deg += (*effects.chain_angle_deg)[j];
  }
  return geometry;
}

Eigen::Matrix3d misalignment_rotation(const Vec3& rotation_deg) {
  const Vec3 r = rotation_deg * kRadPerDeg;
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

StageFrame::StageFrame(const EffectSet& effects) : misaligned_(effects.frame_misalignment.has_value()) {
  if (!misaligned_) return;
  rotation_ = misalignment_rotation(effects.frame_misalignment->rotation_deg);
  translation_m_ = effects.frame_misalignment->translation_m;
}

Vec3 apply_frame_misalignment(const EffectSet& effects, const Vec3& true_position_m) {
  return StageFrame(effects)(true_position_m);
}

JointSensorChain::JointSensorChain(const EffectSet& effects) : effects_(effects) {
  for (int j = 0; j < 3; ++j) {
    backlash_[j] = Backlash(effects.backlash_deg ? (*effects.backlash_deg)[j] : 0.0);
  }
}

void JointSensorChain::reset() {
  for (Backlash& play : backlash_) play.reset();
}

double JointSensorChain::scaled_and_transmitted(int joint, double true_alpha_deg) const {
  const double scale = effects_.encoder_scale ? (*effects_.encoder_scale)[joint] : 0.0;
  double amplitude = 0.0, period = 360.0, phase = 0.0;
  if (effects_.transmission_error) {
    amplitude = effects_.transmission_error->amplitude_deg[joint];
    period = effects_.transmission_error->period_deg[joint];
    phase = effects_.transmission_error->phase_rad[joint];
  }
  return scale_and_transmission(true_alpha_deg, scale, amplitude, period, phase);
}

double JointSensorChain::reading_without_backlash(int joint, double true_alpha_deg) const {
  const double offset = effects_.joint_offset_deg ? (*effects_.joint_offset_deg)[joint] : 0.0;
  // The angle update() last saw (the world's present one): its transmission, without libm.
  if (true_alpha_deg == last_true_alpha_deg_[joint]) return last_transmitted_deg_[joint] + offset;
  return scaled_and_transmitted(joint, true_alpha_deg) + offset;
}

Vec3 JointSensorChain::update(const Vec3& true_alpha_deg) {
  Vec3 measured;
  for (int j = 0; j < 3; ++j) {
    // A joint at rest keeps its angle: the last transmission (the same bits, without libm).
    if (true_alpha_deg[j] != last_true_alpha_deg_[j]) {
      last_true_alpha_deg_[j] = true_alpha_deg[j];
      last_transmitted_deg_[j] = scaled_and_transmitted(j, true_alpha_deg[j]);
    }
    double alpha = last_transmitted_deg_[j];
    if (effects_.backlash_deg) alpha = backlash_[j].update(alpha);
    if (effects_.joint_offset_deg) alpha += (*effects_.joint_offset_deg)[j];
    measured[j] = alpha;
  }
  return measured;
}

}  // namespace delta
