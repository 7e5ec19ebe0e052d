// Training of a complete model (network or hybrid) from a recording, with provenance.
#include "delta/nn/model_training.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <Eigen/Cholesky>

#include "delta/effect_file.hpp"
#include "delta/input_error.hpp"
#include "delta/model_error.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/output_file.hpp"

namespace delta::nn {
namespace {

// Where a recording leaves gaps in its bounding box (the paper's validation run never visits the
// corner x = +5 mm at its top z, for example), a network trained on it alone extrapolates freely,
// tens of millidegrees off. The deployed network also learns, at a grid of poses farther than
// kAnchorGap (share of each axis' range) from every recorded pose, the identified math model
// without backlash plus what that model leaves on the recording, per joint as a function of the
// joint's angle (kResidualBinDeg bins: transmission ripple and scale errors are of this kind).
constexpr int kAnchorGrid = 10;         // poses per axis, over the box grown by kAnchorMargin
constexpr double kAnchorMargin = 0.03;  // share of each axis' range added on both sides
constexpr double kAnchorGap = 0.06;     // share of each axis' range
constexpr double kResidualBinDeg = 0.25;

struct JointResidual {
  double first_deg = 0.0;
  std::vector<double> mean_deg;  // per bin of kResidualBinDeg from first_deg, empty bins filled from neighbours
  double at(double alpha_deg) const {
    const double position = (alpha_deg - first_deg) / kResidualBinDeg - 0.5;
    const double clamped = std::clamp(position, 0.0, static_cast<double>(mean_deg.size() - 1));
    const std::size_t low = static_cast<std::size_t>(clamped);
    const std::size_t high = std::min(low + 1, mean_deg.size() - 1);
    const double weight = clamped - static_cast<double>(low);
    return (1.0 - weight) * mean_deg[low] + weight * mean_deg[high];
  }
};

JointResidual joint_residual(const std::vector<double>& model_deg, const std::vector<double>& residual_deg) {
  JointResidual map;
  const auto [low, high] = std::minmax_element(model_deg.begin(), model_deg.end());
  map.first_deg = *low;
  const std::size_t bins = static_cast<std::size_t>((*high - *low) / kResidualBinDeg) + 1;
  std::vector<double> sum(bins, 0.0), count(bins, 0.0);
  for (std::size_t i = 0; i < model_deg.size(); ++i) {
    const std::size_t bin =
        std::min(bins - 1, static_cast<std::size_t>((model_deg[i] - map.first_deg) / kResidualBinDeg));
    sum[bin] += residual_deg[i];
    count[bin] += 1.0;
  }
  map.mean_deg.assign(bins, 0.0);
  double last = 0.0;
  bool seen = false;
  for (std::size_t b = 0; b < bins; ++b) {
    if (count[b] > 0.0) {
      last = sum[b] / count[b];
      if (!seen) std::fill(map.mean_deg.begin(), map.mean_deg.begin() + static_cast<std::ptrdiff_t>(b), last);
      seen = true;
    }
    map.mean_deg[b] = last;
  }
  return map;
}

using JointResiduals = std::array<JointResidual, 3>;

// What the math model (angles model_deg) leaves of targets_deg, per joint as a function of its angle.
JointResiduals joint_residuals(const std::vector<Vec3>& model_deg, const std::vector<Vec3>& targets_deg) {
  JointResiduals maps;
  for (int j = 0; j < 3; ++j) {
    std::vector<double> model(model_deg.size()), residual(model_deg.size());
    for (std::size_t i = 0; i < model_deg.size(); ++i) {
      model[i] = model_deg[i][j];
      residual[i] = targets_deg[i][j] - model_deg[i][j];
    }
    maps[j] = joint_residual(model, residual);
  }
  return maps;
}

Vec3 with_residuals(const JointResiduals& maps, const Vec3& model_deg) {
  Vec3 angles = model_deg;
  for (int j = 0; j < 3; ++j) angles[j] += maps[j].at(model_deg[j]);
  return angles;
}

// The identified play's share of each recorded angle, in time order: play(s) - s for the static
// angle s the identified model predicts.
std::vector<Vec3> play_lag(const Vec3& half_play_deg, const std::vector<Vec3>& static_deg) {
  BacklashCompensation play(half_play_deg);
  std::vector<Vec3> lag(static_deg.size());
  for (std::size_t i = 0; i < static_deg.size(); ++i) lag[i] = play.update(static_deg[i]) - static_deg[i];
  return lag;
}

// Appends the anchor poses (see above) and their targets: `target` of the math model `effects`.
void add_anchors(const EffectSet& effects, const std::function<Vec3(const Vec3&)>& target, std::vector<Vec3>& inputs,
                 std::vector<Vec3>& targets) {
  const std::size_t recorded = inputs.size();
  Vec3 low = inputs[0], high = inputs[0];
  for (const Vec3& p : inputs) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  const Vec3 range = (high - low).cwiseMax(Vec3::Constant(1e-9));
  for (int a = 0; a < kAnchorGrid; ++a) {
    for (int b = 0; b < kAnchorGrid; ++b) {
      for (int c = 0; c < kAnchorGrid; ++c) {
        const Vec3 share =
            Vec3(a, b, c) / (kAnchorGrid - 1.0) * (1.0 + 2.0 * kAnchorMargin) - Vec3::Constant(kAnchorMargin);
        const Vec3 pose = low + share.cwiseProduct(range);
        double nearest = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < recorded && nearest > kAnchorGap * kAnchorGap; ++i) {
          nearest = std::min(nearest, (inputs[i] - pose).cwiseQuotient(range).squaredNorm());
        }
        if (nearest <= kAnchorGap * kAnchorGap) continue;
        const IkSolution model = math_model_angles(effects, pose);
        if (!model.ok()) continue;
        inputs.push_back(pose);
        targets.push_back(target(model.alpha_deg));
      }
    }
  }
}

// A recording of a slow path at 10 Hz repeats nearly the same pose from one sample to the next:
// the deployed network learns from every stride-th recorded sample (about kThinnedSamples of
// them: 13333 -> every third), which keeps its training under its time budget (under 20 s with the
// identification for 13333 samples) at no measurable cost in held-out accuracy. Anchors stay.
constexpr std::size_t kThinnedSamples = 4000;

void thin_recording(std::size_t recorded, std::vector<Vec3>& inputs, std::vector<Vec3>& targets) {
  const std::size_t stride = std::max<std::size_t>(1, recorded / kThinnedSamples);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (i < recorded && i % stride != 0) continue;
    inputs[kept] = inputs[i];
    targets[kept] = targets[i];
    ++kept;
  }
  inputs.resize(kept);
  targets.resize(kept);
}

