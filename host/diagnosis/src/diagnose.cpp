// Forward selection on held-out error, backward elimination, location and identifiability.
#include "delta/diagnosis/diagnose.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <map>
#include <thread>

#include <Eigen/Eigenvalues>

namespace delta::diagnosis {
namespace {

double mean_square(const Vec3& rmse) { return rmse.squaredNorm() / 3.0; }

// Starting values of a family added to a fitted model, from the FIT residuals of that model.
// backlash: half the jump of the residual between falling and rising motion; transmission_error:
// a periodogram of the residual against the angle (quadratic trend removed), per joint.
// long_period: start transmission_error from the best long period fitted to the raw residual
// instead of the periodogram (only the restart after forward selection uses it: in the rounds a
// long-period ripple is flexible enough to stand in for geometry and mislead the greedy choice).
Parameters initial_guess(Family family, const Parameters& theta, const std::vector<Sample>& rows,
                         const std::vector<Vec3>& predicted, bool long_period = false) {
  Parameters start = theta;
  if (family == Family::backlash) {
    for (int j = 0; j < 3; ++j) {
      double rising = 0.0, falling = 0.0;
      std::size_t rising_count = 0, falling_count = 0;
      for (std::size_t i = 1; i < rows.size(); ++i) {
        const double motion = predicted[i][j] - predicted[i - 1][j];
        const double residual = rows[i].alpha_deg[j] - predicted[i][j];
        if (motion > 1e-6) {
          rising += residual;
          ++rising_count;
        } else if (motion < -1e-6) {
          falling += residual;
          ++falling_count;
        }
      }
      double width = 0.0;
      if (rising_count && falling_count) width = falling / falling_count - rising / rising_count;
      start[slot::backlash + j] = std::max(width, 0.0);
    }
  } else if (family == Family::transmission_error) {
    const std::size_t stride = std::max<std::size_t>(1, rows.size() / 3000);
    for (int j = 0; j < 3; ++j) {
      std::vector<double> angle, residual;
      double low = 1e9, high = -1e9;
      for (std::size_t i = 0; i < rows.size(); i += stride) {
        angle.push_back(predicted[i][j]);
        residual.push_back(rows[i].alpha_deg[j] - predicted[i][j]);
        low = std::min(low, predicted[i][j]);
        high = std::max(high, predicted[i][j]);
      }
      const double range = std::max(high - low, 1e-3);
      const double centre = 0.5 * (high + low);
      const int m = static_cast<int>(angle.size());
      const std::vector<double> raw = residual;
      // Remove a quadratic trend in the angle once (what offsets, scales and geometry leave).
      Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
      Eigen::Vector3d right = Eigen::Vector3d::Zero();
      for (int i = 0; i < m; ++i) {
        const double u = (angle[i] - centre) / range;
        const Eigen::Vector3d basis(1.0, u, u * u);
        normal += basis * basis.transpose();
        right += residual[i] * basis;
      }
      const Eigen::Vector3d trend = normal.ldlt().solve(right);
      for (int i = 0; i < m; ++i) {
        const double u = (angle[i] - centre) / range;
        residual[i] -= trend.dot(Eigen::Vector3d(1.0, u, u * u));
      }
      // Spatial frequencies from a quarter cycle over the range to periods of 0.1 deg, spaced a
      // quarter cycle over the range apart (neighbours differ in phase by at most 90 deg).
      double best_power = -1.0, best_period = 360.0, best_amplitude = 0.0, best_phase = 0.0;
      for (double cycles = 0.25; cycles <= range / 0.1; cycles += 0.25) {
        const double period = range / cycles;
        Eigen::Matrix2d sine_normal = Eigen::Matrix2d::Zero();
        Eigen::Vector2d sine_right = Eigen::Vector2d::Zero();
        for (int i = 0; i < m; ++i) {
          const double w = 2.0 * kPi * angle[i] / period;
          const Eigen::Vector2d basis(std::cos(w), std::sin(w));
          sine_normal += basis * basis.transpose();
          sine_right += residual[i] * basis;
        }
        const Eigen::Vector2d c = sine_normal.ldlt().solve(sine_right);
        const double power = c.dot(sine_right);  // residual sum of squares removed
        if (power > best_power) {
          best_power = power;
          best_period = period;
          best_amplitude = std::hypot(c[0], c[1]);
          best_phase = std::atan2(c[0], c[1]);  // A sin(w + phi) = A cos(phi) sin(w) + A sin(phi) cos(w)
        }
      }
      // Periods much longer than the range look like a trend and vanish with it: the long-period
      // start fits them to the residual as it is (a once-per-revolution ripple, P = 360 deg).
      auto raw_fit = [&](double period, double& amplitude, double& phase) {
        Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
        Eigen::Vector2d right = Eigen::Vector2d::Zero();
        double total = 0.0;
        for (int i = 0; i < m; ++i) {
          const double w = 2.0 * kPi * angle[i] / period;
          const Eigen::Vector2d basis(std::cos(w), std::sin(w));
          normal += basis * basis.transpose();
          right += raw[i] * basis;
          total += raw[i] * raw[i];
        }
        const Eigen::Vector2d c = normal.ldlt().solve(right);
        amplitude = std::hypot(c[0], c[1]);
        phase = std::atan2(c[0], c[1]);
        return total - c.dot(right);
      };
      double amplitude = 0.0, phase = 0.0;
      double best_sse = 1e300;
      for (double period : {2.0 * range, 4.0 * range, 8.0 * range, 90.0, 180.0, 360.0}) {
        if (!long_period) break;
        const double sse = raw_fit(period, amplitude, phase);
        if (sse < best_sse) {
          best_sse = sse;
          best_period = period;
          best_amplitude = amplitude;
          best_phase = phase;
        }
      }
      start[slot::amplitude + j] = best_amplitude;
      start[slot::period + j] = best_period;
      start[slot::phase + j] = best_phase;
    }
  }
  return start;
}

struct Candidate {
  FitResult fit;
  Vec3 holdout_rmse = Vec3::Zero();
  bool ok = false;
};

// Every `stride`-th row: candidate models are screened on this thinner FIT set unless they
// contain backlash, whose hysteresis needs every row in time order.
std::vector<Sample> thin_out(const std::vector<Sample>& rows, std::size_t stride) {
  std::vector<Sample> thinned;
  for (std::size_t i = 0; i < rows.size(); i += stride) thinned.push_back(rows[i]);
  return thinned;
}

Candidate fit_and_check(const std::vector<Sample>& fit, const std::vector<Sample>& thinned_fit,
                        const std::vector<Sample>& check, FamilySet families, const Parameters& start,
                        const DiagnosisOptions& options) {
  Candidate candidate;
  FitOptions fit_options;
  fit_options.noise_floor_deg = options.noise_floor_deg;
  const bool hysteresis = families[index_of(Family::backlash)];
  candidate.fit = fit_model(hysteresis ? fit : thinned_fit, families, start, start, fit_options);
  if (!candidate.fit.ok) return candidate;
  const Prediction prediction = predict_recording(to_effect_set(candidate.fit.theta, families), check);
  candidate.holdout_rmse = joint_rmse(check, prediction.alpha_deg);
  candidate.ok = prediction.unreachable == 0 && candidate.holdout_rmse.allFinite();
  return candidate;
}

// Runs jobs on up to `threads` threads; results in job order.
template <typename Job>
std::vector<Candidate> run_parallel(const std::vector<Job>& jobs, int threads) {
  std::vector<Candidate> results(jobs.size());
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t k = next++; k < jobs.size(); k = next++) results[k] = jobs[k]();
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::max(1, threads); ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& thread : pool) thread.join();
  return results;
}

