// Ranking of the effects and location of the held-out gap per subsystem and per octant.
#include "attribution.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "initial_guess.hpp"

namespace delta::diagnosis {

std::vector<EffectFinding> rank_findings(const PipelineData& data, const Selection& selection,
                                         const Diagnosis& diagnosis, const Vec3& final_rmse,
                                         const std::vector<Vec3>& final_fit) {
  std::vector<EffectFinding> findings;
  const FamilySet current = selection.families;
  {
    std::vector<Job> jobs;
    FamilySet prefix;
    for (Family family : selection.order) {
      prefix.set(index_of(family));
      const Parameters start = without_families(diagnosis.theta, ~prefix);
      jobs.push_back([&data, prefix, start] { return fit_and_check(data, prefix, start); });
    }
    if (!selection.order.empty()) {
      jobs.back() = [&diagnosis, &final_rmse] {
        Candidate final_candidate;
        final_candidate.ok = true;
        final_candidate.fit.theta = diagnosis.theta;
        final_candidate.holdout_rmse = final_rmse;
        return final_candidate;
      };
    }
    // Without eliminations the forward path already is this path.
    std::vector<Candidate> path = diagnosis.eliminated.empty() && !selection.path_changed
                                      ? selection.forward_path
                                      : run_parallel(jobs, data.options.threads);
    if (!path.empty()) path.back().fit.theta = diagnosis.theta;
    Vec3 previous = diagnosis.holdout_rmse_nominal_deg;
    for (std::size_t r = 0; r < selection.order.size(); ++r) {
      EffectFinding finding;
      finding.family = selection.order[r];
      finding.significant = true;
      finding.theta = path[r].fit.theta;
      finding.holdout_rmse_deg = path[r].holdout_rmse;
      finding.holdout_gain_deg2 = mean_square(previous) - mean_square(path[r].holdout_rmse);
      previous = path[r].holdout_rmse;
      findings.push_back(finding);
    }
  }
  std::vector<Family> rest;
  std::vector<Job> jobs;
  for (int f = 0; f < kFamilyCount; ++f) {
    if (current[f]) continue;
    const Family family = family_at(f);
    rest.push_back(family);
    const auto reused = std::find_if(selection.last_round.begin(), selection.last_round.end(), [&](const auto& entry) {
      return entry.first == family && (entry.second.fit.families ^ single(family)) == current;
    });
    if (reused != selection.last_round.end()) {
      const Candidate copy = reused->second;
      jobs.push_back([copy] { return copy; });
    } else {
      const Parameters start = initial_guess(family, diagnosis.theta, data.fit, final_fit);
      const FamilySet families = current | single(family);
      jobs.push_back([&data, families, start] { return fit_and_check(data, families, start); });
    }
  }
  const std::vector<Candidate> results = run_parallel(jobs, data.options.threads);
  std::vector<EffectFinding> others;
  for (std::size_t r = 0; r < rest.size(); ++r) {
    EffectFinding finding;
    finding.family = rest[r];
    finding.theta = results[r].fit.theta;
    finding.holdout_rmse_deg = results[r].ok ? results[r].holdout_rmse : Vec3::Constant(NAN);
    finding.holdout_gain_deg2 = results[r].ok ? mean_square(final_rmse) - mean_square(results[r].holdout_rmse) : 0.0;
    others.push_back(finding);
  }
  std::stable_sort(others.begin(), others.end(), [](const EffectFinding& a, const EffectFinding& b) {
    return a.holdout_gain_deg2 > b.holdout_gain_deg2;
  });
  findings.insert(findings.end(), others.begin(), others.end());
  return findings;
}

std::vector<std::pair<std::string, Vec3>> subsystem_errors(const std::vector<Sample>& check, FamilySet families,
                                                           const Parameters& theta) {
  std::vector<std::pair<std::string, Vec3>> errors;
  for (const char* subsystem : {"geometry", "measuring frame", "transmission", "sensor"}) {
    FamilySet without = families;
    for (int f = 0; f < kFamilyCount; ++f) {
      if (std::string(subsystem_of(family_at(f))) == subsystem) without.reset(f);
    }
    if (without == families) continue;
    const Prediction prediction = predict_recording(to_effect_set(theta, without), check);
    errors.push_back({subsystem, joint_rmse(check, prediction.alpha_deg)});
  }
  return errors;
}

int octant_of(const Vec3& position, const Vec3& middle) {
  return (position.x() > middle.x() ? 1 : 0) | (position.y() > middle.y() ? 2 : 0) |
         (position.z() > middle.z() ? 4 : 0);
}

std::string octant_label(int octant) {
  return std::string("x") + ((octant & 1) ? "+" : "-") + " y" + ((octant & 2) ? "+" : "-") + " z" +
         ((octant & 4) ? "+" : "-");
}

Vec3 middle_of(const std::vector<Sample>& rows) {
  if (rows.empty()) return Vec3::Zero();
  Vec3 low = rows.front().position_m, high = low;
  for (const Sample& sample : rows) {
    low = low.cwiseMin(sample.position_m);
    high = high.cwiseMax(sample.position_m);
  }
  return 0.5 * (low + high);
}

std::vector<RegionError> region_errors(const std::vector<Sample>& check, const std::vector<Vec3>& nominal,
                                       const std::vector<Vec3>& after) {
  std::vector<RegionError> regions;
  if (check.empty()) return regions;
  const Vec3 middle = middle_of(check);
  std::array<RegionError, 8> octants;
  std::array<Vec3, 8> nominal_sum, after_sum;
  for (int o = 0; o < 8; ++o) {
    octants[o].label = octant_label(o);
    nominal_sum[o].setZero();
    after_sum[o].setZero();
  }
  for (std::size_t i = 0; i < check.size(); ++i) {
    const int o = octant_of(check[i].position_m, middle);
    ++octants[o].samples;
    nominal_sum[o] += (check[i].alpha_deg - nominal[i]).cwiseAbs2();
    after_sum[o] += (check[i].alpha_deg - after[i]).cwiseAbs2();
  }
  for (int o = 0; o < 8; ++o) {
    if (!octants[o].samples) continue;
    octants[o].nominal_rmse_deg = (nominal_sum[o] / octants[o].samples).cwiseSqrt();
    octants[o].after_rmse_deg = (after_sum[o] / octants[o].samples).cwiseSqrt();
    regions.push_back(octants[o]);
  }
  return regions;
}

}  // namespace delta::diagnosis