// The encoder floor of a recording: the step q of the grid the readings of every joint lie on (the
// encoder's quantisation, 0.01 deg on the paper's robot: the smallest gap between distinct
// readings, every reading a whole number of steps from the first), over sqrt(12); 0 when the
// readings are not on a grid (unquantised data: no floor to compare with).
double quantisation_floor_deg(const Recording& recording) {
  double step = 0.0;
  for (int j = 0; j < 3; ++j) {
    std::vector<double> values;
    values.reserve(recording.samples.size());
    for (const Sample& sample : recording.samples) values.push_back(sample.alpha_deg[j]);
    std::sort(values.begin(), values.end());
    values.erase(std::unique(values.begin(), values.end()), values.end());
    double smallest = 0.0;
    for (std::size_t i = 1; i < values.size(); ++i) {
      const double gap = values[i] - values[i - 1];
      if (gap > 1e-9 && (smallest == 0.0 || gap < smallest)) smallest = gap;
    }
    if (smallest == 0.0) return 0.0;
    for (double value : values) {
      const double steps = (value - values.front()) / smallest;
      if (std::abs(steps - std::round(steps)) > 1e-3) return 0.0;  // not on a grid
    }
    step = std::max(step, smallest);
  }
  return step / std::sqrt(12.0);
}

