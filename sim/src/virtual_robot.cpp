// The virtual robot: true plate position -> true IK -> sensor chain -> quantised recording.
#include "delta/virtual_robot.hpp"

#include <random>

#include "delta/kinematics.hpp"

namespace delta {

VirtualRobot::VirtualRobot(const EffectSet& effects, const Geometry& nominal)
    : effects_(effects), true_geometry_(apply_geometry_effects(nominal, effects)) {}

SimulationReport VirtualRobot::record(const Trajectory& trajectory, const RecordingOptions& options) const {
  SimulationReport report;
  const std::size_t count = options.samples ? options.samples : trajectory.samples;
  const double rate = options.rate_hz > 0.0 ? options.rate_hz : trajectory.rate_hz;
  JointSensorChain sensors(effects_);
  std::mt19937_64 generator(options.seed);
  std::normal_distribution<double> noise(0.0, options.angle_noise_deg);
  report.samples.reserve(count);
  const StageFrame stage_frame(effects_);
  for (std::size_t i = 0; i < count; ++i) {
    const double t = static_cast<double>(i) / rate;
    const Vec3 true_position = trajectory.position_m(t);
    const IkSolution ik = inverse_kinematics(true_geometry_, true_position);
    if (!ik.ok()) {
      if (report.unreachable++ == 0) report.first_unreachable = "t = " + std::to_string(t) + " s: " + ik.reason();
      continue;
    }
    Sample sample;
    sample.t_s = t;
    sample.alpha_deg = sensors.update(ik.alpha_deg);
    sample.position_m = stage_frame(true_position);
    for (int j = 0; j < 3; ++j) {
      if (options.angle_noise_deg > 0.0) sample.alpha_deg[j] += noise(generator);
      if (options.quantise) {
        sample.alpha_deg[j] = quantise(sample.alpha_deg[j], kEncoderResolutionDeg);
        sample.position_m[j] = quantise(sample.position_m[j], kStageResolutionM);
      }
    }
    report.samples.push_back(sample);
  }
  return report;
}

}  // namespace delta
