// Selection of the effect families by their error on the held-out rows.
#include "selection.hpp"

#include <algorithm>
#include <chrono>

#include "floor_test.hpp"
#include "initial_guess.hpp"

namespace delta::diagnosis {
namespace {

bool near_floor(const Candidate& model, const DiagnosisOptions& options) {
  return model.holdout_rmse.maxCoeff() <= options.near_floor_ratio * options.noise_floor_deg;
}

// Forward selection: each round adds the family that lowers the held-out error most, while the
// gain passes the stopping rule: larger than the minimum effect (threshold_deg2) and significant
// by the paired test on the CHECK rows (z above options.paired_z).
void forward_selection(const PipelineData& data, Selection& selection) {
  std::vector<Vec3> fit_prediction =
      predict_recording(to_effect_set(selection.theta, selection.families), data.fit).alpha_deg;
  for (int round = 0; round < kFamilyCount; ++round) {
    std::vector<Family> candidates;
    for (int f = 0; f < kFamilyCount; ++f) {
      if (!selection.families[f]) candidates.push_back(family_at(f));
    }
    if (candidates.empty()) break;
    const auto round_started = std::chrono::steady_clock::now();
    std::vector<Job> jobs;
    for (Family family : candidates) {
      const Parameters start = initial_guess(family, selection.theta, data.fit, fit_prediction);
      const FamilySet families = selection.families | single(family);
      jobs.push_back([&data, families, start] { return fit_and_check(data, families, start); });
    }
    const std::vector<Candidate> results = run_parallel(jobs, data.options.threads);
    SelectionStep step;
    step.base = selection.families;
    step.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - round_started).count();
    int best = -1;
    selection.last_round.clear();
    const bool first = selection.families.none();
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      if (!results[c].ok) continue;
      selection.last_round.push_back({candidates[c], results[c]});
      if (first) selection.first_round.push_back({candidates[c], results[c]});
      step.candidate_mse.push_back({candidates[c], mean_square(results[c].holdout_rmse)});
      if (best < 0 || mean_square(results[c].holdout_rmse) < mean_square(results[best].holdout_rmse)) {
        best = static_cast<int>(c);
      }
    }
    const double gain =
        best >= 0 ? mean_square(selection.model.holdout_rmse) - mean_square(results[best].holdout_rmse) : 0.0;
    const double z = best >= 0 ? paired_difference(data.check, selection.model.check_prediction,
                                                   results[best].check_prediction, data.options.batch_rows)
                                     .z
                               : 0.0;
    if (best < 0 || gain <= data.threshold_deg2 || z <= data.options.paired_z) {
      step.note = "stop: best held-out gain " + std::to_string(gain / data.threshold_deg2) +
                  " x the threshold, paired z " + std::to_string(z);
      selection.steps.push_back(step);
      break;
    }
    step.chosen = index_of(candidates[best]);
    selection.steps.push_back(step);
    selection.families.set(step.chosen);
    selection.order.push_back(candidates[best]);
    selection.forward_path.push_back(results[best]);
    selection.model = results[best];
    selection.theta = results[best].fit.theta;
    fit_prediction = predict_recording(to_effect_set(selection.theta, selection.families), data.fit).alpha_deg;
  }
}

// A transmission ripple picked early can have locked onto another effect's trend (a long period
// standing in for an arm length). If the model misses the floor, restart the ripple from the
// residual of the model without it, from both starts, and keep what CHECK prefers.
void restart_ripple(const PipelineData& data, Selection& selection) {
  const FamilySet ripple = single(Family::transmission_error);
  if (!(selection.families & ripple).any() || near_floor(selection.model, data.options)) return;
  const FamilySet without = selection.families & ~ripple;
  const Parameters base = without_families(selection.theta, ripple);
  const std::vector<Vec3> prediction = predict_recording(to_effect_set(base, without), data.fit).alpha_deg;
  std::vector<Job> jobs;
  for (bool long_period : {false, true}) {
    const Parameters start = initial_guess(Family::transmission_error, base, data.fit, prediction, long_period);
    const FamilySet families = selection.families;
    jobs.push_back([&data, families, start] { return fit_and_check(data, families, start); });
  }
  for (const Candidate& restarted : run_parallel(jobs, data.options.threads)) {
    if (restarted.ok && mean_square(restarted.holdout_rmse) < mean_square(selection.model.holdout_rmse)) {
      selection.model = restarted;
      selection.theta = restarted.fit.theta;
      selection.path_changed = true;
    }
  }
}