// The zero crossings (degrees of joint angle) of a binned residual with a line removed: a crossing
// counts once the residual has gone beyond +-hysteresis_deg on the other side, at the sign change
// (interpolated) nearest to where it did.
std::vector<double> zero_crossings(double first_deg, const std::vector<double>& detrended, double hysteresis_deg) {
  std::vector<double> crossings;
  int side = 0;  // sign of the last bin beyond the hysteresis
  std::size_t last_beyond = 0;
  for (std::size_t b = 0; b < detrended.size(); ++b) {
    if (std::abs(detrended[b]) <= hysteresis_deg) continue;
    const int sign = detrended[b] > 0.0 ? 1 : -1;
    if (side != 0 && sign != side) {
      std::size_t at = last_beyond;
      for (std::size_t k = last_beyond; k < b; ++k) {
        if ((detrended[k] > 0.0) != (detrended[k + 1] > 0.0)) at = k;
      }
      const double low = detrended[at], high = detrended[at + 1];
      const double share = high != low ? low / (low - high) : 0.5;
      crossings.push_back(first_deg + (static_cast<double>(at) + 0.5 + share) * kResidualBinDeg);
    }
    side = sign;
    last_beyond = b;
  }
  return crossings;
}

// A map's bins less their least-squares straight line (offset + slope * angle).
struct Detrended {
  std::vector<double> values;
  double offset = 0.0;
  double slope = 0.0;
};

Detrended detrended_bins(const JointResidual& map) {
  const std::size_t bins = map.mean_deg.size();
  auto centre = [&](std::size_t b) { return map.first_deg + (static_cast<double>(b) + 0.5) * kResidualBinDeg; };
  double sc = 0.0, sv = 0.0, scc = 0.0, scv = 0.0;
  for (std::size_t b = 0; b < bins; ++b) {
    sc += centre(b);
    sv += map.mean_deg[b];
    scc += centre(b) * centre(b);
    scv += centre(b) * map.mean_deg[b];
  }
  const double count = static_cast<double>(bins);
  Detrended result;
  const double denominator = count * scc - sc * sc;
  result.slope = denominator > 0.0 ? (count * scv - sc * sv) / denominator : 0.0;
  result.offset = (sv - result.slope * sc) / count;
  result.values.resize(bins);
  for (std::size_t b = 0; b < bins; ++b) result.values[b] = map.mean_deg[b] - result.offset - result.slope * centre(b);
  return result;
}

