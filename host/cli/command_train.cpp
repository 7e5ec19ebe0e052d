// deltactl train: fit the inverse-kinematics model (deployed by default, or the plain network, or the
// hybrid) to a recording -> W.json.
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/nn/model_training.hpp"
#include "delta/output_file.hpp"
#include "delta/table.hpp"
#include "options.hpp"
#include "training_options.hpp"

namespace delta::nn {
namespace {

struct TrainOptions {
  std::string data;
  std::string out;
  std::string model = "deployed";
  TrainingOptions training;
  bool unreferenced = false;  // take a recording whose counts were not referenced at the home switches
};

// A high-rate recording (the host's 1 kHz telemetry merged with a stage, deltactl merge) is thinned
// evenly to this many rows: neighbouring rows of a slow motion add little, and the time order the
// play is identified in is kept.
constexpr std::size_t kMaxTrainingRows = 20000;

// The deployed network on the rows it learnt from, per joint in encoder floors; a joint left above
// kStallFloors is named, with the ripple the math model leaves on it when that ripple is as large
// as what the network adds to the encoder's noise (then the network left it, or part of it).
void report_floors(const ModelTraining& result, int hidden) {
  const Vec3 floors = result.recording_rmse_deg / result.floor_deg;
  const JointRippleTable& table = result.weights.joint_ripple;
  if (!table.empty()) {
    std::cerr << "train: joint ripple table: the math model leaves";
    for (std::size_t j = 0; j < 3; ++j) {
      const ResidualRipple& ripple = result.ripple[j];
      std::cerr << (j ? ";" : "") << " joint " << j + 1 << ' ' << fixed(ripple.rms_deg, 4) << " deg RMS";
      if (ripple.period_deg > 0.0) std::cerr << " (period near " << fixed(ripple.period_deg, 1) << " deg)";
    }
    std::cerr << "; " << table.values_deg[0].size() + table.values_deg[1].size() + table.values_deg[2].size()
              << " entries of " << format_number(table.bin_deg)
              << " deg: the host shapes each setpoint so the board's network answers with it\n";
  }
  std::cerr << "train: the deployed " << (table.empty() ? "network" : "model (network + joint ripple table)")
            << " on the recording (its angles without the play): " << fixed(floors[0], 2) << " / "
            << fixed(floors[1], 2) << " / " << fixed(floors[2], 2) << " encoder floors per joint ("
            << fixed(result.floor_deg, 5) << " deg)\n";
  for (int j = 0; j < 3; ++j) {
    if (!(floors[j] > kStallFloors)) continue;
    const ResidualRipple& ripple = result.ripple[static_cast<std::size_t>(j)];
    std::cerr << "train: warning: joint " << j + 1 << " stays at " << fixed(floors[j], 2) << " encoder floors";
    const double beyond_noise_deg = result.floor_deg * std::sqrt(floors[j] * floors[j] - 1.0);
    if (table.empty() && ripple.rms_deg >= result.floor_deg && ripple.period_deg > 0.0 &&
        ripple.rms_deg >= beyond_noise_deg) {
      std::cerr << ": the math model leaves it a ripple of " << fixed(ripple.rms_deg, 4)
                << " deg RMS with a period near " << fixed(ripple.period_deg, 1) << " deg, too short for a 3-" << hidden
                << "-3 network across this workspace (docs/lab_loop.md); train with the default --ripple-table auto, "
                   "or expect about this error on the robot\n";
    } else {
      std::cerr
          << ": train again with another --seed or more --max-epochs, or on a drag that covers the workspace more "
             "evenly\n";
    }
  }
}

void run_train(const TrainOptions& options) {
  Recording recording = read_recording(options.data);
  check_referenced(recording, options.unreferenced);
  if (recording.samples.size() > kMaxTrainingRows) {
    const std::size_t stride = (recording.samples.size() + kMaxTrainingRows - 1) / kMaxTrainingRows;
    std::vector<Sample> kept;
    for (std::size_t i = 0; i < recording.samples.size(); i += stride) kept.push_back(recording.samples[i]);
    std::cerr << "train: " << recording.samples.size() << " rows thinned to every " << stride << "th (" << kept.size()
              << ")\n";
    recording.samples = std::move(kept);
    recording.line_numbers.clear();
  }
  OutputFile{options.out};  // an unwritable --out, or one that is the input, fails before training
  const auto start = std::chrono::steady_clock::now();
  const ModelTraining result = train_model(recording, options.model, options.training, [](const TrainingEpoch& epoch) {
    std::cerr << "train: " << describe_epoch(epoch) << '\n';
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  write_weights_file(options.out, result.weights);
  if (result.effect_fit) {
    const EffectFit& fit = *result.effect_fit;
    std::cerr << "train: math model fitted in " << fit.iterations << " iterations, RMSE per joint "
              << fixed(fit.rmse_before_deg[0], 4) << ' ' << fixed(fit.rmse_before_deg[1], 4) << ' '
              << fixed(fit.rmse_before_deg[2], 4) << " -> " << fixed(fit.rmse_after_deg[0], 4) << ' '
              << fixed(fit.rmse_after_deg[1], 4) << ' ' << fixed(fit.rmse_after_deg[2], 4) << " deg\n";
  }
  const TrainingResult& training = result.training;
  if (result.restart_seed) {
    std::cerr << "train: the first training stalled above " << kStallFloors << " encoder floors ("
              << fixed(result.floor_deg, 5) << " deg); restarted from seed " << *result.restart_seed << ", kept the "
              << (result.restart_kept ? "restart" : "first") << '\n';
  }
  if (result.weights.deployed() && result.floor_deg > 0.0) report_floors(result, options.training.hidden);
  std::cerr << "train: " << options.model << " 3-" << options.training.hidden << "-3 on " << training.training_samples
            << " samples (+" << training.validation_samples << " validation), " << training.epochs
            << " epochs, stopped by " << training.stop_reason << ", best epoch " << training.best_epoch
            << ", validation RMSE " << fixed(std::sqrt(training.validation_mse_deg2), 5) << " deg, "
            << fixed(seconds, 1) << " s -> " << options.out << '\n';
}

const RegisterCommand command("train", 40, [](CLI::App& root) {
  auto options = std::make_shared<TrainOptions>();
  CLI::App* sub = root.add_subcommand("train", "Train the inverse-kinematics network on a recording (-> W.json)");
  sub->footer(
      "\nLevenberg-Marquardt (MATLAB trainlm's damping schedule) on the sum of squared joint-angle errors in\n"
      "degrees, analytic Jacobian, inputs and outputs scaled to [-1, 1] from the data (mapminmax).\n"
      "A seeded share of the samples (--validation) is held out: training stops when it has not improved\n"
      "for 6 epochs in a row, when the training error has plateaued (< 1 % over 25 epochs), or at\n"
      "--max-epochs; the weights with the best validation error are kept. One line per epoch on stderr.\n"
      "--model deployed (the default: what the board runs) first fits the math model's effects (geometry\n"
      "per chain, joint offsets, encoder scales, frame tilt and shift, backlash; in time order), trains the\n"
      "network on the recording without the identified backlash, and keeps the identified half-play: in\n"
      "time order (ik on rows with t_s, the board's setpoints) each joint's answer passes that play.\n"
      "Where the math model leaves a joint a ripple of an encoder floor or more as a function of its angle\n"
      "(a transmission ripple: a tanh network in x, y, z cannot follow one much shorter than the joint's\n"
      "travel), the model gains a joint ripple table (quarter-degree entries, W.json version 3): the\n"
      "network learns the angles without it, and the host shapes every setpoint it sends (ik, host run,\n"
      "home) so that the board's unchanged network answers with the table's value added.\n"
      "It ends with the deployed model's error per joint on the recording's rows in encoder floors, and\n"
      "names a joint left above 1.5 floors, with the ripple the math model leaves on it when no table\n"
      "took it (--ripple-table off).\n"
      "--model network is the paper's plain network on the recording as it is.\n"
      "--model hybrid fits the same effects and trains the network on what they leave (a PC reference).\n"
      "The same data, seed and options give the same W.json, byte for byte, with any thread count.\n"
      "Example: deltactl train --data rec.csv --out W.json --seed 1 --hidden 25");
  sub->add_option("--data", options->data, "recording to fit (CSV, docs/contracts.md)")->required();
  sub->add_option("--out", options->out, "weights file to write (W.json)")->required();
  sub->add_flag("--unreferenced", options->unreferenced,
                "train on a recording whose header says its counts were not referenced at the home switches "
                "('# referenced: hand' or 'none'; refused otherwise)");
  add_training_options(sub, options->training);
  sub->add_option("--model", options->model,
                  "deployed (static network + backlash compensation), network (the paper's) or hybrid (math model + "
                  "network)")
      ->capture_default_str()
      ->check(CLI::IsMember({"deployed", "network", "hybrid"}));
  sub->add_option_function<std::string>(
         "--ripple-table",
         [options](const std::string& value) { options->training.joint_ripple_table = value == "auto"; },
         "deployed: auto (a joint ripple table where the math model leaves a ripple) or off")
      ->default_str("auto")
      ->check(CLI::IsMember({"auto", "off"}));
  sub->add_option("--validation", options->training.validation_fraction, "share of samples held out for early stopping")
      ->capture_default_str()
      ->check(options::real_number(0, 0.5));
  sub->add_option("--threads", options->training.threads, "worker threads (0: all cores; same result for any)")
      ->capture_default_str()
      ->check(options::whole_number(0, 256));
  sub->callback([options] { run_train(*options); });
});

}  // namespace
}  // namespace delta::nn