// A ripple longer than a joint's travel on FIT is a smooth curve there, which geometry imitates: a
// greedy path can end with the wrong geometry and a ripple of the wrong period, above the floor.
// Then the model of every family (backlash only if chosen) is fitted with the ripple's period
// profiled: held at 0.5-4 x each joint's travel on FIT, per joint the period best on CHECK, the
// three held together, then everything free. If that beats the selection on CHECK by the
// threshold and is near the floor, it replaces it; from then on every fit holds the periods found
// (along that valley FIT alone moves a joint's held-out error by 0.2 floors and more, so that two
// sets could not be compared), and eliminate_breadth_first takes the model down to what CHECK
// needs. Drags only: closed-loop telemetry (a small region, the controller's own errors) is left to
// the greedy path.
bool try_every_family_with_long_ripples(const PipelineData& data, Selection& selection) {
  if (data.fit_closed_loop || near_floor(selection.model, data.options)) return false;
  const FamilySet ripple = single(Family::transmission_error);
  FamilySet every;
  for (int f = 0; f < kFamilyCount; ++f) {
    if (family_at(f) != Family::backlash || selection.families[f]) every.set(f);
  }
  const Candidate geometry = fit_and_check(data, every & ~ripple, without_families(selection.theta, ripple));
  if (!geometry.ok) return false;
  const std::vector<Vec3> prediction =
      predict_recording(to_effect_set(geometry.fit.theta, every & ~ripple), data.fit).alpha_deg;
  Vec3 low = Vec3::Constant(1e9), high = Vec3::Constant(-1e9);
  for (const Vec3& a : prediction) {
    low = low.cwiseMin(a);
    high = high.cwiseMax(a);
  }
  const Vec3 travel = (high - low).cwiseMax(1e-3);
  std::vector<Job> jobs;
  for (double multiple : {0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0}) {
    const Parameters start = ripple_start_at(geometry.fit.theta, data.fit, prediction, multiple * travel);
    jobs.push_back([&data, every, start] { return fit_and_check(data, every, start, Periods::held); });
  }
  const std::vector<Candidate> held = run_parallel(jobs, data.options.threads);
  Parameters start = geometry.fit.theta;
  for (int j = 0; j < 3; ++j) {
    int best = -1;
    for (std::size_t r = 0; r < held.size(); ++r) {
      if (held[r].ok && (best < 0 || held[r].holdout_rmse[j] < held[best].holdout_rmse[j])) best = static_cast<int>(r);
    }
    if (best < 0) return false;
    for (int first : {slot::amplitude, slot::period, slot::phase}) start[first + j] = held[best].fit.theta[first + j];
  }
  const Candidate together = fit_and_check(data, every, start, Periods::held);
  if (!together.ok) return false;
  const Candidate free = fit_and_check(data, every, together.fit.theta, Periods::long_valley);
  if (!free.ok || !near_floor(free, data.options) ||
      mean_square(free.holdout_rmse) + data.threshold_deg2 >= mean_square(selection.model.holdout_rmse)) {
    return false;
  }
  for (int f = 0; f < kFamilyCount; ++f) {
    if (every[f] && !selection.families[f]) selection.order.push_back(family_at(f));
  }
  selection.families = every;
  selection.model = free;
  selection.theta = free.fit.theta;
  selection.path_changed = true;
  return true;
}

// The floor test of a candidate on CHECK, with the noise model of `families` at `theta` on FIT.
bool passes_floor_test(const PipelineData& data, FamilySet families, const Parameters& theta,
                       const std::vector<Vec3>& check_prediction) {
  const std::vector<Vec3> fit_prediction = predict_recording(to_effect_set(theta, families), data.fit).alpha_deg;
  return floor_test(data.check, check_prediction, pipeline_noise_model(data, data.fit, fit_prediction), data.options)
      .at_floor;
}

// Backward elimination: drop a family whose removal costs less than the threshold on CHECK (an
// early pick that later picks made redundant). A model at the floor is never reduced to one the
// floor test refuses: a cost below the threshold can still be what keeps the residual at the
// floor (the encoder scales dropped from a model at the floor once left z 5.5).
void backward_elimination(const PipelineData& data, Selection& selection) {
  for (bool dropped = true; dropped && selection.families.count() > 1;) {
    dropped = false;
    const bool at_floor =
        passes_floor_test(data, selection.families, selection.theta, selection.model.check_prediction);
    const std::vector<Family> members = selection.order;
    std::vector<Job> jobs;
    for (Family family : members) {
      const FamilySet reduced = selection.families & ~single(family);
      const Parameters start = without_families(selection.theta, single(family));
      jobs.push_back([&data, reduced, start] { return fit_and_check(data, reduced, start); });
    }
    const std::vector<Candidate> results = run_parallel(jobs, data.options.threads);
    int weakest = -1;
    double weakest_cost = 0.0;
    for (std::size_t m = 0; m < members.size(); ++m) {
      if (!results[m].ok) continue;
      const double cost = mean_square(results[m].holdout_rmse) - mean_square(selection.model.holdout_rmse);
      if (cost <= data.threshold_deg2 && (weakest < 0 || cost < weakest_cost) &&
          (!at_floor || passes_floor_test(data, selection.families & ~single(members[m]), results[m].fit.theta,
                                          results[m].check_prediction))) {
        weakest = static_cast<int>(m);
        weakest_cost = cost;
      }
    }
    if (weakest >= 0) {
      selection.eliminated.push_back({members[weakest], "", ""});
      selection.families.reset(index_of(members[weakest]));
      selection.order.erase(std::find(selection.order.begin(), selection.order.end(), members[weakest]));
      selection.model = results[weakest];
      selection.theta = results[weakest].fit.theta;
      dropped = true;
    }
  }
}