ResidualRipple ripple_of(const JointResidual& map) {
  ResidualRipple ripple;
  if (map.mean_deg.size() < 4) return ripple;
  const std::vector<double> detrended = detrended_bins(map).values;
  double square = 0.0;
  for (double value : detrended) square += value * value;
  const double count = static_cast<double>(detrended.size());
  ripple.rms_deg = std::sqrt(square / count);
  const std::vector<double> crossings = zero_crossings(map.first_deg, detrended, 0.5 * ripple.rms_deg);
  ripple.crossings = static_cast<int>(crossings.size());
  if (crossings.size() >= 2) {
    ripple.period_deg = 2.0 * (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  }
  return ripple;
}

std::array<ResidualRipple, 3> ripples_of(const JointResiduals& maps) {
  return {ripple_of(maps[0]), ripple_of(maps[1]), ripple_of(maps[2])};
}

// The straight line plus sinusoid offset + slope angle + a cos(2 pi angle / period) + b sin(...)
// nearest (least squares) to a map's bins, its period searched around the one the zero crossings
// give; explained: the sinusoid's share of what the straight line alone leaves (sum of squares).
struct Sinusoid {
  double period_deg = 0.0;
  double offset = 0.0, slope = 0.0, a = 0.0, b = 0.0;
  double explained = 0.0;
  double at(double angle_deg) const {
    const double phase = 2.0 * M_PI * angle_deg / period_deg;
    return a * std::cos(phase) + b * std::sin(phase);
  }
};

constexpr int kPeriodSearchSteps = 400;  // periods from 0.6 to 1.6 times the crossings' estimate

Sinusoid fit_sinusoid(double first_deg, const std::vector<double>& values, double line_leaves,
                      double period_estimate_deg) {
  Sinusoid best;
  if (!(period_estimate_deg > 0.0) || !(line_leaves > 0.0)) return best;
  for (int step = 0; step <= kPeriodSearchSteps; ++step) {
    const double period = period_estimate_deg * (0.6 + step / static_cast<double>(kPeriodSearchSteps));
    Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
    Eigen::Vector4d right = Eigen::Vector4d::Zero();
    for (std::size_t k = 0; k < values.size(); ++k) {
      const double angle = first_deg + static_cast<double>(k) * kResidualBinDeg;
      const double phase = 2.0 * M_PI * angle / period;
      const Eigen::Vector4d row(1.0, angle, std::cos(phase), std::sin(phase));
      normal += row * row.transpose();
      right += row * values[k];
    }
    const Eigen::Vector4d c = normal.ldlt().solve(right);
    double left = 0.0;
    for (std::size_t k = 0; k < values.size(); ++k) {
      const double angle = first_deg + static_cast<double>(k) * kResidualBinDeg;
      const double phase = 2.0 * M_PI * angle / period;
      const double error = values[k] - c[0] - c[1] * angle - c[2] * std::cos(phase) - c[3] * std::sin(phase);
      left += error * error;
    }
    const double explained = 1.0 - left / line_leaves;
    if (c.allFinite() && explained > best.explained) best = {period, c[0], c[1], c[2], c[3], explained};
  }
  return best;
}

// The joint ripple table (weights_file.hpp) for static targets, with the straight line it leaves
// to the network: per joint, what the math model (angles model_deg) leaves as a function of the
// target angle itself (the angle the network answers with), in kResidualBinDeg bins. Where a
// sinusoid explains most of it (a transmission ripple repeats with the joint's angle), the table
// continues with that sinusoid for kRippleExtensionDeg beyond both ends of the recorded travel:
// the runs reach a little farther than any drag, and so do the anchors. Otherwise its end entries
// hold beyond.
struct RippleFit {
  JointRippleTable table;
  std::array<Detrended, 3> line;  // offset and slope per joint (values unused)
};

constexpr double kRippleExtensionDeg = 2.0;
constexpr double kSinusoidExplains = 0.5;

RippleFit ripple_table(const std::vector<Vec3>& model_deg, const std::vector<Vec3>& targets_deg) {
  RippleFit fit;
  JointRippleTable& table = fit.table;
  table.bin_deg = kResidualBinDeg;
  for (int j = 0; j < 3; ++j) {
    std::vector<double> angle(targets_deg.size()), residual(targets_deg.size());
    for (std::size_t i = 0; i < targets_deg.size(); ++i) {
      angle[i] = targets_deg[i][j];
      residual[i] = targets_deg[i][j] - model_deg[i][j];
    }
    const JointResidual map = joint_residual(angle, residual);
    Detrended detrended = detrended_bins(map);
    if (detrended.values.size() < 4) return {};  // a joint that hardly moves: nothing to tabulate
    const double first_deg = map.first_deg + 0.5 * kResidualBinDeg;
    double line_leaves = 0.0;
    for (double value : detrended.values) line_leaves += value * value;
    const Sinusoid sinusoid = fit_sinusoid(first_deg, map.mean_deg, line_leaves, ripple_of(map).period_deg);
    std::size_t extra = 0;
    if (sinusoid.explained >= kSinusoidExplains) {
      // The table continues with the sinusoid, so its straight line is the one fitted with it.
      extra = static_cast<std::size_t>(kRippleExtensionDeg / kResidualBinDeg);
      detrended.offset = sinusoid.offset;
      detrended.slope = sinusoid.slope;
      for (std::size_t k = 0; k < detrended.values.size(); ++k) {
        detrended.values[k] =
            map.mean_deg[k] - sinusoid.offset - sinusoid.slope * (first_deg + static_cast<double>(k) * kResidualBinDeg);
      }
    }
    std::vector<double>& values = table.values_deg[static_cast<std::size_t>(j)];
    table.first_deg[j] = first_deg - static_cast<double>(extra) * kResidualBinDeg;
    for (std::size_t b = 0; b < extra; ++b) values.push_back(sinusoid.at(table.first_deg[j] + b * kResidualBinDeg));
    values.insert(values.end(), detrended.values.begin(), detrended.values.end());
    const double last_deg = first_deg + static_cast<double>(detrended.values.size() - 1) * kResidualBinDeg;
    for (std::size_t b = 1; b <= extra; ++b) values.push_back(sinusoid.at(last_deg + b * kResidualBinDeg));
    // Within the bounds a weights file may carry: each entry within the slope bound of the next
    // (one backward pass makes every step so), then the size (a clamp keeps the steps).
    const double step_deg = kMaxJointRippleSlope * kResidualBinDeg;
    for (std::size_t k = values.size() - 1; k-- > 0;) {
      values[k] = std::clamp(values[k], values[k + 1] - step_deg, values[k + 1] + step_deg);
    }
    for (double& value : values) value = std::clamp(value, -kMaxJointRippleDeg, kMaxJointRippleDeg);
    detrended.values.clear();
    fit.line[static_cast<std::size_t>(j)] = std::move(detrended);
  }
  return fit;
}

// Anchor targets with a ripple table: the math model plus the line and the table at its angle.
Vec3 with_ripple(const RippleFit& fit, const Vec3& model_deg) {
  Vec3 angles = model_deg;
  for (int j = 0; j < 3; ++j) {
    const Detrended& line = fit.line[static_cast<std::size_t>(j)];
    angles[j] += line.offset + line.slope * model_deg[j] + fit.table.at(j, model_deg[j]);
  }
  return angles;
}

// What the network must answer so that the answer plus the table gives `target_deg`: n = t - r(n)
// (the table's slope is far below 1, so a few substitutions converge).
Vec3 network_target(const JointRippleTable& table, const Vec3& target_deg) {
  Vec3 answer = target_deg;
  for (int step = 0; step < 4; ++step) answer = target_deg - table.at(answer);
  return answer;
}

// A ripple worth a table: some joint's is at least this many encoder floors RMS (or, on readings
// not on a grid, this many degrees).
constexpr double kRippleTableFloors = 1.0;
constexpr double kRippleTableDegWithoutFloor = 0.003;

// What the network learns from: the recorded poses and angles as the model's preparation leaves
// them and, deployed, how many anchor poses end the rows and the static targets (the network's
// targets before the ripple table comes off them).
struct TrainingSet {
  std::vector<Vec3> inputs, targets;
  std::size_t anchors = 0;           // deployed: poses the recording does not visit (add_anchors)
  std::vector<Vec3> static_targets;  // deployed: the static angles (the network's targets less the ripple table)
};

// The network learns what the identified model, backlash included, leaves: a residual that
// depends on the pose alone. The weights file keeps the pose-wise effects (no backlash).
void prepare_hybrid(const Recording& recording, TrainingSet& set, ModelTraining& result) {
  result.effect_fit = fit_math_model_effects(recording.samples);
  const std::vector<Vec3> predicted = predict_recording(result.effect_fit->effects, recording.samples);
  for (std::size_t i = 0; i < set.inputs.size(); ++i) set.targets[i] -= predicted[i];
  result.weights.effects = result.effect_fit->effects;
  result.weights.effects.backlash_deg.reset();
}

// The recorded angles less the identified play, in time order. The play's input is the static
// angle: the math model's angles `model` plus what that model leaves per joint as a function of its
// angle (transmission ripple) once a first pass has removed the play; the ripple moves where the
// play switches, so the second pass removes it better.
void remove_identified_play(const Vec3& half_play, const std::vector<Vec3>& model, std::vector<Vec3>& targets) {
  std::vector<Vec3> first_pass = targets;
  const std::vector<Vec3> first_lag = play_lag(half_play, model);
  for (std::size_t i = 0; i < targets.size(); ++i) first_pass[i] -= first_lag[i];
  const JointResiduals first_maps = joint_residuals(model, first_pass);
  std::vector<Vec3> static_deg(targets.size());
  for (std::size_t i = 0; i < targets.size(); ++i) static_deg[i] = with_residuals(first_maps, model[i]);
  const std::vector<Vec3> lag = play_lag(half_play, static_deg);
  for (std::size_t i = 0; i < targets.size(); ++i) targets[i] -= lag[i];
}

// The network learns the recorded angles without the play identified in time order; the board
// puts the identified play back on its answers, in time order. Then a joint ripple table where
// the math model leaves a ripple worth one, the anchor poses, and the recording thinned.
void prepare_deployed(const Recording& recording, const TrainingOptions& options, TrainingSet& set,
                      ModelTraining& result) {
  std::vector<Vec3>& inputs = set.inputs;
  std::vector<Vec3>& targets = set.targets;
  result.effect_fit = fit_math_model_effects(recording.samples);
  EffectSet without_backlash = result.effect_fit->effects;
  without_backlash.backlash_deg.reset();
  const Vec3 half_play = 0.5 * *result.effect_fit->effects.backlash_deg;
  result.weights.backlash_half_play_deg = half_play;
  std::vector<Vec3> model(inputs.size());
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const IkSolution solution = math_model_angles(without_backlash, inputs[i]);
    if (!solution.ok()) throw std::invalid_argument("the math model cannot reach a recorded pose");
    model[i] = solution.alpha_deg;
  }
  remove_identified_play(half_play, model, targets);
  const JointResiduals maps = joint_residuals(model, targets);
  result.ripple = ripples_of(maps);
  RippleFit ripple;
  result.floor_deg = quantisation_floor_deg(recording);
  const double table_from_deg =
      result.floor_deg > 0.0 ? kRippleTableFloors * result.floor_deg : kRippleTableDegWithoutFloor;
  if (options.joint_ripple_table && std::any_of(result.ripple.begin(), result.ripple.end(),
                                                [&](const auto& r) { return r.rms_deg >= table_from_deg; })) {
    ripple = ripple_table(model, targets);
    result.weights.joint_ripple = ripple.table;
  }
  if (ripple.table.empty()) {
    add_anchors(
        without_backlash, [&](const Vec3& angles) { return with_residuals(maps, angles); }, inputs, targets);
  } else {
    add_anchors(
        without_backlash, [&](const Vec3& angles) { return with_ripple(ripple, angles); }, inputs, targets);
  }
  set.anchors = inputs.size() - recording.samples.size();
  thin_recording(recording.samples.size(), inputs, targets);
  set.static_targets = targets;
  if (!result.weights.joint_ripple.empty()) {
    for (Vec3& target : targets) target = network_target(result.weights.joint_ripple, target);
  }
}

