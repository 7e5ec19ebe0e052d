// Search for family sets the held-out data cannot tell from the chosen one, and what would.
#include "alternatives.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "identifiability.hpp"
#include "initial_guess.hpp"

namespace delta::diagnosis {
namespace {

// The measurement that would separate two sets: the advice of the weakest direction of the model
// holding both, at the chosen parameters plus the alternative's for the families it adds.
std::string separation(const PipelineData& data, FamilySet chosen, const Parameters& chosen_theta,
                       const Alternative& alternative) {
  const FamilySet both = chosen | alternative.families;
  Parameters theta = chosen_theta;
  for (int k : parameter_indices(alternative.families & ~chosen)) theta[k] = alternative.theta[k];
  for (int j = 0; j < 3; ++j) theta[slot::backlash + j] = std::max(theta[slot::backlash + j], 0.01);
  const Identifiability identifiability = analyse_identifiability(data.thinned_fit, both, theta);
  // An exact gauge (frame yaw against a common chain rotation) is in both sets' reach whenever the
  // frame is: the advice of the weakest direction that is not one, if any.
  for (const WeakDirection& weak : identifiability.weak) {
    if (weak.singular_value > 1e-6) return weak.advice;
  }
  if (!identifiability.weak.empty()) return identifiability.weak.front().advice;
  std::vector<std::pair<int, double>> components;
  for (int k : parameter_indices(both & ~(chosen & alternative.families))) components.push_back({k, 1.0});
  return advice_for(components);
}

// A realistic upper magnitude of each parameter in the internal unit (the blind suite's largest
// draws: 1 deg of joint zero, 0.5 mm of length or radius, 0.5 deg of chain angle or frame
// rotation, 0.5 mm of frame shift, 0.3 deg of play, 1 % of encoder scale); 0 for the
// transmission error, whose ripple is no single direction.
double realistic_magnitude(int k) {
  switch (parameter_table()[k].family) {
    case Family::joint_offset:
      return 1.0;
    case Family::upper_arm_length:
    case Family::lower_arm_length:
    case Family::radius_offset:
      return 0.5;
    case Family::chain_angle:
      return 0.5;
    case Family::frame_misalignment:
      return 0.5;
    case Family::backlash:
      return 0.3;
    case Family::encoder_scale:
      return 0.01;
    default:
      return 0.0;
  }
}

// The families outside the chosen set that the chosen set absorbs on these rows: whatever
// realistic size of such a family's parameters (their vector at most the realistic magnitudes
// in norm), what of its signal the chosen families cannot imitate carries less held-out mean
// square than the stopping rule's threshold. To first order at the chosen parameters: the Schur
// complement of the chosen columns in J^T J, scaled by the magnitudes, its largest eigenvalue
// over the rows' 3 N residuals. Such a family could be on the robot unseen: the chosen set with it
// is as good an explanation, and the data cannot say whether it is there.
std::vector<Family> absorbed_families(const PipelineData& data, FamilySet chosen, const Parameters& chosen_theta) {
  std::vector<Family> absorbed;
  if (data.thinned_fit.empty()) return absorbed;
  FamilySet candidates;
  for (int f = 0; f < kFamilyCount; ++f) {
    if (!chosen[f] && family_at(f) != Family::transmission_error) candidates.set(f);
  }
  if (candidates.none()) return absorbed;
  Parameters probe = chosen_theta;
  // Backlash of exactly zero hides its column's sign; a tiny width makes the direction visible.
  for (int j = 0; j < 3; ++j) probe[slot::backlash + j] = std::max(probe[slot::backlash + j], 0.01);
  const NormalEquations equations = evaluate(probe, chosen | candidates, data.thinned_fit, true);
  if (!equations.ok) return absorbed;
  std::vector<int> kept;
  for (int k : parameter_indices(chosen)) {
    if (equations.jtj(k, k) > 1e-300) kept.push_back(k);
  }
  const int c = static_cast<int>(kept.size());
  Eigen::MatrixXd chosen_block(c, c);
  for (int a = 0; a < c; ++a) {
    for (int b = 0; b < c; ++b) chosen_block(a, b) = equations.jtj(kept[a], kept[b]);
  }
  // Column scaling, then a pseudo-inverse (gauges such as frame yaw against a common chain
  // rotation are exact).
  Eigen::VectorXd scale(c);
  for (int a = 0; a < c; ++a) scale[a] = 1.0 / std::sqrt(chosen_block(a, a));
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Zero(c, c);  // none chosen (a nominal robot): nothing to imitate with
  if (c > 0) {
    const Eigen::MatrixXd normalised = scale.asDiagonal() * chosen_block * scale.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(normalised);
    for (int a = 0; a < c; ++a) {
      if (eigen.eigenvalues()[a] > 1e-10 * eigen.eigenvalues().maxCoeff()) {
        inverse += eigen.eigenvectors().col(a) * eigen.eigenvectors().col(a).transpose() / eigen.eigenvalues()[a];
      }
    }
    inverse = scale.asDiagonal() * inverse * scale.asDiagonal();
  }
  const double residuals = 3.0 * static_cast<double>(data.thinned_fit.size());
  for (int f = 0; f < kFamilyCount; ++f) {
    if (!candidates[f]) continue;
    const std::vector<int> own = parameter_indices(single(family_at(f)));
    const int n = static_cast<int>(own.size());
    Eigen::MatrixXd own_block(n, n), cross(c, n);
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) own_block(a, b) = equations.jtj(own[a], own[b]);
      for (int b = 0; b < c; ++b) cross(b, a) = equations.jtj(kept[b], own[a]);
    }
    Eigen::MatrixXd left = own_block - cross.transpose() * inverse * cross;
    Eigen::VectorXd magnitude(n);
    for (int a = 0; a < n; ++a) magnitude[a] = realistic_magnitude(own[a]);
    left = magnitude.asDiagonal() * left * magnitude.asDiagonal();
    const double largest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(left).eigenvalues().maxCoeff();
    if (largest / residuals < data.threshold_deg2) absorbed.push_back(family_at(f));
  }
  return absorbed;
}