// Below a model of every family (a long ripple, which the geometry families imitate on FIT): the
// families are dropped breadth-first, every set of one size from every kept set one larger, and a
// set is kept while CHECK holds it within the threshold of the model of every family (and at the
// floor, when that model is). The best `kEliminationBeam` of each size go on. The smallest sets kept are the data's
// equivalent answers: the best is the selection, the others its alternatives. A set with the ripple
// is fitted with its periods held where the model of every family put them; one that CHECK does not
// hold so is fitted once more with its periods free (from there) before it is refused: with fewer
// families beside it the ripple's period moves (drawn robot 19: 28.9 deg on joint 2, held at 34.2
// its own set is refused, freed it is the answer).
constexpr std::size_t kEliminationBeam = 6;

void eliminate_breadth_first(PipelineData& data, Selection& selection) {
  const double top_mse = mean_square(selection.model.holdout_rmse);
  const bool top_at_floor =
      passes_floor_test(data, selection.families, selection.theta, selection.model.check_prediction);
  std::vector<std::pair<FamilySet, Candidate>> level = {{selection.families, selection.model}};
  std::vector<std::pair<FamilySet, Candidate>> smallest = level;
  while (!level.empty()) {
    std::vector<FamilySet> sets;
    std::vector<Job> jobs;
    for (const auto& [families, model] : level) {
      if (families.count() <= 1) continue;
      for (int f = 0; f < kFamilyCount; ++f) {
        if (!families[f]) continue;
        const FamilySet reduced = families & ~single(family_at(f));
        if (std::find(sets.begin(), sets.end(), reduced) != sets.end()) continue;
        const Parameters start = without_families(model.fit.theta, single(family_at(f)));
        sets.push_back(reduced);
        jobs.push_back([&data, reduced, start] { return fit_and_check(data, reduced, start, Periods::held); });
      }
    }
    std::vector<Candidate> results = run_parallel(jobs, data.options.threads);
    const auto held_within = [&](const Candidate& c) {
      return c.ok && mean_square(c.holdout_rmse) <= top_mse + data.threshold_deg2;
    };
    std::vector<Job> freed;
    std::vector<std::size_t> refitted;
    for (std::size_t r = 0; r < results.size(); ++r) {
      if (!results[r].ok || held_within(results[r]) || !sets[r][index_of(Family::transmission_error)]) continue;
      const FamilySet reduced = sets[r];
      const Parameters start = results[r].fit.theta;
      refitted.push_back(r);
      freed.push_back([&data, reduced, start] { return fit_and_check(data, reduced, start, Periods::long_valley); });
    }
    const std::vector<Candidate> again = run_parallel(freed, data.options.threads);
    for (std::size_t k = 0; k < again.size(); ++k) {
      if (held_within(again[k])) results[refitted[k]] = again[k];
    }
    std::vector<std::pair<FamilySet, Candidate>> next;
    for (std::size_t r = 0; r < results.size(); ++r) {
      if (!held_within(results[r])) continue;
      if (top_at_floor && !passes_floor_test(data, sets[r], results[r].fit.theta, results[r].check_prediction))
        continue;
      next.push_back({sets[r], results[r]});
    }
    std::sort(next.begin(), next.end(), [](const auto& a, const auto& b) {
      return mean_square(a.second.holdout_rmse) < mean_square(b.second.holdout_rmse);
    });
    if (next.size() > kEliminationBeam) next.resize(kEliminationBeam);
    if (!next.empty()) smallest = next;
    level = std::move(next);
  }
  const auto& [families, model] = smallest.front();
  for (Family family : selection.order) {
    if (!families[index_of(family)]) selection.eliminated.push_back({family, "", ""});
  }
  std::vector<Family> kept;
  for (Family family : selection.order) {
    if (families[index_of(family)]) kept.push_back(family);
  }
  selection.order = kept;
  selection.families = families;
  selection.model = model;
  selection.theta = model.fit.theta;
  data.equivalent_sets.assign(smallest.begin() + 1, smallest.end());
}