// Deployed: a training that stalled above kStallFloors encoder floors is run once more from
// another seed, and the better of the two by validation error kept.
void restart_if_stalled(const TrainingSet& set, const TrainingOptions& options,
                        const std::function<void(const TrainingEpoch&)>& progress, ModelTraining& result) {
  if (result.training.validation_samples > 0 && result.floor_deg > 0.0 &&
      std::sqrt(result.training.validation_mse_deg2) > kStallFloors * result.floor_deg) {
    TrainingOptions restart = options;
    restart.seed = options.seed + kRestartSeedOffset;
    result.restart_seed = restart.seed;
    TrainingResult second = train_network(set.inputs, set.targets, restart, progress);
    result.restart_kept = second.validation_mse_deg2 < result.training.validation_mse_deg2;
    if (result.restart_kept) result.training = std::move(second);
  }
}

// Deployed: the model's error per joint on the recording's rows it learnt from. The thinned
// recording's rows come first, the anchors last (thin_recording). The model's answers: the network
// plus the joint ripple table when there is one.
Vec3 deployed_recording_rmse(const TrainingSet& set, const ModelTraining& result) {
  const std::vector<Vec3> learnt(set.static_targets.begin(),
                                 set.static_targets.end() - static_cast<std::ptrdiff_t>(set.anchors));
  std::vector<Vec3> answers(learnt.size());
  for (std::size_t i = 0; i < learnt.size(); ++i) {
    const Vec3 answer = result.training.network.evaluate(set.inputs[i]);
    answers[i] = answer + result.weights.joint_ripple.at(answer);
  }
  return joint_error_stats(learnt, answers).rmse_deg;
}

