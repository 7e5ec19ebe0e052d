// Reader and writer of W.json (see weights_file.hpp for the layout) with line-accurate errors.
#include "delta/nn/weights_file.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "delta/effect_file.hpp"
#include "delta/input_error.hpp"
#include "delta/json_input.hpp"
#include "delta/output_file.hpp"

namespace delta::nn {
namespace {

using nlohmann::json;

constexpr const char* kFormatName = "delta-nn-weights";

// nlohmann::json keeps no positions: an error about a key points at its first quoted occurrence.
struct Reader {
  const std::string& text;
  const std::string& path;
  const json& document;

  [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
    throw InputError(path, line_of_key(text, key), reason);
  }
  const json& field(const std::string& key) const {
    const auto found = document.find(key);
    if (found == document.end()) throw InputError(path, 1, "missing field \"" + key + "\"");
    return *found;
  }
  double number(const json& value, const std::string& key) const {
    if (!value.is_number()) fail(key, key + ": expected a number, got " + value.dump());
    const double number = value.get<double>();
    if (!std::isfinite(number)) fail(key, key + ": value is not finite");
    return number;
  }
  Eigen::VectorXd vector(const std::string& key, Eigen::Index size) const {
    const json& value = field(key);
    if (!value.is_array() || static_cast<Eigen::Index>(value.size()) != size) {
      fail(key, key + ": expected an array of " + std::to_string(size) + " numbers");
    }
    Eigen::VectorXd result(size);
    for (Eigen::Index i = 0; i < size; ++i) result[i] = number(value[static_cast<std::size_t>(i)], key);
    return result;
  }
  Eigen::MatrixXd matrix(const std::string& key, Eigen::Index rows, Eigen::Index columns) const {
    const json& value = field(key);
    const std::string shape = std::to_string(rows) + " rows of " + std::to_string(columns) + " numbers";
    if (!value.is_array() || static_cast<Eigen::Index>(value.size()) != rows) {
      fail(key, key + ": expected " + shape + ", got " + std::to_string(value.is_array() ? value.size() : 0) + " rows");
    }
    Eigen::MatrixXd result(rows, columns);
    for (Eigen::Index r = 0; r < rows; ++r) {
      const json& row = value[static_cast<std::size_t>(r)];
      if (!row.is_array() || static_cast<Eigen::Index>(row.size()) != columns) {
        fail(key, key + ": row " + std::to_string(r + 1) + " is not an array of " + std::to_string(columns) +
                      " numbers (expected " + shape + ")");
      }
      for (Eigen::Index c = 0; c < columns; ++c) result(r, c) = number(row[static_cast<std::size_t>(c)], key);
    }
    return result;
  }
};

std::string vector_text(const Eigen::VectorXd& values) {
  std::string text = "[";
  for (Eigen::Index i = 0; i < values.size(); ++i) text += (i ? ", " : "") + format_number(values[i]);
  return text + "]";
}

std::string matrix_text(const Eigen::MatrixXd& values) {
  std::string text = "[";
  for (Eigen::Index r = 0; r < values.rows(); ++r) {
    text += std::string(r ? ",\n    " : "\n    ") + vector_text(values.row(r).transpose());
  }
  return text + "]";
}

// "joint_ripple": {"bin_deg", "first_deg": [3], "values_deg": [3 arrays]}.
JointRippleTable parse_joint_ripple(const Reader& part) {
  if (!part.document.is_object()) part.fail("joint_ripple", "joint_ripple must be a JSON object");
  for (const auto& item : part.document.items()) {
    if (item.key() != "bin_deg" && item.key() != "first_deg" && item.key() != "values_deg") {
      part.fail("joint_ripple", "joint_ripple: unknown key " + quoted_excerpt(item.key()) +
                                    " (expected bin_deg, first_deg, values_deg)");
    }
  }
  JointRippleTable table;
  table.bin_deg = part.number(part.field("bin_deg"), "bin_deg");
  if (!(table.bin_deg >= 0.001 && table.bin_deg <= 10.0)) {
    part.fail("bin_deg", "bin_deg must be 0.001 to 10 deg, got " + format_number(table.bin_deg));
  }
  table.first_deg = part.vector("first_deg", 3);
  const nlohmann::json& values = part.field("values_deg");
  if (!values.is_array() || values.size() != 3) part.fail("values_deg", "values_deg: expected 3 arrays, one per joint");
  for (std::size_t j = 0; j < 3; ++j) {
    const nlohmann::json& joint = values[j];
    if (!joint.is_array() || joint.size() < 2 || joint.size() > kMaxJointRippleEntries) {
      part.fail("values_deg", "values_deg: joint " + std::to_string(j + 1) + " needs 2 to " +
                                  std::to_string(kMaxJointRippleEntries) + " numbers");
    }
    for (const nlohmann::json& value : joint) {
      const double entry = part.number(value, "values_deg");
      if (!(std::abs(entry) <= kMaxJointRippleDeg)) {
        part.fail("values_deg", "values_deg: joint " + std::to_string(j + 1) + " has " + format_number(entry) +
                                    " deg, beyond +-" + format_number(kMaxJointRippleDeg));
      }
      std::vector<double>& entries = table.values_deg[j];
      if (!entries.empty() && std::abs(entry - entries.back()) > kMaxJointRippleSlope * table.bin_deg * (1 + 1e-9)) {
        part.fail("values_deg", "values_deg: joint " + std::to_string(j + 1) + " changes by " +
                                    format_number(entry - entries.back()) + " deg from entry " +
                                    std::to_string(entries.size()) + " to " + std::to_string(entries.size() + 1) +
                                    " (bin " + format_number(table.bin_deg) + " deg), steeper than " +
                                    format_number(kMaxJointRippleSlope) +
                                    " deg per deg: the shaping would move the joint beyond the path's checked speed");
      }
      entries.push_back(entry);
    }
  }
  return table;
}

std::string joint_ripple_text(const JointRippleTable& table) {
  std::string text = "{\"bin_deg\": " + format_number(table.bin_deg) +
                     ", \"first_deg\": " + vector_text(table.first_deg) + ", \"values_deg\": [";
  for (std::size_t j = 0; j < 3; ++j) {
    const std::vector<double>& values = table.values_deg[j];
    text += std::string(j ? ",\n    " : "\n    ") +
            vector_text(Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size())));
  }
  return text + "]}";
}

}  // namespace

