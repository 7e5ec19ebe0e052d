// Noise model (quantisation of encoders and stage, estimated extra noise) and the floor and paired
// tests on held-out residuals.
#include "floor_test.hpp"

#include <algorithm>
#include <cmath>

#include "attribution.hpp"
#include "delta/geometry.hpp"
#include "delta/kinematics.hpp"
#include "outliers.hpp"

namespace delta::diagnosis {
namespace {

struct MeanAndError {
  double mean = 0.0;
  double standard_error = 0.0;
  std::size_t blocks = 0;
  double autocorrelation_rows = 1.0;  // integrated autocorrelation time, rows
};

// Mean of a series and its standard error by batch means: neighbouring rows are correlated
// (a slowly moving quantised angle repeats its error), blocks of `batch_rows` rows much less so.
// Also the series' integrated autocorrelation time (1 + 2 sum of its autocorrelations up to the
// first below 0.05), reported as the effective number of rows (the blocks stay batch_rows long).
MeanAndError batch_mean(const std::vector<double>& series, std::size_t batch_rows) {
  MeanAndError result;
  if (series.empty()) return result;
  double total = 0.0;
  for (double value : series) total += value;
  result.mean = total / series.size();
  double variance = 0.0;
  for (double value : series) variance += (value - result.mean) * (value - result.mean);
  double tau = 1.0;
  if (variance > 0.0) {
    const std::size_t max_lag = std::min<std::size_t>(series.size() / 10, 2000);
    for (std::size_t lag = 1; lag <= max_lag; ++lag) {
      double c = 0.0;
      for (std::size_t i = lag; i < series.size(); ++i)
        c += (series[i] - result.mean) * (series[i - lag] - result.mean);
      const double rho = c / variance;
      if (rho < 0.05) break;
      tau += 2.0 * rho;
    }
  }
  result.autocorrelation_rows = tau;
  const std::size_t size = std::max<std::size_t>(batch_rows, 1);
  std::vector<double> means;
  for (std::size_t start = 0; start + size <= series.size(); start += size) {
    double sum = 0.0;
    for (std::size_t i = start; i < start + size; ++i) sum += series[i];
    means.push_back(sum / size);
  }
  if (means.size() < 2) {  // too short for blocks: rows taken as independent
    double square = 0.0;
    for (double value : series) square += (value - result.mean) * (value - result.mean);
    result.standard_error = std::sqrt(square / std::max<std::size_t>(series.size() - 1, 1) / series.size());
    result.blocks = series.size();
    return result;
  }
  double block_total = 0.0, square = 0.0;
  for (double m : means) block_total += m;
  const double block_mean = block_total / means.size();
  for (double m : means) square += (m - block_mean) * (m - block_mean);
  result.standard_error = std::sqrt(square / (means.size() - 1) / means.size());
  result.blocks = means.size();
  return result;
}

double z_of(const MeanAndError& value, double expected) {
  return value.standard_error > 0.0 ? (value.mean - expected) / value.standard_error : 0.0;
}

// Variance of the stage quantisation seen in each joint angle: sum over axes of
// (d alpha_j / d p_k)^2 * step^2 / 12, derivatives of the nominal kinematics (central, 1 um).
Vec3 stage_variance_deg2(const Vec3& position_m) {
  const Geometry nominal = Geometry::nominal();
  constexpr double kStep = 1e-6;
  Vec3 variance = Vec3::Zero();
  for (int axis = 0; axis < 3; ++axis) {
    Vec3 up = position_m, down = position_m;
    up[axis] += kStep;
    down[axis] -= kStep;
    const IkSolution a = inverse_kinematics(nominal, up), b = inverse_kinematics(nominal, down);
    if (!a.ok() || !b.ok()) continue;
    const Vec3 slope = (a.alpha_deg - b.alpha_deg) / (2.0 * kStep);  // deg per metre
    variance += slope.cwiseAbs2() * (kStageResolutionM * kStageResolutionM / 12.0);
  }
  return variance;
}

}  // namespace

NoiseModel noise_model(const std::vector<Sample>& fit, const std::vector<Vec3>& fit_prediction,
                       const std::vector<Sample>& check, double noise_floor_deg, bool fit_quantised) {
  NoiseModel noise;
  noise.encoder_variance_deg2 = noise_floor_deg * noise_floor_deg;
  const double step_deg = noise_floor_deg * std::sqrt(12.0);  // encoder resolution q

  // Extra noise from FIT: per pair of neighbouring rows, half of (d^2 - f (q - f) - stage), d the
  // difference of residuals; averaged over the joints.
  const double usual_s = usual_interval_s(fit);
  std::vector<double> excess;
  for (std::size_t i = 1; fit_quantised && i < fit.size(); ++i) {
    if (!regular_step(fit, i, usual_s)) continue;
    const Vec3 stage = stage_variance_deg2(fit[i].position_m);
    double sum = 0.0;
    for (int j = 0; j < 3; ++j) {
      const double d =
          (fit[i].alpha_deg[j] - fit_prediction[i][j]) - (fit[i - 1].alpha_deg[j] - fit_prediction[i - 1][j]);
      const double motion = std::abs(fit_prediction[i][j] - fit_prediction[i - 1][j]);
      const double f = std::fmod(motion, step_deg);
      sum += 0.5 * (d * d - f * (step_deg - f) - 2.0 * stage[j]);
    }
    excess.push_back(sum / 3.0);
  }
  const MeanAndError extra = batch_mean(excess, 100);
  noise.extra_noise_z = z_of(extra, 0.0);
  // Only a clearly present extra noise enters the model (an overestimate would hide effects).
  const double extra_variance = noise.extra_noise_z > 4.0 ? extra.mean : 0.0;
  noise.extra_noise_deg = std::sqrt(extra_variance);

  double stage_total = 0.0;
  noise.variance_deg2.reserve(check.size());
  for (const Sample& sample : check) {
    const Vec3 stage = stage_variance_deg2(sample.position_m);
    stage_total += stage.sum() / 3.0;
    noise.variance_deg2.push_back(stage + Vec3::Constant(noise.encoder_variance_deg2 + extra_variance));
  }
  noise.stage_sigma_deg = check.empty() ? 0.0 : std::sqrt(stage_total / check.size());
  return noise;
}

FloorTest floor_test(const std::vector<Sample>& check, const std::vector<Vec3>& prediction, const NoiseModel& noise,
                     const DiagnosisOptions& options) {
  FloorTest test;
  test.threshold = options.floor_z;
  test.stage_sigma_deg = noise.stage_sigma_deg;
  test.extra_noise_deg = noise.extra_noise_deg;
  test.extra_noise_z = noise.extra_noise_z;
  test.rows = check.size();
  Vec3 variance_sum = Vec3::Zero();
  std::vector<double> all(check.size());
  std::array<std::vector<double>, 3> joints;
  for (std::size_t i = 0; i < check.size(); ++i) {
    double row = 0.0;
    for (int j = 0; j < 3; ++j) {
      const double r = check[i].alpha_deg[j] - prediction[i][j];
      const double u = r * r / noise.variance_deg2[i][j] - 1.0;
      joints[j].push_back(u);
      row += u / 3.0;
    }
    variance_sum += noise.variance_deg2[i];
    all[i] = row;
  }
  test.sigma_deg = (variance_sum / static_cast<double>(std::max<std::size_t>(check.size(), 1))).cwiseSqrt();
  const MeanAndError total = batch_mean(all, options.batch_rows);
  test.ratio = 1.0 + total.mean;
  test.z = z_of(total, 0.0);
  test.blocks = total.blocks;
  test.effective_rows = static_cast<double>(check.size()) / total.autocorrelation_rows;
  for (int j = 0; j < 3; ++j) {
    const MeanAndError joint = batch_mean(joints[j], options.batch_rows);
    test.joint_ratio[j] = 1.0 + joint.mean;
    test.joint_z[j] = z_of(joint, 0.0);
  }
  // Either the three joints together or one joint alone (Bonferroni over four tests, one-sided);
  // and whatever the noise model says, no joint's held-out RMSE above rmse_cap floors (an extra
  // noise estimated from FIT, e.g. a controller's dither the stage does not resolve, must not make
  // a residual of several floors look like noise).
  Vec3 square = Vec3::Zero();
  for (std::size_t i = 0; i < check.size(); ++i) square += (check[i].alpha_deg - prediction[i]).cwiseAbs2();
  test.joint_rmse_floors =
      (square / static_cast<double>(std::max<std::size_t>(check.size(), 1))).cwiseSqrt() / options.noise_floor_deg;
  test.rmse_cap_floors = options.rmse_cap_floors;
  test.at_floor = test.z <= test.threshold && test.joint_z.maxCoeff() <= test.threshold + 0.5 &&
                  test.joint_rmse_floors.maxCoeff() <= options.rmse_cap_floors;
  return test;
}

PairedDifference paired_difference(const std::vector<Sample>& check, const std::vector<Vec3>& prediction_a,
                                   const std::vector<Vec3>& prediction_b, std::size_t batch_rows) {
  std::vector<double> difference(check.size());
  for (std::size_t i = 0; i < check.size(); ++i) {
    const Vec3 a = check[i].alpha_deg - prediction_a[i], b = check[i].alpha_deg - prediction_b[i];
    difference[i] = (a.squaredNorm() - b.squaredNorm()) / 3.0;
  }
  const MeanAndError value = batch_mean(difference, batch_rows);
  return {value.mean, z_of(value, 0.0)};
}

UnexplainedResidual locate_unexplained(const std::vector<Sample>& check, const std::vector<Vec3>& prediction,
                                       const NoiseModel& noise) {
  UnexplainedResidual where;
  if (check.empty()) return where;
  const Vec3 middle = middle_of(check);
  const double t0 = check.front().t_s, span = std::max(check.back().t_s - t0, 1e-9);
  Vec3 joint_excess = Vec3::Zero();
  std::array<double, 8> octant_excess{}, octant_rows{};
  std::array<double, 10> tenth_excess{}, tenth_rows{};
  for (std::size_t i = 0; i < check.size(); ++i) {
    const Vec3 excess = (check[i].alpha_deg - prediction[i]).cwiseAbs2() - noise.variance_deg2[i];
    joint_excess += excess;
    const int o = octant_of(check[i].position_m, middle);
    octant_excess[o] += excess.sum() / 3.0;
    ++octant_rows[o];
    const int tenth = std::min(9, static_cast<int>(10.0 * (check[i].t_s - t0) / span));
    tenth_excess[tenth] += excess.sum() / 3.0;
    ++tenth_rows[tenth];
  }
  joint_excess /= static_cast<double>(check.size());
  joint_excess.maxCoeff(&where.joint);
  where.excess_rms_deg = std::sqrt(std::max(joint_excess.mean(), 0.0));
  int best = 0;
  double best_value = -1e300;
  for (int o = 0; o < 8; ++o) {
    if (octant_rows[o] > 0 && octant_excess[o] / octant_rows[o] > best_value) {
      best_value = octant_excess[o] / octant_rows[o];
      best = o;
    }
  }
  where.region = octant_label(best);
  where.region_excess_rms_deg = std::sqrt(std::max(best_value, 0.0));
  best = 0;
  best_value = -1e300;
  for (int k = 0; k < 10; ++k) {
    if (tenth_rows[k] > 0 && tenth_excess[k] / tenth_rows[k] > best_value) {
      best_value = tenth_excess[k] / tenth_rows[k];
      best = k;
    }
  }
  where.t_from_s = t0 + span * best / 10.0;
  where.t_to_s = t0 + span * (best + 1) / 10.0;
  where.time_excess_rms_deg = std::sqrt(std::max(best_value, 0.0));
  return where;
}

}  // namespace delta::diagnosis
