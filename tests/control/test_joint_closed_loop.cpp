// Closed loop on the single-joint plant: tracking (paper's experiment 1), standstill, load step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "delta/control/closed_loop.hpp"

namespace delta::control {
namespace {

constexpr double kResolutionDeg = 0.01;

// Paper: after a smooth start the error stays within 1.1 % of the peak-to-peak reference; the
// fixed-point controller must be within 5 % of the double one (max and RMS error).
TEST(JointClosedLoop, Experiment1TrackingWithinPaperBoundAndFixedWithinFivePercentOfDouble) {
  const golden::JointControllerParameters controller;
  for (int joint = 0; joint < 3; ++joint) {
    LoopScenario scenario;
    scenario.reference_shaft_deg = experiment1_joint_reference(joint, 1.0);
    scenario.initial_shaft_deg = scenario.reference_shaft_deg(0.0);
    scenario.duration_s = 11.0;  // 1 s blend, then two periods of 0.2 Hz
    const TrackingStats reference = tracking_stats(
        run_loop(ControllerKind::double_precision, controller, default_plant(), scenario), 1.0, kResolutionDeg);
    const LoopTrace fixed_trace = run_loop(ControllerKind::fixed_point, controller, default_plant(), scenario);
    const TrackingStats fixed = tracking_stats(fixed_trace, 1.0, kResolutionDeg);
    std::cout << "joint " << joint + 1 << ": p-p " << reference.peak_to_peak_deg << " deg, max error double "
              << reference.max_abs_error_deg << " fixed " << fixed.max_abs_error_deg << " deg, rms double "
              << reference.rms_error_deg << " fixed " << fixed.rms_error_deg << "\n";
    EXPECT_LE(reference.max_abs_error_deg, 0.011 * reference.peak_to_peak_deg) << "joint " << joint;
    EXPECT_LE(fixed.max_abs_error_deg, 0.011 * fixed.peak_to_peak_deg) << "joint " << joint;
    EXPECT_LE(std::abs(fixed.max_abs_error_deg - reference.max_abs_error_deg), 0.05 * reference.max_abs_error_deg)
        << "joint " << joint;
    EXPECT_LE(std::abs(fixed.rms_error_deg - reference.rms_error_deg), 0.05 * reference.rms_error_deg)
        << "joint " << joint;
    EXPECT_EQ(fixed_trace.overflow_count, 0) << "joint " << joint;
  }
}

// At standstill with gravity and Coulomb friction, after settling, the encoder may toggle
// between two adjacent counts but no more (a limit cycle of at most one count).
TEST(JointClosedLoop, NoLimitCycleLargerThanOneCountAtStandstill) {
  const golden::JointControllerParameters controller;
  for (const double target : {30.0, 30.005, 30.0037, -12.3421}) {
    for (const ControllerKind kind : {ControllerKind::double_precision, ControllerKind::fixed_point}) {
      LoopScenario scenario;
      scenario.reference_shaft_deg = [target](double) { return target; };
      scenario.initial_shaft_deg = target - 0.3;  // starts 30 counts away
      scenario.duration_s = 3.0;
      const LoopTrace trace = run_loop(kind, controller, default_plant(), scenario);
      const TrackingStats settled = tracking_stats(trace, 1.0, kResolutionDeg);
      EXPECT_LE(settled.encoder_span_counts, 1) << "target " << target << " kind " << static_cast<int>(kind);
      EXPECT_LE(settled.max_abs_error_deg, 2.0 * kResolutionDeg) << "target " << target;
    }
  }
}

struct StepResponse {
  double peak_counts = 0.0;   // largest |encoder - reference| after the step
  double after_counts = 0.0;  // largest |encoder - reference| from 50 ms after the step on
};

StepResponse load_step(ControllerKind kind, bool disturbance_observer) {
  golden::JointControllerParameters controller;
  controller.disturbance_observer = disturbance_observer;
  LoopScenario scenario;
  const double target = 30.005;  // mid-count: the encoder error at rest is +-0.5 count
  scenario.reference_shaft_deg = [target](double) { return target; };
  scenario.initial_shaft_deg = target;
  scenario.duration_s = 2.0;
  scenario.load_step_time_s = 1.5;
  scenario.load_step_shaft_nm = 0.03;  // 5 x the gravity amplitude, 2.3 x the Coulomb friction
  const LoopTrace trace = run_loop(kind, controller, default_plant(), scenario);
  StepResponse response;
  for (std::size_t i = 0; i < trace.t_s.size(); ++i) {
    const double error = std::abs(trace.encoder_count[i] - target / kResolutionDeg);
    if (trace.t_s[i] >= scenario.load_step_time_s) response.peak_counts = std::max(response.peak_counts, error);
    if (trace.t_s[i] >= scenario.load_step_time_s + 0.05) {
      response.after_counts = std::max(response.after_counts, error);
    }
  }
  return response;
}

// A load-torque step is rejected by the DOB: within 2 counts from 50 ms after the step on; the
// same loop without the DOB is still far off.
TEST(JointClosedLoop, LoadStepRejectedWithinTwoCountsIn50MsByTheDobOnly) {
  for (const ControllerKind kind : {ControllerKind::double_precision, ControllerKind::fixed_point}) {
    const StepResponse with_dob = load_step(kind, true);
    const StepResponse without_dob = load_step(kind, false);
    std::cout << (kind == ControllerKind::fixed_point ? "fixed" : "double") << ": with DOB peak "
              << with_dob.peak_counts << " counts, after 50 ms " << with_dob.after_counts << "; without DOB peak "
              << without_dob.peak_counts << ", after 50 ms " << without_dob.after_counts << "\n";
    EXPECT_LE(with_dob.after_counts, 2.0);
    EXPECT_GT(without_dob.after_counts, 2.0);
  }
}

}  // namespace
}  // namespace delta::control