// The weights file's provenance: the data, the options, how the training went and, with a math
// model, what it was fitted to; deployed, the anchors, the ripple table and the restart.
void write_provenance(const Recording& recording, const TrainingOptions& options, std::size_t anchors,
                      ModelTraining& result) {
  const TrainingResult& training = result.training;
  nlohmann::json& provenance = result.weights.provenance;
  provenance["tool"] = "deltactl train";
  provenance["data"] = recording.path;
  provenance["samples"] = recording.samples.size();
  provenance["seed"] = options.seed;
  provenance["hidden"] = options.hidden;
  provenance["max_epochs"] = options.max_epochs;
  provenance["validation_fraction"] = options.validation_fraction;
  provenance["training_samples"] = training.training_samples;
  provenance["validation_samples"] = training.validation_samples;
  provenance["epochs"] = training.epochs;
  provenance["best_epoch"] = training.best_epoch;
  provenance["stop_reason"] = training.stop_reason;
  provenance["training_mse_deg2"] = training.training_mse_deg2;
  provenance["validation_mse_deg2"] = training.validation_mse_deg2;
  if (result.effect_fit) {
    const Vec3& before = result.effect_fit->rmse_before_deg;
    const Vec3& after = result.effect_fit->rmse_after_deg;
    provenance["math_model_rmse_nominal_deg"] = {before[0], before[1], before[2]};
    provenance["math_model_rmse_fitted_deg"] = {after[0], after[1], after[2]};
    const Vec3& backlash = *result.effect_fit->effects.backlash_deg;
    provenance["identified_backlash_deg"] = {backlash[0], backlash[1], backlash[2]};
  }
  if (result.weights.deployed()) {
    provenance["anchor_poses"] = anchors;
    provenance["encoder_floor_deg"] = result.floor_deg;
    if (!result.weights.joint_ripple.empty()) {
      provenance["joint_ripple_rule"] = "the math model leaves a joint at least " + format_number(kRippleTableFloors) +
                                        " encoder floor RMS (its straight line removed) as a function of its angle";
    }
    if (result.restart_seed) {
      provenance["restart"] = {{"seed", *result.restart_seed},
                               {"rule", "validation RMSE above " + format_number(kStallFloors) + " encoder floors"},
                               {"kept", result.restart_kept ? "restart" : "first"}};
    }
    provenance["anchor_rule"] = "grid " + std::to_string(kAnchorGrid) + "^3 over the recorded box grown by " +
                                format_number(kAnchorMargin) + " of each range, farther than " +
                                format_number(kAnchorGap) + " of each range from every recorded pose";
  }
}

}  // namespace

