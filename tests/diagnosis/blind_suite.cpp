// Blind suite generator and scorer: draws effects (and one effect outside the library), records
// them, runs `deltactl diagnose` as a black box and scores its JSON and predictions file.
#include "blind_suite.hpp"

#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <set>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "delta/csv.hpp"
#include "delta/kinematics.hpp"
#include "delta/recording.hpp"
#include "delta/trajectory.hpp"

namespace delta::blind {
namespace {

constexpr double kNoiseFloorDeg = 0.01 / 3.4641016151377544;  // 0.01 / sqrt(12)

class Draw {
 public:
  explicit Draw(std::uint64_t seed) : generator_(seed) {}
  double uniform(double low, double high) { return std::uniform_real_distribution<double>(low, high)(generator_); }
  // A magnitude in [low, high] with a random sign.
  double magnitude(double low, double high) { return (uniform(0.0, 1.0) < 0.5 ? -1.0 : 1.0) * uniform(low, high); }
  int integer(int count) { return std::uniform_int_distribution<int>(0, count - 1)(generator_); }
  // Per-joint values; one joint in four cases is left without the effect.
  Vec3 joints(double low, double high, bool signed_values = true) {
    Vec3 v;
    for (int j = 0; j < 3; ++j) v[j] = signed_values ? magnitude(low, high) : uniform(low, high);
    if (uniform(0.0, 1.0) < 0.25) v[integer(3)] = 0.0;
    return v;
  }

