// deltactl joint-loop: double and fixed-point joint controllers side by side on the single-joint plant.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/control/closed_loop.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/plot.hpp"
#include "delta/table.hpp"
#include "options.hpp"

namespace delta::control {
namespace {

struct JointLoopOptions {
  std::string plot;
  double load_step_nm = 0.03;
};

constexpr double kResolutionDeg = 0.01;
constexpr double kBlendS = 1.0;

const char* kind_name(ControllerKind kind) { return kind == ControllerKind::double_precision ? "double" : "fixed"; }

std::string percent(double part, double whole) { return fixed(100.0 * part / whole, 3) + " %"; }

struct StepResult {
  double peak_counts = 0.0;
  double after_counts = 0.0;
  LoopTrace trace;
};

StepResult run_load_step(ControllerKind kind, bool disturbance_observer, double step_nm) {
  golden::JointControllerParameters controller;
  controller.disturbance_observer = disturbance_observer;
  LoopScenario scenario;
  const double target = 30.005;  // mid-count
  scenario.reference_shaft_deg = [target](double) { return target; };
  scenario.initial_shaft_deg = target;
  scenario.duration_s = 2.0;
  scenario.load_step_time_s = 1.5;
  scenario.load_step_shaft_nm = step_nm;
  StepResult result;
  result.trace = run_loop(kind, controller, default_plant(), scenario);
  for (std::size_t i = 0; i < result.trace.t_s.size(); ++i) {
    const double error = std::abs(result.trace.encoder_count[i] - target / kResolutionDeg);
    if (result.trace.t_s[i] >= 1.5) result.peak_counts = std::max(result.peak_counts, error);
    if (result.trace.t_s[i] >= 1.55) result.after_counts = std::max(result.after_counts, error);
  }
  return result;
}

PlotSeries series(const std::string& label, const LoopTrace& trace, double from_s,
                  const std::function<double(std::size_t)>& value) {
  PlotSeries out{label, {}, {}, false};
  for (std::size_t i = 0; i < trace.t_s.size(); i += 10) {  // 1 kHz is plenty for a plot
    if (trace.t_s[i] < from_s) continue;
    out.x.push_back(trace.t_s[i]);
    out.y.push_back(value(i));
  }
  return out;
}

void run_joint_loop(const JointLoopOptions& options) {
  const golden::JointControllerParameters controller;
  bool pass = true;
  std::cout << "Experiment 1 (0.2 Hz, nominal IK), smooth start over " << kBlendS
            << " s, errors from t = 1 s to 11 s (encoder reading - reference):\n\n";
  Table tracking({"joint", "p-p [deg]", "max error double [% p-p]", "max error fixed [% p-p]", "fixed vs double (max)",
                  "rms double [deg]", "rms fixed [deg]", "fixed vs double (rms)", "saturations"});
  PlotPanel errors{"Experiment 1 tracking error (encoder - reference)", "t [s]", "error [deg]", {}, false};
  for (int joint = 0; joint < 3; ++joint) {
    LoopScenario scenario;
    scenario.reference_shaft_deg = experiment1_joint_reference(joint, kBlendS);
    scenario.initial_shaft_deg = scenario.reference_shaft_deg(0.0);
    scenario.duration_s = 11.0;
    TrackingStats stats[2];
    for (const ControllerKind kind : {ControllerKind::double_precision, ControllerKind::fixed_point}) {
      const LoopTrace trace = run_loop(kind, controller, default_plant(), scenario);
      stats[kind == ControllerKind::fixed_point] = tracking_stats(trace, kBlendS, kResolutionDeg);
      if (kind == ControllerKind::fixed_point && trace.overflow_count != 0) pass = false;
      errors.series.push_back(
          series("alpha" + std::to_string(joint + 1) + " " + kind_name(kind), trace, 0.0,
                 [&trace](std::size_t i) { return trace.encoder_count[i] * kResolutionDeg - trace.reference_deg[i]; }));
      if (kind == ControllerKind::fixed_point) {
        tracking.add_row({"alpha_" + std::to_string(joint + 1), fixed(stats[0].peak_to_peak_deg, 4),
                          percent(stats[0].max_abs_error_deg, stats[0].peak_to_peak_deg),
                          percent(stats[1].max_abs_error_deg, stats[1].peak_to_peak_deg),
                          percent(stats[1].max_abs_error_deg - stats[0].max_abs_error_deg, stats[0].max_abs_error_deg),
                          fixed(stats[0].rms_error_deg, 5), fixed(stats[1].rms_error_deg, 5),
                          percent(stats[1].rms_error_deg - stats[0].rms_error_deg, stats[0].rms_error_deg),
                          std::to_string(trace.overflow_count)});
      }
    }
    for (const TrackingStats& s : stats) pass = pass && s.max_abs_error_deg <= 0.011 * s.peak_to_peak_deg;
    pass =
        pass && std::abs(stats[1].max_abs_error_deg - stats[0].max_abs_error_deg) <= 0.05 * stats[0].max_abs_error_deg;
  }
  tracking.print(std::cout);

  std::cout << "\nStandstill (gravity + Coulomb friction, start 30 counts off), encoder span over t = 1..3 s:\n\n";
  Table standstill({"reference [deg]", "span double [counts]", "span fixed [counts]"});
  for (const double target : {30.0, 30.005, 30.0037, -12.3421}) {
    std::vector<std::string> row{fixed(target, 4)};
    for (const ControllerKind kind : {ControllerKind::double_precision, ControllerKind::fixed_point}) {
      LoopScenario scenario;
      scenario.reference_shaft_deg = [target](double) { return target; };
      scenario.initial_shaft_deg = target - 0.3;
      scenario.duration_s = 3.0;
      const TrackingStats settled =
          tracking_stats(run_loop(kind, controller, default_plant(), scenario), 1.0, kResolutionDeg);
      row.push_back(std::to_string(settled.encoder_span_counts));
      pass = pass && settled.encoder_span_counts <= 1;
    }
    standstill.add_row(row);
  }
  standstill.print(std::cout);

  std::cout << "\nLoad-torque step of " << options.load_step_nm
            << " N m on the shaft at t = 1.5 s, reference 30.005 deg (|encoder - reference| in counts):\n\n";
  Table step({"controller", "DOB", "peak [counts]", "max from 50 ms on [counts]"});
  PlotPanel step_panel{"Load step at t = 1.5 s", "t [s]", "encoder - reference [counts]", {}, false};
  for (const ControllerKind kind : {ControllerKind::double_precision, ControllerKind::fixed_point}) {
    for (const bool dob : {true, false}) {
      const StepResult result = run_load_step(kind, dob, options.load_step_nm);
      step.add_row({kind_name(kind), dob ? "on" : "off", fixed(result.peak_counts, 1), fixed(result.after_counts, 1)});
      pass = pass && (dob ? result.after_counts <= 2.0 : result.after_counts > 2.0);
      const LoopTrace& trace = result.trace;
      step_panel.series.push_back(
          series(std::string(kind_name(kind)) + (dob ? " with DOB" : " without DOB"), trace, 1.4,
                 [&trace](std::size_t i) { return trace.encoder_count[i] - 30.005 / kResolutionDeg; }));
    }
  }
  step.print(std::cout);

  if (!options.plot.empty()) {
    PlotSpec spec;
    spec.title = "Joint controller: double vs fixed point on the single-joint plant";
    spec.panels = {errors, step_panel};
    write_plot(options.plot, spec);
    std::cout << "\nplot: " << options.plot << '\n';
  }
  std::cout << "\nacceptance (1.1 % of p-p, fixed within 5 % of double, span <= 1 count, DOB step): "
            << (pass ? "pass" : "FAIL") << '\n';
  if (!pass) throw CommandExit{kExitFailure};
}

const RegisterCommand command("joint-loop", 60, [](CLI::App& root) {
  auto options = std::make_shared<JointLoopOptions>();
  CLI::App* sub = root.add_subcommand("joint-loop",
                                      "Joint controller closed loop: double vs fixed point on the single-joint plant");
  sub->footer(
      "\nRuns the per-joint acceleration controller (reference filter, VOB, DOB, the paper's eq. 5) in\n"
      "double precision and in the fixed-point golden model (bit-identical to the HLS top and the RTL)\n"
      "on the same single-joint plant (Faulhaber-like motor, 66:1 gearbox, friction, gravity, 0.01 deg\n"
      "encoder), and prints: experiment 1 tracking per joint, standstill limit cycles, and the\n"
      "rejection of a load-torque step with and without the DOB. Exit code 1 if an acceptance bound\n"
      "fails. Plant and design figures: hls/README.md, \"Joint controller fixed-point formats\".\n"
      "Example: deltactl joint-loop --plot joint_loop.png");
  sub->add_option("--plot", options->plot, "PNG of the tracking errors and the load-step responses");
  sub->add_option("--load-step", options->load_step_nm,
                  "load-torque step on the shaft [N m]; the DOB-step bound (<= 2 counts) holds up to 0.03")
      ->capture_default_str()
      ->check(options::real_number(0.01, 0.03));
  sub->callback([options] { run_joint_loop(*options); });
});

}  // namespace
}  // namespace delta::control