// The largest of a family's fitted parameters as a share of its realistic magnitude.
// A family fitted to at least kSizedShare of it (0.05 deg of chain angle, 0.05 mm of length, 0.1 %
// of encoder scale, ...) is a real part of that set's explanation, not a zero added to the chosen set.
constexpr double kSizedShare = 0.1;
double realistic_share(Family family, const Parameters& theta) {
  double share = 0.0;
  for (int k : parameter_indices(single(family))) {
    if (realistic_magnitude(k) > 0.0) share = std::max(share, std::abs(theta[k]) / realistic_magnitude(k));
  }
  return share;
}

// Whether a set that misses the floor test is still one CHECK cannot tell from the chosen set
// (which passes it): in every part of the floor test it misses (the three joints together, or
// one joint), its held-out error is not significantly larger than the chosen set's there (paired
// z <= options.paired_z; the noise cancels in the pairs, so this test sees far smaller differences
// than the floor test), and no joint is above the floor test's RMSE cap. Two such sets sit on
// either side of the floor test's threshold by chance.
bool indistinguishable_where_missed(const PipelineData& data, const std::vector<Vec3>& prediction,
                                    const std::vector<Vec3>& chosen, const FloorTest& test,
                                    const PairedDifference& difference) {
  if (test.joint_rmse_floors.maxCoeff() > test.rmse_cap_floors) return false;
  if (test.z > test.threshold && difference.z > data.options.paired_z) return false;
  for (int j = 0; j < 3; ++j) {
    if (test.joint_z[j] <= test.threshold + 0.5) continue;
    // Both predictions equal the measurement in the other joints: the pairs hold joint j alone.
    std::vector<Vec3> alone = prediction, chosen_alone = chosen;
    for (std::size_t i = 0; i < data.check.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        if (k == j) continue;
        alone[i][k] = data.check[i].alpha_deg[k];
        chosen_alone[i][k] = data.check[i].alpha_deg[k];
      }
    }
    if (paired_difference(data.check, alone, chosen_alone, data.options.batch_rows).z > data.options.paired_z) {
      return false;
    }
  }
  return true;
}

