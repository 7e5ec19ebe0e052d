// Search for family sets the held-out data cannot tell from the chosen one, and what would.
#include "alternatives.hpp"

#include <algorithm>

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
  if (!identifiability.weak.empty()) return identifiability.weak.front().advice;
  std::vector<std::pair<int, double>> components;
  for (int k : parameter_indices(both & ~(chosen & alternative.families))) components.push_back({k, 1.0});
  return advice_for(components);
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
    if (chosen_at_floor && !test.at_floor) continue;
    Alternative alternative;
    alternative.families = sets[r];
    alternative.theta = results[r].fit.theta;
    alternative.holdout_rmse_deg = results[r].holdout_rmse;
    alternative.mse_difference_deg2 = mean_square(results[r].holdout_rmse) - chosen_mse;
    alternative.paired_z = difference.z;
    alternative.at_floor = test.at_floor;
    alternatives.push_back(alternative);
  }
  std::sort(alternatives.begin(), alternatives.end(),
            [](const Alternative& a, const Alternative& b) { return a.mse_difference_deg2 < b.mse_difference_deg2; });
  if (alternatives.size() > 5) alternatives.resize(5);
  for (Alternative& alternative : alternatives) {
    alternative.separate_by = separation(data, chosen_families, chosen_theta, alternative);
  }
  return alternatives;
}

}  // namespace delta::diagnosis
