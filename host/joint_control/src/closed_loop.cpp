// Closed-loop runs of one joint: controller update at Ts, plant integrated with the current held.
#include "delta/control/closed_loop.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "delta/control/joint_controller.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/kinematics.hpp"
#include "delta/trajectory.hpp"

namespace delta::control {

JointPlantParameters default_plant() {
  JointPlantParameters plant;
  plant.torque_constant_nm_per_a = 0.0194 * 0.95;  // K_T 5 % below the nominal value
  plant.rotor_inertia_kg_m2 = 1.1e-7;              // inertia 10 % above the nominal value
  return plant;
}

LoopTrace run_loop(ControllerKind kind, const golden::JointControllerParameters& controller,
                   const JointPlantParameters& plant_parameters, const LoopScenario& scenario) {
  JointPlant plant(plant_parameters, scenario.initial_shaft_deg);
  JointController double_controller(controller);
  const golden::JointFixedCoefficients coefficients = golden::make_fixed_coefficients(controller);
  golden::JointFixedState fixed_state;
  const double resolution = controller.encoder_resolution_deg;
  auto fixed_input = [&](double reference_deg, int count) {
    if (count < INT16_MIN || count > INT16_MAX) throw std::runtime_error("encoder count outside int16");
    return golden::JointFixedInput{golden::reference_code(reference_deg, resolution), static_cast<std::int16_t>(count)};
  };
  const double first_reference = scenario.reference_shaft_deg(0.0);
  double_controller.reset({first_reference, plant.encoder_count() * resolution});
  fixed_state = golden::fixed_rest_state(fixed_input(first_reference, plant.encoder_count()));

  LoopTrace trace;
  const auto periods = static_cast<long>(std::llround(scenario.duration_s / controller.period_s));
  for (long k = 0; k < periods; ++k) {
    const double t = k * controller.period_s;
    const double reference = scenario.reference_shaft_deg(t);
    const int count = plant.encoder_count();
    double current = 0.0;
    if (kind == ControllerKind::double_precision) {
      const JointOutput output = double_controller.update({reference, count * resolution});
      current = output.current_a;
      trace.limited_periods += output.limited;
    } else {
      golden::JointFixedStatus status;
      current = golden::current_from_code(
          golden::fixed_update(coefficients, fixed_state, fixed_input(reference, count), status));
      trace.limited_periods += status.limited;
      trace.overflow_count += status.overflow_count;
    }
    trace.t_s.push_back(t);
    trace.reference_deg.push_back(reference);
    trace.angle_deg.push_back(plant.shaft_angle_deg());
    trace.encoder_count.push_back(count);
    trace.current_a.push_back(current);
    const bool loaded = scenario.load_step_time_s >= 0.0 && t >= scenario.load_step_time_s;
    plant.step(current, controller.period_s, loaded ? scenario.load_step_shaft_nm : 0.0);
  }
  return trace;
}

std::function<double(double)> experiment1_joint_reference(int joint, double blend_s) {
  const Trajectory trajectory = make_trajectory("experiment1");
  const Geometry geometry = Geometry::nominal();
  auto angle = [trajectory, geometry, joint](double t) {
    const IkSolution solution = inverse_kinematics(geometry, trajectory.position_m(t));
    if (!solution.ok()) throw std::runtime_error("experiment 1 unreachable: " + solution.reason());
    return solution.alpha_deg[joint];
  };
  const double start = angle(0.0);
  return [angle, start, blend_s](double t) {
    if (t >= blend_s) return angle(t);
    return start + quintic_blend(t / blend_s) * (angle(t) - start);
  };
}

TrackingStats tracking_stats(const LoopTrace& trace, double from_s, double resolution_deg) {
  TrackingStats stats;
  double low = INFINITY, high = -INFINITY, square_sum = 0.0;
  int count_low = INT32_MAX, count_high = INT32_MIN;
  long n = 0;
  for (std::size_t i = 0; i < trace.t_s.size(); ++i) {
    if (trace.t_s[i] < from_s) continue;
    low = std::min(low, trace.reference_deg[i]);
    high = std::max(high, trace.reference_deg[i]);
    const double error = trace.encoder_count[i] * resolution_deg - trace.reference_deg[i];
    stats.max_abs_error_deg = std::max(stats.max_abs_error_deg, std::abs(error));
    stats.max_abs_true_error_deg =
        std::max(stats.max_abs_true_error_deg, std::abs(trace.angle_deg[i] - trace.reference_deg[i]));
    square_sum += error * error;
    count_low = std::min(count_low, trace.encoder_count[i]);
    count_high = std::max(count_high, trace.encoder_count[i]);
    ++n;
  }
  if (n == 0) throw std::invalid_argument("tracking_stats: no samples after from_s");
  stats.peak_to_peak_deg = high - low;
  stats.rms_error_deg = std::sqrt(square_sum / n);
  stats.encoder_span_counts = count_high - count_low;
  return stats;
}

}  // namespace delta::control