double JointRippleTable::at(int joint, double alpha_deg) const {
  const std::vector<double>& values = values_deg[static_cast<std::size_t>(joint)];
  if (values.empty()) return 0.0;
  const double position =
      std::clamp((alpha_deg - first_deg[joint]) / bin_deg, 0.0, static_cast<double>(values.size() - 1));
  const std::size_t low = std::min(static_cast<std::size_t>(position), values.size() - 1);
  const std::size_t high = std::min(low + 1, values.size() - 1);
  const double weight = position - static_cast<double>(low);
  return (1.0 - weight) * values[low] + weight * values[high];
}

Vec3 JointRippleTable::at(const Vec3& alpha_deg) const {
  return {at(0, alpha_deg[0]), at(1, alpha_deg[1]), at(2, alpha_deg[2])};
}

WeightsFile parse_weights_file(const std::string& text, const std::string& path) {
  const json document = parse_json_input(text, path);
  if (!document.is_object()) throw InputError(path, 1, "a weights file must be a JSON object");
  const Reader reader{text, path, document};
  const json& format = reader.field("format");
  if (format != kFormatName)
    reader.fail("format", "format must be \"" + std::string(kFormatName) + "\", got " + format.dump());
  const json& version = reader.field("version");
  if (!version.is_number_integer() || version.get<long long>() < kFirstWeightsFileVersion ||
      version.get<long long>() > kWeightsFileVersion) {
    reader.fail("version", "unsupported weights file version " + version.dump() + " (this build reads versions " +
                               std::to_string(kFirstWeightsFileVersion) + " to " + std::to_string(kWeightsFileVersion) +
                               ")");
  }
  WeightsFile weights;
  const json& model = reader.field("model");
  if (model != "network" && model != "hybrid" && model != "deployed") {
    reader.fail("model", "model must be \"network\", \"hybrid\" or \"deployed\", got " + quoted_excerpt(model.dump()));
  }
  weights.model = model.get<std::string>();
  if (version.get<int>() < weights.version()) {
    reader.fail("version", "model \"" + weights.model + "\" needs weights file version " +
                               std::to_string(weights.version()) + ", the file says " + version.dump());
  }
  const json& hidden_value = reader.field("hidden");
  if (!hidden_value.is_number_integer() || hidden_value.get<long long>() < 1 ||
      hidden_value.get<long long>() > kMaxHiddenNeurons) {
    reader.fail("hidden", "hidden must be a whole number of neurons between 1 and " +
                              std::to_string(kMaxHiddenNeurons) + ", got " + quoted_excerpt(hidden_value.dump()));
  }
  const Eigen::Index hidden = hidden_value.get<Eigen::Index>();
  Network& network = weights.network;
  network.input_min = reader.vector("input_min", 3);
  network.input_max = reader.vector("input_max", 3);
  network.output_min = reader.vector("output_min", 3);
  network.output_max = reader.vector("output_max", 3);
  for (int k = 0; k < 3; ++k) {
    if (!(network.input_max[k] > network.input_min[k])) {
      reader.fail("input_max", "input_max must exceed input_min on every axis (mapminmax divides by the range)");
    }
    if (!(network.output_max[k] > network.output_min[k])) {
      reader.fail("output_max", "output_max must exceed output_min on every joint (mapminmax divides by the range)");
    }
  }
  network.input_weights = reader.matrix("input_weights", hidden, 3);
  network.hidden_bias = reader.vector("hidden_bias", hidden);
  network.output_weights = reader.matrix("output_weights", 3, hidden);
  network.output_bias = reader.vector("output_bias", 3);
  const auto effects = document.find("effects");
  if (weights.hybrid()) {
    if (effects == document.end()) throw InputError(path, 1, "a hybrid model needs an \"effects\" object");
    try {
      weights.effects = parse_effects(effects->dump(), path);
    } catch (const InputError& error) {
      reader.fail("effects", "effects: " + error.reason());
    }
    if (weights.effects.backlash_deg) {
      reader.fail("effects", "effects: backlash depends on the direction of motion; a pose-wise model cannot apply it");
    }
  } else if (effects != document.end()) {
    reader.fail("effects", "effects belong to a hybrid model only (this file says model \"network\")");
  }
  const auto compensation = document.find("compensation");
  if (weights.deployed()) {
    if (compensation == document.end()) throw InputError(path, 1, "a deployed model needs a \"compensation\" object");
    if (!compensation->is_object()) reader.fail("compensation", "compensation must be a JSON object");
    for (const auto& item : compensation->items()) {
      if (item.key() != "backlash_half_play_deg" && item.key() != "joint_ripple") {
        reader.fail("compensation", "compensation: unknown part " + quoted_excerpt(item.key()) +
                                        " (this build applies backlash_half_play_deg and joint_ripple only)");
      }
    }
    const Reader part{text, path, *compensation};
    weights.backlash_half_play_deg = part.vector("backlash_half_play_deg", 3);
    for (int j = 0; j < 3; ++j) {
      const double half_play = weights.backlash_half_play_deg[j];
      if (!(half_play >= 0.0 && half_play <= kMaxBacklashHalfPlayDeg)) {
        reader.fail("backlash_half_play_deg", "backlash_half_play_deg: joint " + std::to_string(j + 1) + " has " +
                                                  format_number(half_play) + " deg, expected 0 to " +
                                                  format_number(kMaxBacklashHalfPlayDeg));
      }
    }
    const auto ripple = compensation->find("joint_ripple");
    if (ripple != compensation->end()) {
      if (version.get<int>() < 3) reader.fail("joint_ripple", "joint_ripple needs weights file version 3");
      weights.joint_ripple = parse_joint_ripple(Reader{text, path, *ripple});
    }
  } else if (compensation != document.end()) {
    reader.fail("compensation", "compensation belongs to a deployed model only (this file says model " +
                                    json(weights.model).dump() + ")");
  }
  const auto provenance = document.find("provenance");
  if (provenance != document.end()) {
    if (!provenance->is_object()) reader.fail("provenance", "provenance must be a JSON object");
    weights.provenance = *provenance;
  }
  return weights;
}