std::string advice_for(const std::vector<std::pair<int, double>>& components) {
  std::map<Family, double> weight;
  bool yaw = false, common_chain = false;
  for (const auto& [k, w] : components) {
    weight[parameter_table()[k].family] += w * w;
    if (k == slot::frame_rotation + 2) yaw = true;
    if (k >= slot::chain_angle && k < slot::chain_angle + 3) common_chain = true;
  }
  auto has = [&weight](Family f) { return weight.count(f) && weight[f] > 0.05; };
  if (yaw && common_chain) {
    return "frame yaw rz and a common chain rotation are the same motion: measure the stage's yaw against "
           "the base (align the stage axes to a base edge or fiducial) to tell them apart";
  }
  if (has(Family::joint_offset) && has(Family::encoder_scale)) {
    return "encoder zero and scale trade off over this small angle range: record a wider range of joint "
           "angles, or reference the encoders at a known angle (index pulse, gauge block under the arm)";
  }
  if (has(Family::frame_misalignment) && (has(Family::joint_offset) || has(Family::radius_offset))) {
    return "measuring-frame translation trades with joint zeros and radii: touch the plate off on a fixture "
           "whose position in the base frame is known";
  }
  if (has(Family::upper_arm_length) || has(Family::lower_arm_length) || has(Family::radius_offset)) {
    return "link lengths trade off inside a 10 mm cube: measure the arms (calipers, CMM) or record poses far "
           "apart in the 40 mm design workspace";
  }
  if (has(Family::transmission_error)) {
    return "the ripple period spans more than the recorded angle range: record a longer angle travel";
  }
  return "record a trajectory spanning a larger part of the workspace";
}

}  // namespace

