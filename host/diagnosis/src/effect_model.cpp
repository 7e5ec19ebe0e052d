// Parameter layout of the diagnosis model and its conversion to and from SPEC effect sets.
#include "delta/diagnosis/effect_model.hpp"

namespace delta::diagnosis {

const char* family_name(Family family) {
  static const char* names[kFamilyCount] = {"joint_offset",  "upper_arm_length",   "lower_arm_length",
                                            "radius_offset", "chain_angle",        "frame_misalignment",
                                            "backlash",      "transmission_error", "encoder_scale"};
  return names[index_of(family)];
}

const char* subsystem_of(Family family) {
  switch (family) {
    case Family::upper_arm_length:
    case Family::lower_arm_length:
    case Family::radius_offset:
    case Family::chain_angle:
      return "geometry";
    case Family::frame_misalignment:
      return "measuring frame";
    case Family::backlash:
    case Family::transmission_error:
      return "transmission";
    case Family::joint_offset:
    case Family::encoder_scale:
      return "sensor";
  }
  return "?";
}

FamilySet single(Family family) {
  FamilySet set;
  set.set(index_of(family));
  return set;
}

std::string describe(FamilySet families) {
  std::string text;
  for (int f = 0; f < kFamilyCount; ++f) {
    if (families[f]) text += (text.empty() ? "" : " + ") + std::string(family_name(family_at(f)));
  }
  return text.empty() ? "nominal" : text;
}

const std::array<ParameterInfo, kParameterCount>& parameter_table() {
  static const std::array<ParameterInfo, kParameterCount> table = [] {
    std::array<ParameterInfo, kParameterCount> t;
    auto per_joint = [&t](int base, const std::string& stem, const std::string& unit, Family family, double typical) {
      for (int j = 0; j < 3; ++j) t[base + j] = {stem + "_" + std::to_string(j + 1), unit, family, typical};
    };
    per_joint(slot::joint_offset, "o", "deg", Family::joint_offset, 1.0);
    per_joint(slot::upper_arm, "dL_A", "mm", Family::upper_arm_length, 1.0);
    per_joint(slot::lower_arm, "dL_B", "mm", Family::lower_arm_length, 1.0);
    per_joint(slot::radius, "dr", "mm", Family::radius_offset, 1.0);
    per_joint(slot::chain_angle, "dphi", "deg", Family::chain_angle, 1.0);
    const char* rotations[3] = {"rx", "ry", "rz"};
    const char* translations[3] = {"tx", "ty", "tz"};
    for (int k = 0; k < 3; ++k) {
      t[slot::frame_rotation + k] = {rotations[k], "deg", Family::frame_misalignment, 1.0};
      t[slot::frame_translation + k] = {translations[k], "mm", Family::frame_misalignment, 1.0};
    }
    per_joint(slot::backlash, "b", "deg", Family::backlash, 0.3);
    per_joint(slot::amplitude, "A", "deg", Family::transmission_error, 0.1);
    per_joint(slot::period, "P", "deg", Family::transmission_error, 10.0);
    per_joint(slot::phase, "phi", "rad", Family::transmission_error, 1.0);
    per_joint(slot::encoder_scale, "k", "-", Family::encoder_scale, 0.01);
    return t;
  }();
  return table;
}

std::vector<int> parameter_indices(FamilySet families) {
  std::vector<int> indices;
  for (int k = 0; k < kParameterCount; ++k) {
    if (families[index_of(parameter_table()[k].family)]) indices.push_back(k);
  }
  return indices;
}

Parameters neutral_parameters() {
  Parameters theta = Parameters::Zero();
  theta.segment<3>(slot::period).setConstant(360.0);
  return theta;
}

std::array<int, kLocalCount> local_parameters(int joint) {
  return {slot::joint_offset + joint,  slot::upper_arm + joint,     slot::lower_arm + joint,
          slot::radius + joint,        slot::chain_angle + joint,   slot::frame_rotation + 0,
          slot::frame_rotation + 1,    slot::frame_rotation + 2,    slot::frame_translation + 0,
          slot::frame_translation + 1, slot::frame_translation + 2, slot::backlash + joint,
          slot::amplitude + joint,     slot::period + joint,        slot::phase + joint,
          slot::encoder_scale + joint};
}

EffectSet to_effect_set(const Parameters& theta, FamilySet families) {
  EffectSet effects;
  auto has = [&families](Family f) { return families[index_of(f)]; };
  if (has(Family::joint_offset)) effects.joint_offset_deg = theta.segment<3>(slot::joint_offset);
  if (has(Family::upper_arm_length)) effects.upper_arm_length_m = theta.segment<3>(slot::upper_arm) * 1e-3;
  if (has(Family::lower_arm_length)) effects.lower_arm_length_m = theta.segment<3>(slot::lower_arm) * 1e-3;
  if (has(Family::radius_offset)) effects.radius_offset_m = theta.segment<3>(slot::radius) * 1e-3;
  if (has(Family::chain_angle)) effects.chain_angle_deg = theta.segment<3>(slot::chain_angle);
  if (has(Family::frame_misalignment)) {
    FrameMisalignment frame;
    frame.rotation_deg = theta.segment<3>(slot::frame_rotation);
    frame.translation_m = theta.segment<3>(slot::frame_translation) * 1e-3;
    effects.frame_misalignment = frame;
  }
  if (has(Family::backlash)) effects.backlash_deg = theta.segment<3>(slot::backlash);
  if (has(Family::transmission_error)) {
    TransmissionError transmission;
    transmission.amplitude_deg = theta.segment<3>(slot::amplitude);
    transmission.period_deg = theta.segment<3>(slot::period);
    transmission.phase_rad = theta.segment<3>(slot::phase);
    effects.transmission_error = transmission;
  }
  if (has(Family::encoder_scale)) effects.encoder_scale = theta.segment<3>(slot::encoder_scale);
  return effects;
}

Parameters from_effect_set(const EffectSet& effects) {
  Parameters theta = neutral_parameters();
  if (effects.joint_offset_deg) theta.segment<3>(slot::joint_offset) = *effects.joint_offset_deg;
  if (effects.upper_arm_length_m) theta.segment<3>(slot::upper_arm) = *effects.upper_arm_length_m * 1e3;
  if (effects.lower_arm_length_m) theta.segment<3>(slot::lower_arm) = *effects.lower_arm_length_m * 1e3;
  if (effects.radius_offset_m) theta.segment<3>(slot::radius) = *effects.radius_offset_m * 1e3;
  if (effects.chain_angle_deg) theta.segment<3>(slot::chain_angle) = *effects.chain_angle_deg;
  if (effects.frame_misalignment) {
    theta.segment<3>(slot::frame_rotation) = effects.frame_misalignment->rotation_deg;
    theta.segment<3>(slot::frame_translation) = effects.frame_misalignment->translation_m * 1e3;
  }
  if (effects.backlash_deg) theta.segment<3>(slot::backlash) = *effects.backlash_deg;
  if (effects.transmission_error) {
    theta.segment<3>(slot::amplitude) = effects.transmission_error->amplitude_deg;
    theta.segment<3>(slot::period) = effects.transmission_error->period_deg;
    theta.segment<3>(slot::phase) = effects.transmission_error->phase_rad;
  }
  if (effects.encoder_scale) theta.segment<3>(slot::encoder_scale) = *effects.encoder_scale;
  return theta;
}

FamilySet families_of(const EffectSet& effects) {
  FamilySet set;
  for (const std::string& name : effects.names()) {
    for (int f = 0; f < kFamilyCount; ++f) {
      if (name == family_name(family_at(f))) set.set(f);
    }
  }
  return set;
}

Prediction predict_recording(const EffectSet& effects, const std::vector<Sample>& rows) {
  Prediction prediction;
  prediction.alpha_deg.reserve(rows.size());
  const Geometry geometry = apply_geometry_effects(Geometry::nominal(), effects);
  Eigen::Matrix3d inverse_rotation = Eigen::Matrix3d::Identity();
  Vec3 translation = Vec3::Zero();
  if (effects.frame_misalignment) {
    inverse_rotation = misalignment_rotation(effects.frame_misalignment->rotation_deg).transpose();
    translation = effects.frame_misalignment->translation_m;
  }
  JointSensorChain sensors(effects);
  Vec3 true_alpha = Vec3::Zero();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const IkSolution ik = inverse_kinematics(geometry, inverse_rotation * (rows[i].position_m - translation));
    if (ik.ok()) {
      true_alpha = ik.alpha_deg;
    } else if (prediction.unreachable++ == 0) {
      prediction.first_unreachable = i;
    }
    prediction.alpha_deg.push_back(sensors.update(true_alpha));
  }
  return prediction;
}

}  // namespace delta::diagnosis
