// Effect-file reader and writer with line-accurate errors.
#include "delta/effect_file.hpp"

#include <algorithm>
#include <cmath>

#include "delta/input_error.hpp"
#include "delta/json_input.hpp"

namespace delta {
namespace {

using nlohmann::json;

struct Context {
  const std::string& text;
  const std::string& path;
  [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
    throw InputError(path, line_of_key(text, key), reason);
  }
  double number(const json& value, const std::string& key, const std::string& what) const {
    if (!value.is_number()) fail(key, key + ": " + what + " must be a number, got " + value.dump());
    const double number = value.get<double>();
    if (!std::isfinite(number)) fail(key, key + ": " + what + " is not finite");
    return number;
  }
  Vec3 triple(const json& value, const std::string& key, const std::string& what) const {
    if (!value.is_array() || value.size() != 3) {
      fail(key, key + ": " + what + " must be an array of 3 numbers (one per chain), got " + value.dump());
    }
    return Vec3(number(value[0], key, what), number(value[1], key, what), number(value[2], key, what));
  }
};

TransmissionError parse_transmission(const json& value, const Context& context) {
  const std::string key = "transmission_error";
  TransmissionError transmission;
  if (value.is_object()) {
    for (const auto& [name, item] : value.items()) {
      if (name == "amplitude_deg" || name == "A")
        transmission.amplitude_deg = context.triple(item, key, name);
      else if (name == "period_deg" || name == "P")
        transmission.period_deg = context.triple(item, key, name);
      else if (name == "phase_rad" || name == "phi")
        transmission.phase_rad = context.triple(item, key, name);
      else
        context.fail(key, key + ": unknown field '" + name + "' (expected amplitude_deg, period_deg, phase_rad)");
    }
  } else if (value.is_array() && value.size() == 3 && value[0].is_array()) {
    for (int j = 0; j < 3; ++j) {
      const Vec3 entry = context.triple(value[j], key, "chain entry [A_deg, P_deg, phi_rad]");
      transmission.amplitude_deg[j] = entry[0];
      transmission.period_deg[j] = entry[1];
      transmission.phase_rad[j] = entry[2];
    }
  } else {
    context.fail(
        key,
        key +
            ": expected {\"amplitude_deg\":[..],\"period_deg\":[..],\"phase_rad\":[..]} or three [A, P, phi] triples");
  }
  for (int j = 0; j < 3; ++j) {
    if (!(std::fabs(transmission.period_deg[j]) > 0.0)) context.fail(key, key + ": period_deg must not be zero");
  }
  return transmission;
}

FrameMisalignment parse_frame(const json& value, const Context& context) {
  const std::string key = "frame_misalignment";
  FrameMisalignment frame;
  const char* names[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  double parameters[6] = {0, 0, 0, 0, 0, 0};
  if (value.is_object()) {
    for (const auto& entry : value.items()) {
      const std::string& name = entry.key();  // a plain name: C++17 lambdas cannot capture a binding
      const json& item = entry.value();
      const auto* found = std::find_if(std::begin(names), std::end(names), [&](const char* n) { return name == n; });
      if (found == std::end(names))
        context.fail(key, key + ": unknown field '" + name + "' (expected rx ry rz [deg], tx ty tz [m])");
      parameters[found - std::begin(names)] = context.number(item, key, name);
    }
  } else if (value.is_array() && value.size() == 6) {
    for (int k = 0; k < 6; ++k) parameters[k] = context.number(value[k], key, names[k]);
  } else {
    context.fail(key, key + ": expected {\"rx\",\"ry\",\"rz\",\"tx\",\"ty\",\"tz\"} or an array of 6 numbers");
  }
  frame.rotation_deg = Vec3(parameters[0], parameters[1], parameters[2]);
  frame.translation_m = Vec3(parameters[3], parameters[4], parameters[5]);
  return frame;
}

}  // namespace

EffectSet parse_effects(const std::string& text, const std::string& path) {
  const json document = parse_json_input(text, path);
  if (!document.is_object()) throw InputError(path, 1, "an effect file must be a JSON object of effect names");
  const Context context{text, path};
  EffectSet effects;
  for (const auto& [name, value] : document.items()) {
    if (name == "joint_offset")
      effects.joint_offset_deg = context.triple(value, name, "o_j [deg]");
    else if (name == "upper_arm_length")
      effects.upper_arm_length_m = context.triple(value, name, "dL_A [m]");
    else if (name == "lower_arm_length")
      effects.lower_arm_length_m = context.triple(value, name, "dL_B [m]");
    else if (name == "radius_offset")
      effects.radius_offset_m = context.triple(value, name, "dr [m]");
    else if (name == "chain_angle")
      effects.chain_angle_deg = context.triple(value, name, "dphi [deg]");
    else if (name == "backlash") {
      effects.backlash_deg = context.triple(value, name, "b_j [deg]");
      if ((effects.backlash_deg->array() < 0.0).any()) context.fail(name, "backlash: width must not be negative");
    } else if (name == "encoder_scale")
      effects.encoder_scale = context.triple(value, name, "k_j [-]");
    else if (name == "transmission_error")
      effects.transmission_error = parse_transmission(value, context);
    else if (name == "frame_misalignment")
      effects.frame_misalignment = parse_frame(value, context);
    else {
      std::string known;
      for (const std::string& entry : effect_vocabulary()) known += (known.empty() ? "" : ", ") + entry;
      context.fail(name, "unknown effect '" + name + "' (the vocabulary: " + known + ")");
    }
  }
  return effects;
}

EffectSet read_effect_file(const std::string& path) { return parse_effects(read_input_text(path), path); }

nlohmann::json effects_to_json(const EffectSet& effects) {
  auto triple = [](const Vec3& v) { return json::array({v[0], v[1], v[2]}); };
  json document = json::object();
  if (effects.joint_offset_deg) document["joint_offset"] = triple(*effects.joint_offset_deg);
  if (effects.upper_arm_length_m) document["upper_arm_length"] = triple(*effects.upper_arm_length_m);
  if (effects.lower_arm_length_m) document["lower_arm_length"] = triple(*effects.lower_arm_length_m);
  if (effects.radius_offset_m) document["radius_offset"] = triple(*effects.radius_offset_m);
  if (effects.chain_angle_deg) document["chain_angle"] = triple(*effects.chain_angle_deg);
  if (effects.frame_misalignment) {
    const FrameMisalignment& f = *effects.frame_misalignment;
    document["frame_misalignment"] = {{"rx", f.rotation_deg[0]},  {"ry", f.rotation_deg[1]},
                                      {"rz", f.rotation_deg[2]},  {"tx", f.translation_m[0]},
                                      {"ty", f.translation_m[1]}, {"tz", f.translation_m[2]}};
  }
  if (effects.backlash_deg) document["backlash"] = triple(*effects.backlash_deg);
  if (effects.transmission_error) {
    const TransmissionError& t = *effects.transmission_error;
    document["transmission_error"] = {{"amplitude_deg", triple(t.amplitude_deg)},
                                      {"period_deg", triple(t.period_deg)},
                                      {"phase_rad", triple(t.phase_rad)}};
  }
  if (effects.encoder_scale) document["encoder_scale"] = triple(*effects.encoder_scale);
  return document;
}

}  // namespace delta