Vec3 joint_rmse(const std::vector<Sample>& rows, const std::vector<Vec3>& predicted) {
  Vec3 sum = Vec3::Zero();
  for (std::size_t i = 0; i < rows.size(); ++i) sum += (rows[i].alpha_deg - predicted[i]).cwiseAbs2();
  return (sum / static_cast<double>(std::max<std::size_t>(rows.size(), 1))).cwiseSqrt();
}

Identifiability analyse_identifiability(const std::vector<Sample>& rows, FamilySet families, const Parameters& theta) {
  Identifiability result;
  result.model = describe(families);
  const NormalEquations equations = evaluate(theta, families, rows, true);
  if (!equations.ok) return result;
  // Keep only the columns the data touch at all (an absent transmission amplitude leaves its
  // period and phase without any effect).
  for (int k : parameter_indices(families)) {
    if (equations.jtj(k, k) > 1e-300) result.parameters.push_back(k);
  }
  const int n = static_cast<int>(result.parameters.size());
  if (n == 0) return result;
  Eigen::MatrixXd normalised(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      const int ka = result.parameters[a], kb = result.parameters[b];
      normalised(a, b) = equations.jtj(ka, kb) / std::sqrt(equations.jtj(ka, ka) * equations.jtj(kb, kb));
    }
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(normalised);
  for (int a = n - 1; a >= 0; --a) result.singular_values.push_back(std::sqrt(std::max(eigen.eigenvalues()[a], 0.0)));
  for (int a = 0; a < n; ++a) {
    const double singular = std::sqrt(std::max(eigen.eigenvalues()[a], 0.0));
    if (singular >= 1e-2) break;
    WeakDirection weak;
    weak.singular_value = singular;
    const Eigen::VectorXd vector = eigen.eigenvectors().col(a);
    for (int b = 0; b < n; ++b) {
      if (std::abs(vector[b]) > 0.2) weak.components.push_back({result.parameters[b], vector[b]});
    }
    std::sort(weak.components.begin(), weak.components.end(),
              [](const auto& x, const auto& y) { return std::abs(x.second) > std::abs(y.second); });
    weak.advice = advice_for(weak.components);
    result.weak.push_back(weak);
  }
  // Correlations from the pseudo-inverse; exact gauges (normalised singular value below 1e-6,
  // such as frame yaw against a common chain rotation) are left out, they are reported above.
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(n, n);
  for (int a = 0; a < n; ++a) {
    if (eigen.eigenvalues()[a] > 1e-12) {
      covariance += eigen.eigenvectors().col(a) * eigen.eigenvectors().col(a).transpose() / eigen.eigenvalues()[a];
    }
  }
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const double denominator = std::sqrt(covariance(a, a) * covariance(b, b));
      if (denominator <= 0.0) continue;
      const double value = covariance(a, b) / denominator;
      if (std::abs(value) > 0.95) result.correlations.push_back({result.parameters[a], result.parameters[b], value});
    }
  }
  std::sort(result.correlations.begin(), result.correlations.end(),
            [](const Correlation& x, const Correlation& y) { return std::abs(x.value) > std::abs(y.value); });
  if (result.correlations.size() > 12) result.correlations.resize(12);
  return result;
}