WeightsFile read_weights_file(const std::string& path) { return parse_weights_file(read_input_text(path), path); }

std::string weights_file_text(const WeightsFile& weights) {
  const Network& network = weights.network;
  std::string text = "{\n";
  text += "  \"format\": \"" + std::string(kFormatName) + "\",\n";
  text += "  \"version\": " + std::to_string(weights.version()) + ",\n";
  text += "  \"model\": " + json(weights.model).dump() + ",\n";
  text += "  \"hidden\": " + std::to_string(network.hidden()) + ",\n";
  text += "  \"input_min\": " + vector_text(network.input_min) + ",\n";
  text += "  \"input_max\": " + vector_text(network.input_max) + ",\n";
  text += "  \"output_min\": " + vector_text(network.output_min) + ",\n";
  text += "  \"output_max\": " + vector_text(network.output_max) + ",\n";
  text += "  \"input_weights\": " + matrix_text(network.input_weights) + ",\n";
  text += "  \"hidden_bias\": " + vector_text(network.hidden_bias) + ",\n";
  text += "  \"output_weights\": " + matrix_text(network.output_weights) + ",\n";
  text += "  \"output_bias\": " + vector_text(network.output_bias) + ",\n";
  if (weights.hybrid()) text += "  \"effects\": " + effects_to_json(weights.effects).dump() + ",\n";
  if (weights.deployed()) {
    text += "  \"compensation\": {\"backlash_half_play_deg\": " + vector_text(weights.backlash_half_play_deg);
    if (!weights.joint_ripple.empty()) text += ",\n    \"joint_ripple\": " + joint_ripple_text(weights.joint_ripple);
    text += "},\n";
  }
  // nlohmann's dump prints doubles as shortest round-trip text and sorts keys: deterministic.
  text += "  \"provenance\": " + weights.provenance.dump() + "\n";
  return text + "}\n";
}

void write_weights_file(const std::string& path, const WeightsFile& weights) {
  if (weights.network.hidden_bias.size() > kMaxHiddenNeurons) {
    throw InputError(path, 0,
                     "a network of " + std::to_string(weights.network.hidden_bias.size()) +
                         " hidden neurons; a weights file holds at most " + std::to_string(kMaxHiddenNeurons));
  }
  OutputFile file(path);
  file.stream() << weights_file_text(weights);
  file.commit();
}

}  // namespace delta::nn