// Swap search: a wrong early pick can absorb two true effects and end as a larger model at the
// floor (chain_angle + joint_offset read as frame_misalignment + radius_offset + joint_offset).
// When a model of three or four families reaches the floor, try each two-for-one swap and keep a
// smaller model that does as well on CHECK (within the threshold). Limited to three or four
// families: the search grows as k^2 (9 - k) fits.
void swap_search(const PipelineData& data, Selection& selection) {
  while (selection.families.count() >= 3 && selection.families.count() <= 4 &&
         near_floor(selection.model, data.options)) {
    std::vector<FamilySet> sets;
    std::vector<Job> jobs;
    const std::vector<Family>& order = selection.order;
    for (std::size_t a = 0; a < order.size(); ++a) {
      for (std::size_t b = a + 1; b < order.size(); ++b) {
        const FamilySet removed = single(order[a]) | single(order[b]);
        const FamilySet reduced = selection.families & ~removed;
        const Parameters reduced_theta = without_families(selection.theta, removed);
        const std::vector<Vec3> reduced_prediction =
            predict_recording(to_effect_set(reduced_theta, reduced), data.fit).alpha_deg;
        for (int f = 0; f < kFamilyCount; ++f) {
          if (selection.families[f]) continue;
          const Parameters start = initial_guess(family_at(f), reduced_theta, data.fit, reduced_prediction);
          const FamilySet families = reduced | single(family_at(f));
          sets.push_back(families);
          jobs.push_back([&data, families, start] { return fit_and_check(data, families, start); });
        }
      }
    }
    const std::vector<Candidate> results = run_parallel(jobs, data.options.threads);
    int best = -1;
    for (std::size_t r = 0; r < results.size(); ++r) {
      if (results[r].ok &&
          (best < 0 || mean_square(results[r].holdout_rmse) < mean_square(results[best].holdout_rmse))) {
        best = static_cast<int>(r);
      }
    }
    if (best < 0 ||
        mean_square(results[best].holdout_rmse) > mean_square(selection.model.holdout_rmse) + data.threshold_deg2) {
      break;
    }
    std::vector<Family> kept;
    for (Family family : order) {
      if (sets[best][index_of(family)])
        kept.push_back(family);
      else
        selection.eliminated.push_back({family, "", "swapped out"});
    }
    for (int f = 0; f < kFamilyCount; ++f) {
      if (sets[best][f] && !selection.families[f]) kept.push_back(family_at(f));
    }
    selection.order = kept;
    selection.families = sets[best];
    selection.model = results[best];
    selection.theta = results[best].fit.theta;
  }
}

// Forward selection can stop far above the floor after a first pick that takes a share of several
// effects and leaves none of them a significant gain alone (radius offsets picked before a 5 deg
// frame and joint offsets: 25 floors, no single family helps). Then the selection is run again
// from each of the next two first picks, and the path that ends lowest on CHECK (by more than the
// threshold) is kept.
void restart_from_runners_up(const PipelineData& data, Selection& selection) {
  if (near_floor(selection.model, data.options) || selection.order.empty()) return;
  std::vector<std::pair<Family, Candidate>> first = selection.first_round;
  std::sort(first.begin(), first.end(), [](const auto& a, const auto& b) {
    return mean_square(a.second.holdout_rmse) < mean_square(b.second.holdout_rmse);
  });
  const Family first_pick = selection.order.front();
  int tried = 0;
  for (const auto& [family, candidate] : first) {
    if (family == first_pick) continue;
    if (tried++ == 2) break;
    Selection other;
    other.families = single(family);
    other.order = {family};
    other.model = candidate;
    other.theta = candidate.fit.theta;
    other.forward_path = {candidate};
    other.first_round = selection.first_round;
    other.steps = {selection.steps.front()};
    other.steps.front().chosen = index_of(family);
    other.steps.front().note = "restarted from this first pick (the first path stopped far above the floor)";
    forward_selection(data, other);
    if (mean_square(other.model.holdout_rmse) + data.threshold_deg2 < mean_square(selection.model.holdout_rmse)) {
      for (Family dropped : selection.order) {
        if (!other.families[index_of(dropped)]) {
          other.eliminated.push_back({dropped, "", "a first path that stopped far above the floor"});
        }
      }
      other.path_changed = true;
      selection = std::move(other);
    }
  }
}

}  // namespace

Selection select_families(PipelineData& data, const Candidate& nominal) {
  Selection selection;
  selection.theta = neutral_parameters();
  selection.model = nominal;
  forward_selection(data, selection);
  restart_from_runners_up(data, selection);
  restart_ripple(data, selection);
  data.long_ripples = try_every_family_with_long_ripples(data, selection);
  if (data.long_ripples) {
    eliminate_breadth_first(data, selection);
  } else {
    backward_elimination(data, selection);
  }
  swap_search(data, selection);
  return selection;
}

}  // namespace delta::diagnosis