Diagnosis diagnose(const std::vector<Sample>& fit, const std::vector<Sample>& check, const DiagnosisOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  Diagnosis diagnosis;
  diagnosis.noise_floor_deg = options.noise_floor_deg;
  const double threshold = options.significance * options.noise_floor_deg * options.noise_floor_deg;
  diagnosis.significance_threshold_deg2 = threshold;

  const std::vector<Sample> thinned_fit = thin_out(fit, options.screening_stride);
  FamilySet current;
  Parameters theta = neutral_parameters();
  const Prediction nominal_fit = predict_recording(EffectSet{}, fit);
  const Prediction nominal_check = predict_recording(EffectSet{}, check);
  diagnosis.check_nominal_deg = nominal_check.alpha_deg;
  diagnosis.fit_rmse_nominal_deg = joint_rmse(fit, nominal_fit.alpha_deg);
  diagnosis.holdout_rmse_nominal_deg = joint_rmse(check, nominal_check.alpha_deg);
  Vec3 current_rmse = diagnosis.holdout_rmse_nominal_deg;
  std::vector<Vec3> current_fit_prediction = nominal_fit.alpha_deg;
  std::vector<std::pair<Family, Candidate>> last_round;
  std::vector<Family> order;
  std::vector<Candidate> forward_path;  // the model after each kept family

  // Forward selection: add the family that lowers the held-out error most, while it passes the
  // stopping rule.
  for (int round = 0; round < kFamilyCount; ++round) {
    std::vector<Family> candidates;
    for (int f = 0; f < kFamilyCount; ++f) {
      if (!current[f]) candidates.push_back(family_at(f));
    }
    if (candidates.empty()) break;
    const auto round_started = std::chrono::steady_clock::now();
    std::vector<std::function<Candidate()>> jobs;
    for (Family family : candidates) {
      const Parameters start = initial_guess(family, theta, fit, current_fit_prediction);
      const FamilySet families = current | single(family);
      jobs.push_back([&fit, &thinned_fit, &check, families, start, &options] {
        return fit_and_check(fit, thinned_fit, check, families, start, options);
      });
    }
    const std::vector<Candidate> results = run_parallel(jobs, options.threads);
    SelectionStep step;
    step.base = current;
    step.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - round_started).count();
    int best = -1;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      if (!results[c].ok) continue;
      step.candidate_mse.push_back({candidates[c], mean_square(results[c].holdout_rmse)});
      if (best < 0 || mean_square(results[c].holdout_rmse) < mean_square(results[best].holdout_rmse)) {
        best = static_cast<int>(c);
      }
    }
    last_round.clear();
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      if (results[c].ok) last_round.push_back({candidates[c], results[c]});
    }
    const double gain = best >= 0 ? mean_square(current_rmse) - mean_square(results[best].holdout_rmse) : 0.0;
    if (best < 0 || gain <= threshold) {
      step.note = "stop: best held-out gain " + std::to_string(gain / threshold) + " x the threshold";
      diagnosis.steps.push_back(step);
      break;
    }
    step.chosen = index_of(candidates[best]);
    diagnosis.steps.push_back(step);
    current.set(step.chosen);
    order.push_back(candidates[best]);
    forward_path.push_back(results[best]);
    theta = results[best].fit.theta;
    current_rmse = results[best].holdout_rmse;
    current_fit_prediction = predict_recording(to_effect_set(theta, current), fit).alpha_deg;
  }

  // A transmission ripple picked early can have locked onto another effect's trend (a long
  // period standing in for an arm length). If the model misses the floor, restart the ripple
  // from the residual of the model without it, from both starts, and keep what CHECK prefers.
  const double floor_limit = options.explained_ratio * options.noise_floor_deg;
  bool path_changed = false;
  if (current[index_of(Family::transmission_error)] && current_rmse.maxCoeff() > floor_limit) {
    FamilySet without = current;
    without.reset(index_of(Family::transmission_error));
    Parameters base = theta;
    for (int k : parameter_indices(single(Family::transmission_error))) base[k] = neutral_parameters()[k];
    const std::vector<Vec3> prediction = predict_recording(to_effect_set(base, without), fit).alpha_deg;
    std::vector<std::function<Candidate()>> jobs;
    for (bool long_period : {false, true}) {
      const Parameters start = initial_guess(Family::transmission_error, base, fit, prediction, long_period);
      jobs.push_back([&fit, &thinned_fit, &check, current, start, &options] {
        return fit_and_check(fit, thinned_fit, check, current, start, options);
      });
    }
    for (const Candidate& restarted : run_parallel(jobs, options.threads)) {
      if (restarted.ok && mean_square(restarted.holdout_rmse) < mean_square(current_rmse)) {
        theta = restarted.fit.theta;
        current_rmse = restarted.holdout_rmse;
        path_changed = true;
      }
    }
  }

  // Backward elimination: drop a family whose removal costs less than the threshold on CHECK
  // (an early pick that later picks made redundant).
  for (bool dropped = true; dropped && current.count() > 1;) {
    dropped = false;
    std::vector<Family> members;
    for (Family family : order) members.push_back(family);
    std::vector<std::function<Candidate()>> jobs;
    for (Family family : members) {
      FamilySet reduced = current;
      reduced.reset(index_of(family));
      Parameters start = theta;
      for (int k : parameter_indices(single(family))) start[k] = neutral_parameters()[k];
      jobs.push_back([&fit, &thinned_fit, &check, reduced, start, &options] { return fit_and_check(fit, thinned_fit, check, reduced, start, options); });
    }
    const std::vector<Candidate> results = run_parallel(jobs, options.threads);
    int weakest = -1;
    double weakest_cost = 0.0;
    for (std::size_t m = 0; m < members.size(); ++m) {
      if (!results[m].ok) continue;
      const double cost = mean_square(results[m].holdout_rmse) - mean_square(current_rmse);
      if (cost <= threshold && (weakest < 0 || cost < weakest_cost)) {
        weakest = static_cast<int>(m);
        weakest_cost = cost;
      }
    }
    if (weakest >= 0) {
      diagnosis.eliminated.push_back(family_name(members[weakest]));
      current.reset(index_of(members[weakest]));
      order.erase(std::find(order.begin(), order.end(), members[weakest]));
      theta = results[weakest].fit.theta;
      current_rmse = results[weakest].holdout_rmse;
      dropped = true;
    }
  }

  // Swap search: a wrong early pick can absorb two true effects and end as a larger model at the
  // floor (chain_angle + joint_offset read as frame_misalignment + radius_offset + joint_offset).
  // When a model of three or four families reaches the floor, try each two-for-one swap and keep
  // a smaller model that does as well on CHECK (within the threshold).
  // Limited to models of three or four families: the search grows as k^2 (9 - k) fits.
  while (current.count() >= 3 && current.count() <= 4 && current_rmse.maxCoeff() <= floor_limit) {
    std::vector<FamilySet> sets;
    std::vector<std::function<Candidate()>> jobs;
    for (std::size_t a = 0; a < order.size(); ++a) {
      for (std::size_t b = a + 1; b < order.size(); ++b) {
        FamilySet reduced = current;
        reduced.reset(index_of(order[a]));
        reduced.reset(index_of(order[b]));
        Parameters reduced_theta = theta;
        for (int k : parameter_indices(single(order[a]) | single(order[b]))) reduced_theta[k] = neutral_parameters()[k];
        const std::vector<Vec3> reduced_prediction =
            predict_recording(to_effect_set(reduced_theta, reduced), fit).alpha_deg;
        for (int f = 0; f < kFamilyCount; ++f) {
          if (current[f]) continue;
          const Parameters start = initial_guess(family_at(f), reduced_theta, fit, reduced_prediction);
          const FamilySet families = reduced | single(family_at(f));
          sets.push_back(families);
          jobs.push_back([&fit, &thinned_fit, &check, families, start, &options] {
            return fit_and_check(fit, thinned_fit, check, families, start, options);
          });
        }
      }
    }
    const std::vector<Candidate> results = run_parallel(jobs, options.threads);
    int best = -1;
    for (std::size_t r = 0; r < results.size(); ++r) {
      if (results[r].ok && (best < 0 || mean_square(results[r].holdout_rmse) < mean_square(results[best].holdout_rmse))) {
        best = static_cast<int>(r);
      }
    }
    if (best < 0 || mean_square(results[best].holdout_rmse) > mean_square(current_rmse) + threshold) break;
    std::vector<Family> kept;
    for (Family family : order) {
      if (sets[best][index_of(family)]) kept.push_back(family);
      else diagnosis.eliminated.push_back(std::string(family_name(family)) + " (swapped out)");
    }
    for (int f = 0; f < kFamilyCount; ++f) {
      if (sets[best][f] && !current[f]) kept.push_back(family_at(f));
    }
    order = kept;
    current = sets[best];
    theta = results[best].fit.theta;
    current_rmse = results[best].holdout_rmse;
  }

  // The kept model, refitted on every FIT row.
  if (current.any()) {
    FitOptions fit_options;
    fit_options.noise_floor_deg = options.noise_floor_deg;
    const FitResult final_fit = fit_model(fit, current, theta, theta, fit_options);
    if (final_fit.ok) {
      theta = final_fit.theta;
      if (!forward_path.empty() && diagnosis.eliminated.empty() && !path_changed) forward_path.back().fit.theta = theta;
    }
  }
  diagnosis.significant = current;
  diagnosis.theta = theta;
  for (int k = 0; k < kParameterCount; ++k) {
    if (!current[index_of(parameter_table()[k].family)]) diagnosis.theta[k] = neutral_parameters()[k];
  }
  diagnosis.fitted_effects = to_effect_set(diagnosis.theta, current);
  const Prediction final_fit = predict_recording(diagnosis.fitted_effects, fit);
  const Prediction final_check = predict_recording(diagnosis.fitted_effects, check);
  diagnosis.check_after_deg = final_check.alpha_deg;
  diagnosis.check_unreachable = final_check.unreachable;
  diagnosis.fit_rmse_after_deg = joint_rmse(fit, final_fit.alpha_deg);
  diagnosis.holdout_rmse_after_deg = joint_rmse(check, final_check.alpha_deg);
  const double floor_square = options.noise_floor_deg * options.noise_floor_deg;
  const double excess_before = mean_square(diagnosis.holdout_rmse_nominal_deg) - floor_square;
  const double excess_after = std::max(mean_square(diagnosis.holdout_rmse_after_deg) - floor_square, 0.0);
  diagnosis.explained_fraction = excess_before > 0.0 ? std::clamp(1.0 - excess_after / excess_before, 0.0, 1.0) : 1.0;
  diagnosis.explained =
      diagnosis.holdout_rmse_after_deg.maxCoeff() <= options.explained_ratio * options.noise_floor_deg;

  // Ranking: the kept families in the order they were added, each with the held-out RMSE of the
  // model built up to it; then the rest by what they would still add to the final model.
  {
    std::vector<std::function<Candidate()>> jobs;
    FamilySet prefix;
    for (Family family : order) {
      prefix.set(index_of(family));
      Parameters start = diagnosis.theta;
      for (int k = 0; k < kParameterCount; ++k) {
        if (!prefix[index_of(parameter_table()[k].family)]) start[k] = neutral_parameters()[k];
      }
      jobs.push_back([&fit, &thinned_fit, &check, prefix, start, &options] { return fit_and_check(fit, thinned_fit, check, prefix, start, options); });
    }
    if (!order.empty()) jobs.back() = [&] {
      Candidate final_candidate;
      final_candidate.ok = true;
      final_candidate.fit.theta = diagnosis.theta;
      final_candidate.holdout_rmse = diagnosis.holdout_rmse_after_deg;
      return final_candidate;
    };
    // Without eliminations the forward path already is this path.
    const std::vector<Candidate> path =
        diagnosis.eliminated.empty() && !path_changed ? forward_path : run_parallel(jobs, options.threads);
    Vec3 previous = diagnosis.holdout_rmse_nominal_deg;
    for (std::size_t r = 0; r < order.size(); ++r) {
      EffectFinding finding;
      finding.family = order[r];
      finding.significant = true;
      finding.theta = path[r].fit.theta;
      finding.holdout_rmse_deg = path[r].holdout_rmse;
      finding.holdout_gain_deg2 = mean_square(previous) - mean_square(path[r].holdout_rmse);
      previous = path[r].holdout_rmse;
      diagnosis.findings.push_back(finding);
    }
  }
  {
    std::vector<Family> rest;
    std::vector<std::function<Candidate()>> jobs;
    for (int f = 0; f < kFamilyCount; ++f) {
      if (current[f]) continue;
      const Family family = family_at(f);
      rest.push_back(family);
      const auto reused = std::find_if(last_round.begin(), last_round.end(), [&](const auto& entry) {
        return entry.first == family && (entry.second.fit.families ^ single(family)) == current;
      });
      if (reused != last_round.end()) {
        const Candidate copy = reused->second;
        jobs.push_back([copy] { return copy; });
      } else {
        const Parameters start = initial_guess(family, diagnosis.theta, fit, final_fit.alpha_deg);
        const FamilySet families = current | single(family);
        jobs.push_back([&fit, &thinned_fit, &check, families, start, &options] { return fit_and_check(fit, thinned_fit, check, families, start, options); });
      }
    }
    const std::vector<Candidate> results = run_parallel(jobs, options.threads);
    std::vector<EffectFinding> others;
    for (std::size_t r = 0; r < rest.size(); ++r) {
      EffectFinding finding;
      finding.family = rest[r];
      finding.theta = results[r].fit.theta;
      finding.holdout_rmse_deg = results[r].ok ? results[r].holdout_rmse : Vec3::Constant(NAN);
      finding.holdout_gain_deg2 =
          results[r].ok ? mean_square(diagnosis.holdout_rmse_after_deg) - mean_square(results[r].holdout_rmse) : 0.0;
      others.push_back(finding);
    }
    std::stable_sort(others.begin(), others.end(), [](const EffectFinding& a, const EffectFinding& b) {
      return a.holdout_gain_deg2 > b.holdout_gain_deg2;
    });
    diagnosis.findings.insert(diagnosis.findings.end(), others.begin(), others.end());
  }

  // Subsystems: the final model without one subsystem's families (parameters kept as fitted).
  for (const char* subsystem : {"geometry", "measuring frame", "transmission", "sensor"}) {
    FamilySet without = current;
    for (int f = 0; f < kFamilyCount; ++f) {
      if (std::string(subsystem_of(family_at(f))) == subsystem) without.reset(f);
    }
    if (without == current) continue;
    const Prediction prediction = predict_recording(to_effect_set(diagnosis.theta, without), check);
    diagnosis.subsystem_rmse_without_deg.push_back({subsystem, joint_rmse(check, prediction.alpha_deg)});
  }

  // Regions: octants of the CHECK trajectory's bounding box.
  if (!check.empty()) {
    Vec3 low = check.front().position_m, high = low;
    for (const Sample& sample : check) {
      low = low.cwiseMin(sample.position_m);
      high = high.cwiseMax(sample.position_m);
    }
    const Vec3 middle = 0.5 * (low + high);
    std::array<RegionError, 8> octants;
    std::array<Vec3, 8> nominal_sum, after_sum;
    for (int o = 0; o < 8; ++o) {
      octants[o].label = std::string("x") + ((o & 1) ? "+" : "-") + " y" + ((o & 2) ? "+" : "-") + " z" +
                         ((o & 4) ? "+" : "-");
      nominal_sum[o].setZero();
      after_sum[o].setZero();
    }
    for (std::size_t i = 0; i < check.size(); ++i) {
      const Vec3& p = check[i].position_m;
      const int o = (p.x() > middle.x() ? 1 : 0) | (p.y() > middle.y() ? 2 : 0) | (p.z() > middle.z() ? 4 : 0);
      ++octants[o].samples;
      nominal_sum[o] += (check[i].alpha_deg - diagnosis.check_nominal_deg[i]).cwiseAbs2();
      after_sum[o] += (check[i].alpha_deg - diagnosis.check_after_deg[i]).cwiseAbs2();
    }
    for (int o = 0; o < 8; ++o) {
      if (!octants[o].samples) continue;
      octants[o].nominal_rmse_deg = (nominal_sum[o] / octants[o].samples).cwiseSqrt();
      octants[o].after_rmse_deg = (after_sum[o] / octants[o].samples).cwiseSqrt();
      diagnosis.regions.push_back(octants[o]);
    }
  }

  diagnosis.final_model = analyse_identifiability(fit, current, diagnosis.theta);
  FamilySet everything;
  for (int f = 0; f < kFamilyCount; ++f) everything.set(f);
  if (!current[index_of(Family::transmission_error)]) everything.reset(index_of(Family::transmission_error));
  Parameters probe = diagnosis.theta;
  // Backlash of exactly zero hides its column's sign; a tiny width makes the direction visible.
  for (int j = 0; j < 3; ++j) probe[slot::backlash + j] = std::max(probe[slot::backlash + j], 0.01);
  diagnosis.all_families = analyse_identifiability(fit, everything, probe);
  diagnosis.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return diagnosis;
}

}  // namespace delta::diagnosis