ModelTraining train_model(const Recording& recording, const std::string& model, const TrainingOptions& options,
                          const std::function<void(const TrainingEpoch&)>& progress) {
  if (model != "network" && model != "hybrid" && model != "deployed") {
    throw std::invalid_argument("unknown model '" + model + "' (choose deployed, network or hybrid)");
  }
  // The deployed model adds anchor poses: count the recording's own samples first.
  if (recording.samples.size() < kMinTrainingSamples) {
    throw InputError(recording.path, 0, "training needs at least " + std::to_string(kMinTrainingSamples) + " samples");
  }
  ModelTraining result;
  result.weights.model = model;
  TrainingSet set;
  for (const Sample& sample : recording.samples) {
    set.inputs.push_back(sample.position_m);
    set.targets.push_back(sample.alpha_deg);
  }
  // What the data cannot support (too few rows, an axis that does not vary, a pose the math
  // model cannot reach) is a fault of the recording: name it.
  try {
    if (model == "hybrid") {
      prepare_hybrid(recording, set, result);
    } else if (model == "deployed") {
      prepare_deployed(recording, options, set, result);
    }
    result.training = train_network(set.inputs, set.targets, options, progress);
    if (model == "deployed") {
      restart_if_stalled(set, options, progress, result);
      result.recording_rmse_deg = deployed_recording_rmse(set, result);
    }
  } catch (const std::invalid_argument& error) {
    throw InputError(recording.path, 0, error.what());
  }
  result.weights.network = result.training.network;
  write_provenance(recording, options, set.anchors, result);
  return result;
}

std::array<ResidualRipple, 3> residual_ripple(const std::vector<Vec3>& model_deg,
                                              const std::vector<Vec3>& targets_deg) {
  if (model_deg.empty() || model_deg.size() != targets_deg.size()) {
    throw std::invalid_argument("residual_ripple needs as many targets as model angles, at least one");
  }
  return ripples_of(joint_residuals(model_deg, targets_deg));
}

std::string describe_epoch(const TrainingEpoch& epoch) {
  char line[200];
  std::snprintf(line, sizeof line,
                "epoch %4d  mse %.4e deg^2 (rmse %.5f deg)  validation %.4e (rmse %.5f)  mu %.1e  |J'e| %.3e",
                epoch.epoch, epoch.training_mse_deg2, std::sqrt(epoch.training_mse_deg2), epoch.validation_mse_deg2,
                std::sqrt(epoch.validation_mse_deg2), epoch.mu, epoch.gradient_norm);
  return line;
}

}  // namespace delta::nn
