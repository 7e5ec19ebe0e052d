// A candidate model of the diagnosis: one family set fitted on FIT and scored on CHECK, and the
// data every step of the pipeline shares (internal to the diagnosis library).
#pragma once

#include <atomic>
#include <functional>
#include <thread>
#include <utility>
#include <vector>

#include "delta/diagnosis/diagnose.hpp"
#include "floor_test.hpp"

namespace delta::diagnosis {

struct Candidate {
  FitResult fit;
  Vec3 holdout_rmse = Vec3::Zero();
  std::vector<Vec3> check_prediction;  // per kept CHECK row
  bool ok = false;
};

// What every step sees: the cleaned recordings (outlier rows left out) and the options.
struct PipelineData {
  std::vector<Sample> fit;          // every FIT row kept
  std::vector<Sample> thinned_fit;  // every options.screening_stride-th of them
  std::vector<Sample> check;        // every CHECK row kept
  DiagnosisOptions options;
  double threshold_deg2 = 0.0;   // the stopping rule's minimum held-out MSE gain
  bool fit_closed_loop = false;  // FIT is closed-loop telemetry, its readings less their lead
  // A ripple longer than a joint's travel on FIT is in the model (selection.cpp): every later fit
  // holds the ripple's periods where the model of every family put them (Periods::held).
  bool long_ripples = false;
  // Where the model came down from every family (long ripples): each smallest subset that holds
  // CHECK at the floor, within the threshold of the larger model (selection.cpp), with its fit.
  std::vector<std::pair<FamilySet, Candidate>> equivalent_sets;
};

double mean_square(const Vec3& rmse);

// Every `stride`-th row: candidate models are screened on this thinner FIT set unless they
// contain backlash, whose hysteresis needs every row in time order.
std::vector<Sample> thin_out(const std::vector<Sample>& rows, std::size_t stride);

// The floor test's noise model for a model that predicts `fit_prediction` on `fit_rows` (the FIT
// rows kept, or those rows with their positions unscaled), at the pipeline's floor; closed-loop
// telemetry as FIT adds no noise of its own (floor_test.hpp).
NoiseModel pipeline_noise_model(const PipelineData& data, const std::vector<Sample>& fit_rows,
                                const std::vector<Vec3>& fit_prediction);

// How a fit treats the ripple's periods: as any parameter; held at their start values; or as any
// parameter, with the steps a ripple longer than the joint's travel needs (it trades its period
// against amplitude, phase and geometry along a long flat valley: 60-200 steps).
enum class Periods { usual, held, long_valley };
constexpr int kLongValleyIterations = 200;

// The options of every fit of the diagnosis (its noise floor and prior).
FitOptions fit_options(const DiagnosisOptions& options);
// ... for a fit in this pipeline: `periods` held or long_valley take kLongValleyIterations
// steps; once data.long_ripples is set, usual holds the periods too (with those steps).
FitOptions fit_options(const PipelineData& data, Periods periods = Periods::usual);

// Fits `families` from `start` (thinned FIT unless backlash is in the set) and predicts CHECK.
Candidate fit_and_check(const PipelineData& data, FamilySet families, const Parameters& start,
                        Periods periods = Periods::usual);

// `theta` with the parameters of `families` set back to neutral.
Parameters without_families(Parameters theta, FamilySet families);

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

using Job = std::function<Candidate()>;

}  // namespace delta::diagnosis