 private:
  std::mt19937_64 generator_;
};

// Realistic magnitudes for a 40/68 mm Delta built with ordinary tolerances.
void inject_family(EffectSet& effects, int family, Draw& draw) {
  switch (family) {
    case 0:
      effects.joint_offset_deg = draw.joints(0.05, 1.0);
      break;
    case 1:
      effects.upper_arm_length_m = draw.joints(0.05e-3, 0.5e-3);
      break;
    case 2:
      effects.lower_arm_length_m = draw.joints(0.05e-3, 0.5e-3);
      break;
    case 3:
      effects.radius_offset_m = draw.joints(0.05e-3, 0.5e-3);
      break;
    case 4:
      effects.chain_angle_deg = draw.joints(0.05, 0.5);
      break;
    case 5: {
      FrameMisalignment frame;
      for (int k = 0; k < 3; ++k) {
        frame.rotation_deg[k] = draw.magnitude(0.05, 0.5);
        frame.translation_m[k] = draw.magnitude(0.05e-3, 0.5e-3);
      }
      effects.frame_misalignment = frame;
      break;
    }
    case 6:
      effects.backlash_deg = draw.joints(0.02, 0.3, false);
      break;
    case 7: {
      TransmissionError transmission;
      transmission.amplitude_deg = draw.joints(0.01, 0.05, false);
      for (int j = 0; j < 3; ++j) {
        transmission.period_deg[j] = draw.uniform(3.0, 30.0);
        transmission.phase_rad[j] = draw.uniform(0.0, 2.0 * kPi);
      }
      effects.transmission_error = transmission;
      break;
    }
    case 8:
      effects.encoder_scale = draw.joints(0.001, 0.01);
      break;
    default:
      break;
  }
}

// An effect of family `family` with every magnitude times `size` (0.15: small effects near the
// detection limit, 0.2 floor RMS of held-out signal).
void inject(EffectSet& effects, int family, Draw& draw, double size = 1.0) {
  inject_family(effects, family, draw);
  if (size == 1.0) return;
  auto scale = [size](std::optional<Vec3>& v) {
    if (v) *v *= size;
  };
  scale(effects.joint_offset_deg);
  scale(effects.upper_arm_length_m);
  scale(effects.lower_arm_length_m);
  scale(effects.radius_offset_m);
  scale(effects.chain_angle_deg);
  scale(effects.backlash_deg);
  scale(effects.encoder_scale);
  if (effects.frame_misalignment) {
    effects.frame_misalignment->rotation_deg *= size;
    effects.frame_misalignment->translation_m *= size;
  }
  if (effects.transmission_error) effects.transmission_error->amplitude_deg *= size;
}

// Extended kinds (cases from kExtendedFirst on), cycling every 10.
void make_extended_case(BlindCase& blind_case, Draw& draw) {
  const int slot = (blind_case.id - kExtendedFirst) % 10;
  // Pairs whose effects trade against another family on a 10 mm cube.
  static const int trading[4][2] = {{4, 3}, {4, 0}, {5, 3}, {8, 0}};
  if (slot < 2) {
    blind_case.kind = CaseKind::trading;
    const int* pair = trading[((blind_case.id - kExtendedFirst) / 10 * 2 + slot) % 4];
    inject(blind_case.effects, pair[0], draw);
    inject(blind_case.effects, pair[1], draw);
  } else if (slot < 4) {
    blind_case.kind = CaseKind::triple;
    int chosen[3];
    for (int k = 0; k < 3; ++k) {
      bool repeated = true;
      while (repeated) {
        chosen[k] = draw.integer(9);
        repeated = false;
        for (int m = 0; m < k; ++m) repeated |= chosen[m] == chosen[k];
      }
      inject(blind_case.effects, chosen[k], draw);
    }
  } else if (slot < 6) {
    blind_case.kind = CaseKind::small;
    inject(blind_case.effects, draw.integer(9), draw, 0.15);
  } else if (slot < 8) {
    blind_case.kind = CaseKind::outliers;
    blind_case.glitches = 6;
    if (slot == 7) {  // history-dependent effects across a gap in time
      blind_case.gap_rows = 400;
      inject(blind_case.effects, 6, draw);
      inject(blind_case.effects, 0, draw);
    }
  } else {
    blind_case.kind = CaseKind::stage_scale;
    blind_case.stage_scale = draw.magnitude(0.003, 0.01);
    // Slot 8: every axis (a new effect, measuring_scale, must be named); slot 9: x or y alone
    // (explained false, or measuring_scale per axis reaching the floor).
    blind_case.stage_axis = slot == 8 ? -1 : (blind_case.id / 10) % 2;
  }
}

Trajectory trajectory_named(const std::string& name) {
  if (name.rfind("sweep:", 0) == 0) return make_trajectory("sweep", std::stoull(name.substr(6)));
  return make_trajectory(name);
}

// Rotation of the plate from a rotation vector (radians).
Eigen::Matrix3d rotation_of(const Vec3& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
}

// Squared-length mismatch of the six rods for angles alpha (deg) and plate rotation vector w (rad).
Eigen::Matrix<double, 6, 1> rod_constraints(const Eigen::Matrix<double, 6, 1>& unknowns, const Vec3& position,
                                            const std::array<double, 6>& rod_length) {
  const Geometry geometry = Geometry::nominal();
  const Eigen::Matrix3d plate = rotation_of(unknowns.tail<3>());
  Eigen::Matrix<double, 6, 1> mismatch;
  for (int j = 0; j < 3; ++j) {
    const ChainGeometry& chain = geometry.chains[j];
    const double phi = chain.angle_deg * kRadPerDeg, alpha = unknowns[j] * kRadPerDeg;
    const Vec3 radial(std::cos(phi), std::sin(phi), 0.0), tangent(-std::sin(phi), std::cos(phi), 0.0);
    const double base_radius = 0.040, plate_radius = base_radius - chain.radius_offset_m;
    const Vec3 elbow = (base_radius + chain.upper_arm_m * std::cos(alpha)) * radial -
                       chain.upper_arm_m * std::sin(alpha) * Vec3::UnitZ();
    for (int side = 0; side < 2; ++side) {
      const double offset = side ? -kRodHalfSpacingM : kRodHalfSpacingM;
      const Vec3 upper_end = elbow + offset * tangent;
      const Vec3 lower_end = position + plate * (plate_radius * radial + offset * tangent);
      const double length = rod_length[2 * j + side];
      mismatch[2 * j + side] = ((upper_end - lower_end).squaredNorm() - length * length) / (2.0 * length);
    }
  }
  return mismatch;
}

}  // namespace

const char* kind_name(CaseKind kind) {
  switch (kind) {
    case CaseKind::none:
      return "none";
    case CaseKind::single:
      return "single";
    case CaseKind::pair:
      return "pair";
    case CaseKind::outside:
      return "outside";
    case CaseKind::trading:
      return "trading";
    case CaseKind::triple:
      return "triple";
    case CaseKind::small:
      return "small";
    case CaseKind::outliers:
      return "outliers";
    case CaseKind::stage_scale:
      return "stage_scale";
  }
  return "?";
}

BlindCase make_case(int id, bool quick) {
  BlindCase blind_case;
  blind_case.id = id;
  Draw draw(0x9E3779B97F4A7C15ULL ^ (static_cast<std::uint64_t>(id) * 7919ULL + 13ULL));
  // Kinds cycle every 20 cases: 2 none, 9 single (one per family), 8 pairs, 1 outside the library.
  const int slot = id % 20;
  if (id >= kExtendedFirst) {
    make_extended_case(blind_case, draw);
  } else if (slot == 0 || slot == 18) {
    blind_case.kind = CaseKind::none;
  } else if (slot <= 9) {
    blind_case.kind = CaseKind::single;
    inject(blind_case.effects, slot - 1, draw);
  } else if (slot == 17) {
    blind_case.kind = CaseKind::outside;
    blind_case.unequal_rods_m = draw.uniform(0.4e-3, 0.8e-3);
    blind_case.unequal_chain = draw.integer(3);
  } else {
    blind_case.kind = CaseKind::pair;
    const int first = draw.integer(9);
    int second = draw.integer(8);
    if (second >= first) ++second;
    inject(blind_case.effects, first, draw);
    inject(blind_case.effects, second, draw);
  }
  if (quick) {
    blind_case.fit_trajectory = "sweep:" + std::to_string(1000 + id);
    blind_case.fit_samples = 4000;
    blind_case.check_samples = 2000;
  } else if (id % 3 == 2) {
    blind_case.fit_trajectory = "sweep:" + std::to_string(1000 + id);
    blind_case.fit_samples = 8000;
    blind_case.check_samples = 6000;
  } else {
    blind_case.fit_trajectory = "validation";
    blind_case.fit_samples = 13333;
    blind_case.check_samples = 6000;
  }
  blind_case.check_seed = 2000 + id;
  for (const std::string& name : blind_case.effects.names()) {
    blind_case.description += (blind_case.description.empty() ? "" : " + ") + name;
  }
  if (blind_case.kind == CaseKind::outside) {
    blind_case.description = "unequal rods in chain " + std::to_string(blind_case.unequal_chain + 1) + " (" +
                             std::to_string(blind_case.unequal_rods_m * 1e3).substr(0, 5) + " mm)";
  }
  if (blind_case.kind == CaseKind::stage_scale) {
    const char* axes[4] = {"all-axes", "x", "y", "z"};
    blind_case.description = std::string("stage ") + axes[blind_case.stage_axis + 1] + " scale " +
                             std::to_string(blind_case.stage_scale * 100.0).substr(0, 5) + " %";
  }
  if (blind_case.description.empty()) blind_case.description = "none";
  if (blind_case.glitches) blind_case.description += " + " + std::to_string(blind_case.glitches) + " glitches";
  if (blind_case.gap_rows) blind_case.description += " + gap";
  return blind_case;
}

std::vector<Sample> record_unequal_rods(const std::string& trajectory_name, std::uint64_t, std::size_t samples,
                                        double difference_m, int chain) {
  const Trajectory trajectory = trajectory_named(trajectory_name);
  const Geometry nominal = Geometry::nominal();
  std::array<double, 6> rod_length;
  for (int j = 0; j < 3; ++j) {
    const double half = j == chain ? 0.5 * difference_m : 0.0;
    rod_length[2 * j] = nominal.chains[j].lower_arm_m + half;
    rod_length[2 * j + 1] = nominal.chains[j].lower_arm_m - half;
  }
  std::vector<Sample> rows;
  Eigen::Matrix<double, 6, 1> unknowns = Eigen::Matrix<double, 6, 1>::Zero();
  for (std::size_t i = 0; i < samples; ++i) {
    const double t = static_cast<double>(i) / trajectory.rate_hz;
    const Vec3 position = trajectory.position_m(t);
    if (i == 0) unknowns.head<3>() = inverse_kinematics(nominal, position).alpha_deg;
    for (int iteration = 0; iteration < 30; ++iteration) {  // Newton, numerical Jacobian
      const Eigen::Matrix<double, 6, 1> mismatch = rod_constraints(unknowns, position, rod_length);
      if (mismatch.norm() < 1e-15) break;
      Eigen::Matrix<double, 6, 6> jacobian;
      for (int k = 0; k < 6; ++k) {
        Eigen::Matrix<double, 6, 1> nudged = unknowns;
        const double step = k < 3 ? 1e-6 : 1e-8;
        nudged[k] += step;
        jacobian.col(k) = (rod_constraints(nudged, position, rod_length) - mismatch) / step;
      }
      unknowns -= jacobian.partialPivLu().solve(mismatch);
    }
    Sample sample;
    sample.t_s = t;
    for (int j = 0; j < 3; ++j) {
      sample.alpha_deg[j] = quantise(unknowns[j], kEncoderResolutionDeg);
      sample.position_m[j] = quantise(position[j], kStageResolutionM);
    }
    rows.push_back(sample);
  }
  return rows;
}

CaseRecordings record_case(const BlindCase& blind_case) {
  CaseRecordings recordings;
  const std::string check_name = "sweep:" + std::to_string(blind_case.check_seed);
  if (blind_case.kind == CaseKind::outside) {
    recordings.fit = record_unequal_rods(blind_case.fit_trajectory, 0, blind_case.fit_samples,
                                         blind_case.unequal_rods_m, blind_case.unequal_chain);
    recordings.check = record_unequal_rods(check_name, 0, blind_case.check_samples, blind_case.unequal_rods_m,
                                           blind_case.unequal_chain);
    return recordings;
  }
  const VirtualRobot robot(blind_case.effects);
  RecordingOptions options;
  options.samples = blind_case.fit_samples;
  recordings.fit = robot.record(trajectory_named(blind_case.fit_trajectory), options).samples;
  options.samples = blind_case.check_samples;
  recordings.check = robot.record(trajectory_named(check_name), options).samples;
  if (blind_case.stage_scale != 0.0) {
    for (std::vector<Sample>* rows : {&recordings.fit, &recordings.check}) {
      for (Sample& sample : *rows) {
        for (int axis = 0; axis < 3; ++axis) {
          if (blind_case.stage_axis >= 0 && axis != blind_case.stage_axis) continue;
          sample.position_m[axis] =
              quantise((1.0 + blind_case.stage_scale) * sample.position_m[axis], kStageResolutionM);
        }
      }
    }
  }
  if (blind_case.gap_rows) {
    const auto from = recordings.fit.begin() + static_cast<std::ptrdiff_t>(recordings.fit.size() / 3);
    recordings.fit.erase(from, from + static_cast<std::ptrdiff_t>(blind_case.gap_rows));
  }
  Draw draw(0xC0FFEEULL + static_cast<std::uint64_t>(blind_case.id));
  for (std::size_t g = 0; g < blind_case.glitches; ++g) {
    // Spread over the recording, away from its ends; a random direction and size.
    const std::size_t row = (g + 1) * recordings.fit.size() / (blind_case.glitches + 1) + draw.integer(100);
    Vec3 direction(draw.uniform(-1, 1), draw.uniform(-1, 1), draw.uniform(-1, 1));
    direction.normalize();
    Vec3& position = recordings.fit[row].position_m;
    position += draw.uniform(0.05e-3, 0.5e-3) * direction;
    for (int k = 0; k < 3; ++k) position[k] = quantise(position[k], kStageResolutionM);
    recordings.glitch_rows.push_back(row + 1);
  }
  return recordings;
}

CaseScore run_case(const BlindCase& blind_case, const std::string& deltactl, const std::string& folder) {
  namespace fs = std::filesystem;
  CaseScore score;
  score.blind_case = blind_case;
  const fs::path directory = fs::path(folder) / ("case_" + std::to_string(blind_case.id));
  fs::create_directories(directory);
  const CaseRecordings recordings = record_case(blind_case);
  const std::string fit = (directory / "fit.csv").string(), check = (directory / "check.csv").string();
  const std::string json_path = (directory / "diagnosis.json").string();
  const std::string predictions_path = (directory / "pred.csv").string();
  write_recording(fit, recordings.fit, {"blind suite case " + std::to_string(blind_case.id)});
  write_recording(check, recordings.check, {"blind suite case " + std::to_string(blind_case.id)});
  const std::string command = deltactl + " diagnose --data " + fit + " --holdout " + check + " --json " + json_path +
                              " --predictions " + predictions_path + " >" + (directory / "stdout.txt").string() +
                              " 2>" + (directory / "stderr.txt").string();
  const auto started = std::chrono::steady_clock::now();
  const int status = std::system(command.c_str());
  score.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    score.error = "deltactl diagnose failed, see " + (directory / "stderr.txt").string();
    return score;
  }
  nlohmann::json document;
  std::ifstream(json_path) >> document;
  score.explained = document.at("explained").get<bool>();
  std::set<std::string> reported;
  std::optional<double> stage_scale_found;  // a measuring_scale's value on the injected axis
  for (const auto& effect : document.at("effects")) {
    if (!effect.at("significant").get<bool>()) continue;
    reported.insert(effect.at("name").get<std::string>());
    if (effect.at("name") == "measuring_scale") {
      const nlohmann::json& parameters = effect.at("parameters");
      const std::string axis = blind_case.stage_axis < 0 ? "s" : std::string("s_") + "xyz"[blind_case.stage_axis];
      if (parameters.contains(axis)) {
        stage_scale_found = parameters.at(axis).get<double>();
      } else if (parameters.contains("s")) {
        stage_scale_found = parameters.at("s").get<double>();
      } else if (parameters.contains("s_x")) {  // per axis for an all-axes scale: their mean
        stage_scale_found = (parameters.at("s_x").get<double>() + parameters.at("s_y").get<double>() +
                             parameters.at("s_z").get<double>()) /
                            3.0;
      }
    }
  }
  score.reported.assign(reported.begin(), reported.end());
  std::vector<std::set<std::string>> alternatives;
  for (const auto& alternative : document.value("alternatives", nlohmann::json::array())) {
    const std::vector<std::string> names = alternative.at("effects").get<std::vector<std::string>>();
    score.alternatives.push_back(names);
    alternatives.emplace_back(names.begin(), names.end());
  }
  std::set<std::size_t> listed;
  for (const auto& outlier : document.value("outliers", nlohmann::json::array())) {
    if (outlier.at("recording") == "FIT") listed.insert(outlier.at("row").get<std::size_t>());
  }
  for (std::size_t row : recordings.glitch_rows) score.glitches_found += listed.count(row);
  // Held-out error of the predictions file, computed here rather than taken from the JSON.
  const CsvTable predictions = read_csv(predictions_path, {"t_s", "alpha1_deg", "alpha2_deg", "alpha3_deg"});
  if (predictions.rows.size() != recordings.check.size()) {
    score.error = "predictions file has " + std::to_string(predictions.rows.size()) + " rows for " +
                  std::to_string(recordings.check.size()) + " CHECK rows";
    return score;
  }
  Vec3 sum = Vec3::Zero();
  for (std::size_t i = 0; i < predictions.rows.size(); ++i) {
    for (int j = 0; j < 3; ++j) {
      const double residual = recordings.check[i].alpha_deg[j] - predictions.rows[i][1 + j];
      sum[j] += residual * residual;
    }
  }
  score.rmse_after_over_floor =
      (sum / static_cast<double>(predictions.rows.size())).cwiseSqrt().maxCoeff() / kNoiseFloorDeg;
  const std::vector<std::string> injected_names = blind_case.effects.names();
  const std::set<std::string> injected(injected_names.begin(), injected_names.end());
  if (blind_case.kind == CaseKind::outside || blind_case.kind == CaseKind::stage_scale) {
    // Pass: explained false, or an effect named outside the vocabulary that reaches the floor.
    bool new_name = false;
    for (const std::string& name : score.reported) {
      const auto& vocabulary = effect_vocabulary();
      if (std::find(vocabulary.begin(), vocabulary.end(), name) == vocabulary.end()) new_name = true;
    }
    score.set_ok = !score.explained || (new_name && score.rmse_after_over_floor <= 1.5);
    // A stage scale named must be the injected one (within 5 % of its value).
    if (blind_case.kind == CaseKind::stage_scale && stage_scale_found) {
      score.set_ok = score.set_ok &&
                     std::abs(*stage_scale_found - blind_case.stage_scale) <= 0.05 * std::abs(blind_case.stage_scale);
    }
    score.rmse_ok = true;
  } else {
    score.via_alternative =
        reported != injected && std::find(alternatives.begin(), alternatives.end(), injected) != alternatives.end();
    score.set_ok =
        (reported == injected || score.via_alternative) && score.glitches_found == recordings.glitch_rows.size();
    score.rmse_ok = score.rmse_after_over_floor <= 1.5;
  }
  return score;
}

}  // namespace delta::blind
