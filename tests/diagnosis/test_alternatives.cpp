// Tests of the search for the sets CHECK cannot tell from the chosen one, and of those it tells
// better (internal to the diagnosis library: alternatives.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

#include "alternatives.hpp"
#include "candidate.hpp"
#include "delta/trajectory.hpp"
#include "delta/virtual_robot.hpp"

namespace delta::diagnosis {
namespace {

std::vector<Sample> record(const EffectSet& effects, const std::string& trajectory, std::uint64_t seed) {
  RecordingOptions options;
  options.samples = 6000;
  options.seed = seed;
  return VirtualRobot(effects).record(make_trajectory(trajectory, seed), options).samples;
}

// The chosen set with one more family that CHECK sees significantly better is listed (and
// diagnose then adopts it) whatever the size of its gain: the selection's own fit of that set
// starts from the family's initial guess and can land elsewhere along a valley FIT cannot fix (a
// closed-loop run's few millimetres, where joint zeros trade with the frame's translation and the
// radii), so a gain above the stopping rule's minimum effect is no proof that the selection saw it.
TEST(Alternatives, TheChosenSetWithAFamilyCheckSeesSignificantlyBetterIsListed) {
  EffectSet robot;
  robot.joint_offset_deg = Vec3(0.25, 0.55, -0.35);
  FrameMisalignment frame;
  frame.rotation_deg = Vec3(-0.25, 0.1, 1.7);
  frame.translation_m = Vec3(0.1e-3, 0.3e-3, -0.2e-3);
  robot.frame_misalignment = frame;
  PipelineData data;
  data.fit = record(robot, "validation", 7);
  data.thinned_fit = thin_out(data.fit, data.options.screening_stride);
  data.check = record(robot, "sweep", 8);
  data.threshold_deg2 = data.options.significance * data.options.noise_floor_deg * data.options.noise_floor_deg;

  const FamilySet chosen = single(Family::frame_misalignment);
  const Candidate frame_only = fit_and_check(data, chosen, neutral_parameters());
  ASSERT_TRUE(frame_only.ok);
  const std::vector<Vec3> fit_prediction =
      predict_recording(to_effect_set(frame_only.fit.theta, chosen), data.fit).alpha_deg;
  const NoiseModel noise = pipeline_noise_model(data, data.fit, fit_prediction);
  const std::vector<Alternative> alternatives =
      find_alternatives(data, chosen, frame_only.fit.theta, frame_only.check_prediction, noise, false);

  const FamilySet robots = chosen | single(Family::joint_offset);
  const auto listed = std::find_if(alternatives.begin(), alternatives.end(),
                                   [&](const Alternative& a) { return a.families == robots; });
  for (const Alternative& a : alternatives) {
    std::cout << describe(a.families) << ": paired z " << a.paired_z << ", MSE difference " << a.mse_difference_deg2
              << " deg^2, at the floor " << a.at_floor << '\n';
  }
  ASSERT_NE(listed, alternatives.end()) << "the robot's set is not listed";
  EXPECT_LT(listed->paired_z, -data.options.paired_z);
  EXPECT_LT(listed->mse_difference_deg2, -data.threshold_deg2) << "a gain above the minimum effect";
  EXPECT_TRUE(listed->at_floor);
}

}  // namespace
}  // namespace delta::diagnosis