// A fitted candidate as an alternative to the chosen set (whose held-out MSE is chosen_mse).
Alternative alternative_of(FamilySet families, const Candidate& candidate, const PairedDifference& difference,
                           double chosen_mse, bool at_floor) {
  Alternative alternative;
  alternative.families = families;
  alternative.theta = candidate.fit.theta;
  alternative.holdout_rmse_deg = candidate.holdout_rmse;
  alternative.mse_difference_deg2 = mean_square(candidate.holdout_rmse) - chosen_mse;
  alternative.paired_z = difference.z;
  alternative.at_floor = at_floor;
  return alternative;
}

}  // namespace

std::vector<Alternative> find_alternatives(const PipelineData& data, FamilySet chosen_families,
                                           const Parameters& chosen_theta, const std::vector<Vec3>& chosen,
                                           const NoiseModel& noise, bool chosen_at_floor) {
  std::vector<Family> members;
  for (int f = 0; f < kFamilyCount; ++f) {
    if (chosen_families[f]) members.push_back(family_at(f));
  }
  std::vector<FamilySet> removals;
  for (std::size_t a = 0; a < members.size(); ++a) {
    removals.push_back(single(members[a]));
    // Two-for-one only for small models that reach the floor: the search grows as k^2 (9 - k) fits.
    if (members.size() < 2 || members.size() > 3 || !chosen_at_floor) continue;
    for (std::size_t b = a + 1; b < members.size(); ++b) removals.push_back(single(members[a]) | single(members[b]));
  }
  std::vector<FamilySet> sets;
  std::vector<Job> jobs;
  for (const FamilySet& removed : removals) {
    const FamilySet reduced = chosen_families & ~removed;
    const Parameters reduced_theta = without_families(chosen_theta, removed);
    const std::vector<Vec3> reduced_prediction =
        predict_recording(to_effect_set(reduced_theta, reduced), data.fit).alpha_deg;
    for (int f = 0; f < kFamilyCount; ++f) {
      if (chosen_families[f]) continue;
      const FamilySet families = reduced | single(family_at(f));
      const Parameters start = initial_guess(family_at(f), reduced_theta, data.fit, reduced_prediction);
      sets.push_back(families);
      jobs.push_back([&data, families, start] { return fit_and_check(data, families, start); });
    }
  }
  const std::vector<Candidate> results = run_parallel(jobs, data.options.threads);
  const double chosen_mse = [&] {
    double sum = 0.0;
    for (std::size_t i = 0; i < data.check.size(); ++i)
      sum += (data.check[i].alpha_deg - chosen[i]).squaredNorm() / 3.0;
    return sum / std::max<std::size_t>(data.check.size(), 1);
  }();
  std::vector<Alternative> alternatives;
  for (std::size_t r = 0; r < results.size(); ++r) {
    if (!results[r].ok) continue;
    const PairedDifference difference =
        paired_difference(data.check, results[r].check_prediction, chosen, data.options.batch_rows);
    const bool close = difference.mean_deg2 <= data.threshold_deg2 || difference.z <= data.options.paired_z;
    if (!close) continue;
    const FloorTest test = floor_test(data.check, results[r].check_prediction, noise, data.options);
    if (chosen_at_floor && !test.at_floor &&
        !indistinguishable_where_missed(data, results[r].check_prediction, chosen, test, difference)) {
      continue;
    }
    alternatives.push_back(alternative_of(sets[r], results[r], difference, chosen_mse, test.at_floor));
  }
  std::sort(alternatives.begin(), alternatives.end(),
            [](const Alternative& a, const Alternative& b) { return a.mse_difference_deg2 < b.mse_difference_deg2; });
  if (alternatives.size() > 5) alternatives.resize(5);

  // The chosen set with one more family (the ripple aside: its fit needs a start of its own),
  // listed after the swaps (at most three, the best on CHECK first) when the data cannot say
  // whether that family is there:
  // - it is absorbed (absorbed_families), or fitted to a realistic size (realistic_share: the chosen
  //   set plus chain angles of 0.2-0.3 deg on a calibration drag, which the chosen families imitate
  //   there but would not at 0.5 deg), and CHECK cannot tell the two sets apart either way;
  // - or CHECK sees it, significantly: below the stopping rule's minimum effect (the selection could
  //   not add it), or above it where the selection's own fit of that set, from its family's initial
  //   guess, landed elsewhere along a valley FIT cannot fix (joint zeros that the frame's translation
  //   and the radii imitate across a closed-loop run's few millimetres); adopt_better_alternative
  //   then takes the larger set.
  const std::vector<Family> absorbed = absorbed_families(data, chosen_families, chosen_theta);
  std::vector<Family> added;
  std::vector<FamilySet> supersets;
  std::vector<Job> superset_jobs;
  for (int f = 0; f < kFamilyCount; ++f) {
    if (chosen_families[f] || family_at(f) == Family::transmission_error) continue;
    const FamilySet families = chosen_families | single(family_at(f));
    added.push_back(family_at(f));
    supersets.push_back(families);
    superset_jobs.push_back([&data, families, &chosen_theta] { return fit_and_check(data, families, chosen_theta); });
  }
  const std::vector<Candidate> superset_results = run_parallel(superset_jobs, data.options.threads);
  std::vector<Alternative> larger;
  for (std::size_t r = 0; r < superset_results.size(); ++r) {
    if (!superset_results[r].ok) continue;
    const PairedDifference difference =
        paired_difference(data.check, superset_results[r].check_prediction, chosen, data.options.batch_rows);
    const bool unseen =
        (std::find(absorbed.begin(), absorbed.end(), added[r]) != absorbed.end() ||
         realistic_share(added[r], superset_results[r].fit.theta) >= kSizedShare) &&
        difference.z >= -data.options.paired_z &&
        (std::abs(difference.mean_deg2) <= data.threshold_deg2 || std::abs(difference.z) <= data.options.paired_z);
    const bool seen = difference.z < -data.options.paired_z;
    if (!unseen && !seen) continue;
    const FloorTest test = floor_test(data.check, superset_results[r].check_prediction, noise, data.options);
    // An unseen family leaves the verdict as it is; a seen one may lift a set short of the floor
    // onto it, never the other way.
    if (unseen ? test.at_floor != chosen_at_floor : chosen_at_floor && !test.at_floor) continue;
    larger.push_back(alternative_of(supersets[r], superset_results[r], difference, chosen_mse, test.at_floor));
  }
  // The other smallest sets an elimination from every family kept (selection.cpp), first.
  std::vector<Alternative> equivalent;
  for (const auto& [families, candidate] : data.equivalent_sets) {
    if (families == chosen_families) continue;
    const bool listed = std::any_of(alternatives.begin(), alternatives.end(),
                                    [&](const Alternative& a) { return a.families == families; });
    if (listed) continue;
    const PairedDifference difference =
        paired_difference(data.check, candidate.check_prediction, chosen, data.options.batch_rows);
    const FloorTest test = floor_test(data.check, candidate.check_prediction, noise, data.options);
    equivalent.push_back(alternative_of(families, candidate, difference, chosen_mse, test.at_floor));
  }
  alternatives.insert(alternatives.begin(), equivalent.begin(), equivalent.end());
  std::sort(larger.begin(), larger.end(),
            [](const Alternative& a, const Alternative& b) { return a.mse_difference_deg2 < b.mse_difference_deg2; });
  if (larger.size() > 3) larger.resize(3);
  alternatives.insert(alternatives.end(), larger.begin(), larger.end());
  for (Alternative& alternative : alternatives) {
    alternative.separate_by = separation(data, chosen_families, chosen_theta, alternative);
  }
  return alternatives;
}

}  // namespace delta::diagnosis
