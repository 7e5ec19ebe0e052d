// deltactl simulate: record a trajectory on the virtual robot, in the SPEC recording format.
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/effect_file.hpp"
#include "delta/recording.hpp"
#include "delta/virtual_robot.hpp"
#include "options.hpp"

namespace delta {
namespace {

struct SimulateOptions {
  std::string experiment = "validation";
  std::string effects;
  std::uint64_t seed = 1;
  std::string out;
  std::size_t samples = 0;
  double rate_hz = 0.0;
  double noise_deg = 0.0;
};

void run_simulate(const SimulateOptions& options) {
  const EffectSet effects = options.effects.empty() ? EffectSet{} : read_effect_file(options.effects);
  const Trajectory trajectory = make_trajectory(options.experiment, options.seed);
  RecordingOptions recording_options;
  recording_options.samples = options.samples;
  recording_options.rate_hz = options.rate_hz;
  recording_options.angle_noise_deg = options.noise_deg;
  recording_options.seed = options.seed;
  const VirtualRobot robot(effects);
  const SimulationReport report = robot.record(trajectory, recording_options);
  if (report.unreachable) {
    std::cerr << "deltactl: error: " << (options.effects.empty() ? std::string("nominal robot") : options.effects)
              << ": " << report.unreachable << " poses of '" << options.experiment
              << "' are unreachable for this robot, first at " << report.first_unreachable << '\n';
    throw CommandExit{kExitBadInput};
  }
  std::string effect_names;
  for (const std::string& name : effects.names()) effect_names += (effect_names.empty() ? "" : " ") + name;
  write_recording(options.out, report.samples,
                  {"deltactl simulate --experiment " + options.experiment + " --seed " + std::to_string(options.seed),
                   "effects: " + (effect_names.empty() ? std::string("none") : effect_names) +
                       (options.effects.empty() ? "" : " (" + options.effects + ")"),
                   // The virtual robot's encoders read the home count at its home switches.
                   referencing_comment(Referencing::kHomeSwitches)});
  std::cerr << "simulate: " << report.samples.size() << " samples of '" << options.experiment << "' -> " << options.out
            << '\n';
}

const RegisterCommand command("simulate", 10, [](CLI::App& root) {
  auto options = std::make_shared<SimulateOptions>();
  std::string catalogue;
  for (const auto& [name, summary] : trajectory_catalogue()) catalogue += "\n  " + name + ": " + summary;
  CLI::App* sub = root.add_subcommand("simulate", "Record a trajectory on the virtual robot (a recording CSV)");
  sub->footer("\nExperiments:" + catalogue +
              "\nThe virtual robot applies the effects of E.json (docs/contracts.md's vocabulary) in its order,\n"
              "then quantises angles to 0.01 deg and positions to 6.87 nm.\n"
              "Example: deltactl simulate --experiment validation --effects sim/paper_like_effects.json --out rec.csv");
  sub->add_option("--experiment", options->experiment, "trajectory to run")->capture_default_str();
  sub->add_option("--effects", options->effects, "effect file (JSON); none: the nominal robot");
  sub->add_option("--seed", options->seed, "seed for the sweep trajectory and angle noise")
      ->capture_default_str()
      ->check(options::seed());
  sub->add_option("--out", options->out, "recording to write")->required();
  sub->add_option("--samples", options->samples, "number of samples (0: the experiment's default)")
      ->check(options::whole_number(0, 1000000));
  sub->add_option("--rate", options->rate_hz, "sampling rate in Hz (0: the experiment's default)")
      ->check(options::real_number(0, 1e6));
  sub->add_option("--noise-deg", options->noise_deg, "extra white angle noise, standard deviation in deg")
      ->capture_default_str()
      ->check(options::real_number(0, 10));
  sub->callback([options] { run_simulate(*options); });
});

}  // namespace
}  // namespace delta
