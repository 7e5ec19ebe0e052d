// Closed loop of one joint controller (double or fixed point) on the single-joint plant.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "delta/golden/joint_parameters.hpp"
#include "delta/joint_plant.hpp"

namespace delta::control {

enum class ControllerKind { double_precision, fixed_point };

struct LoopScenario {
  std::function<double(double t_s)> reference_shaft_deg;  // must be smooth where the loop runs
  double initial_shaft_deg = 0.0;                         // plant at rest here at t = 0
  double duration_s = 1.0;
  double load_step_time_s = -1.0;  // extra shaft load torque switched on at this time (< 0: none)
  double load_step_shaft_nm = 0.0;
};

struct LoopTrace {
  std::vector<double> t_s;
  std::vector<double> reference_deg;  // shaft
  std::vector<double> angle_deg;      // true shaft angle
  std::vector<int> encoder_count;
  std::vector<double> current_a;
  int limited_periods = 0;  // periods in which the current limit clipped the command
  int overflow_count = 0;   // fixed point only: saturated operands and states
};

LoopTrace run_loop(ControllerKind kind, const golden::JointControllerParameters& controller,
                   const JointPlantParameters& plant, const LoopScenario& scenario);

// Shaft reference of joint `joint` (0-based) along the paper's experiment 1 (nominal inverse
// kinematics), reached from rest at its t = 0 value by a quintic blend over `blend_s` seconds.
std::function<double(double)> experiment1_joint_reference(int joint, double blend_s);

// Statistics of a trace from time `from_s` on; errors are measured - reference, shaft side.
struct TrackingStats {
  double peak_to_peak_deg = 0.0;   // of the reference
  double max_abs_error_deg = 0.0;  // encoder reading (what the paper's plots show)
  double rms_error_deg = 0.0;
  double max_abs_true_error_deg = 0.0;  // true shaft angle
  int encoder_span_counts = 0;          // max - min encoder count
};
TrackingStats tracking_stats(const LoopTrace& trace, double from_s, double resolution_deg);

// Plant figures matching the controller's nominal ones except for deliberate model errors.
JointPlantParameters default_plant();

}  // namespace delta::control
