// Small recordings of the virtual robot for the network tests (fast: a few thousand samples).
#pragma once

#include <string>
#include <vector>

#include "delta/effect_file.hpp"
#include "delta/recording.hpp"
#include "delta/virtual_robot.hpp"
#include "support/tree_paths.hpp"

namespace delta::nn::test {

// The shipped paper-like effect set of the lead (sim/paper_like_effects.json).
inline EffectSet paper_like_effects() {
  return read_effect_file(std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json");
}

// `samples` samples spread over the whole trajectory (the rate is scaled down to cover it).
inline std::vector<Sample> record(const std::string& experiment, const EffectSet& effects, std::size_t samples,
                                  std::uint64_t seed = 1) {
  const Trajectory trajectory = make_trajectory(experiment, seed);
  RecordingOptions options;
  options.samples = samples;
  options.rate_hz = trajectory.rate_hz * static_cast<double>(samples) / static_cast<double>(trajectory.samples);
  options.seed = seed;
  return VirtualRobot(effects).record(trajectory, options).samples;
}

inline Recording as_recording(const std::vector<Sample>& samples, const std::string& path) {
  Recording recording{path, samples, {}};
  for (std::size_t i = 0; i < samples.size(); ++i) recording.line_numbers.push_back(i + 2);
  return recording;
}

}  // namespace delta::nn::test
