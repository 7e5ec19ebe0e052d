// deltactl table1: the paper's Table 1 on held-out recordings: math model, network, hybrid and the
// deployed model (in time order and pose-wise).
#include <functional>
#include <iostream>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/input_error.hpp"
#include "delta/model_error.hpp"
#include "delta/nn/model_training.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/output_file.hpp"
#include "delta/table.hpp"
#include "training_options.hpp"

namespace delta::nn {
namespace {

struct Table1Options {
  std::string data;
  std::vector<std::string> holdouts;
  std::string network_weights;   // given: skip training the network
  std::string hybrid_weights;    // given: skip training the hybrid
  std::string deployed_weights;  // given: skip training the deployed model
  std::string save_network;
  std::string save_hybrid;
  std::string save_deployed;
  TrainingOptions training;
};

// The paper's Table 1 (degrees, over its whole recorded set).
const JointErrorStats& paper_math_model() {
  static const JointErrorStats stats{Vec3(0.8270, 0.8845, 0.8083), Vec3(0.6593, 0.7142, 0.6255), Vec3::Zero()};
  return stats;
}
const JointErrorStats& paper_network() {
  static const JointErrorStats stats{Vec3(0.1655, 0.0616, 0.0576), Vec3(0.0969, 0.0476, 0.0431), Vec3::Zero()};
  return stats;
}

using PoseModel = std::function<IkSolution(const Vec3& position_m)>;

JointErrorStats model_stats(const Recording& recording, const std::string& name, const PoseModel& model) {
  std::vector<Vec3> measured, predicted;
  for (std::size_t i = 0; i < recording.samples.size(); ++i) {
    const IkSolution solution = model(recording.samples[i].position_m);
    if (!solution.ok()) throw InputError(recording.path, recording.line_numbers[i], name + ": " + solution.reason());
    measured.push_back(recording.samples[i].alpha_deg);
    predicted.push_back(solution.alpha_deg);
  }
  return joint_error_stats(measured, predicted);
}

void add_row(Table& table, const std::string& name, const JointErrorStats& stats) {
  std::vector<std::string> row{name};
  for (int j = 0; j < 3; ++j) row.push_back(fixed(stats.rmse_deg[j], 4));
  for (int j = 0; j < 3; ++j) row.push_back(fixed(stats.mae_deg[j], 4));
  table.add_row(row);
}

WeightsFile obtain(const std::string& given, const std::string& model, const Recording& data,
                   const TrainingOptions& training, std::optional<OutputFile>& save) {
  if (!given.empty()) {
    save.reset();  // nothing trained, nothing saved
    WeightsFile weights = read_weights_file(given);
    if (weights.model != model) {
      throw InputError(given, 0, "expected a " + model + " model, this file holds a " + weights.model + " model");
    }
    return weights;
  }
  std::cerr << "table1: training the " << model << " on " << data.path << '\n';
  const ModelTraining result = train_model(data, model, training, [&model](const TrainingEpoch& epoch) {
    if (epoch.epoch % 25 == 0) std::cerr << "table1: " << model << ' ' << describe_epoch(epoch) << '\n';
  });
  std::cerr << "table1: " << model << ": " << result.training.epochs << " epochs, stopped by "
            << result.training.stop_reason << '\n';
  if (save) save->stream() << weights_file_text(result.weights);
  return result.weights;
}

void run_table1(const Table1Options& options) {
  const Recording data = read_recording(options.data);
  std::vector<Recording> holdouts;
  for (const std::string& path : options.holdouts) holdouts.push_back(read_recording(path));
  // Saved networks are opened first (a bad path fails before training) and appear together at the end.
  std::optional<OutputFile> save_network, save_hybrid, save_deployed;
  if (!options.save_network.empty()) save_network.emplace(options.save_network);
  if (!options.save_hybrid.empty()) save_hybrid.emplace(options.save_hybrid);
  if (!options.save_deployed.empty()) save_deployed.emplace(options.save_deployed);
  const WeightsFile network = obtain(options.network_weights, "network", data, options.training, save_network);
  const WeightsFile hybrid = obtain(options.hybrid_weights, "hybrid", data, options.training, save_hybrid);
  const WeightsFile deployed = obtain(options.deployed_weights, "deployed", data, options.training, save_deployed);
  const std::string hidden = std::to_string(network.network.hidden());
  std::cout << "Table 1: joint-angle error (measured - model) in degrees. Paper: its robot, over the whole\n"
               "recorded set. Ours: models fitted on "
            << options.data << " only.\n";
  std::vector<const Recording*> recordings{&data};
  for (const Recording& holdout : holdouts) recordings.push_back(&holdout);
  for (const Recording* recording : recordings) {
    const bool fit = recording == &data;
    std::cout << "\n"
              << (fit ? "Fit recording (seen in training): " : "Held-out recording (never seen): ") << recording->path
              << ", " << recording->samples.size() << " samples\n\n";
    Table table({"model", "RMSE alpha_1", "RMSE alpha_2", "RMSE alpha_3", "MAE alpha_1", "MAE alpha_2", "MAE alpha_3"});
    add_row(table, "paper: math model", paper_math_model());
    add_row(table, "paper: NN 3-25-3", paper_network());
    const std::vector<std::pair<std::string, PoseModel>> models = {
        {"ours: math model (nominal)", [](const Vec3& p) { return math_model_angles(EffectSet{}, p); }},
        {"ours: math model + identified effects",
         [&hybrid](const Vec3& p) { return math_model_angles(hybrid.effects, p); }},
        {"ours: network 3-" + hidden + "-3", [&network](const Vec3& p) { return evaluate_model(network, p); }},
        {"ours: hybrid (identified model + network)", [&hybrid](const Vec3& p) { return evaluate_model(hybrid, p); }},
        {"ours: deployed, pose-wise (static network)",
         [&deployed](const Vec3& p) { return evaluate_model(deployed, p); }},
        // The rows of a recording come in time order: the compensation follows them.
        {"ours: deployed, in time order (+ backlash compensation)",
         [&deployed, play = std::make_shared<BacklashCompensation>(deployed.backlash_half_play_deg)](const Vec3& p) {
           IkSolution solution = evaluate_model(deployed, p);
           if (solution.ok()) solution.alpha_deg = play->update(solution.alpha_deg);
           return solution;
         }}};
    for (const auto& [name, model] : models) add_row(table, name, model_stats(*recording, name, model));
    table.print(std::cout);
  }
  for (auto* save : {&save_network, &save_hybrid, &save_deployed})
    if (*save) (*save)->finish();
  for (auto* save : {&save_network, &save_hybrid, &save_deployed})
    if (*save) (*save)->commit();
}

const RegisterCommand command("table1", 45, [](CLI::App& root) {
  auto options = std::make_shared<Table1Options>();
  CLI::App* sub =
      root.add_subcommand("table1", "The paper's Table 1 on held-out data: math model, network, hybrid, deployed");
  sub->footer(
      "\nFits the network, the hybrid and the deployed model on FIT (as 'deltactl train' does, or loads them with\n"
      "--network, --hybrid and --deployed), then prints RMSE and MAE per joint as Markdown tables, the paper's\n"
      "figures beside ours, for FIT and for every --holdout recording. Rows: the nominal math model, the math\n"
      "model with the effects the hybrid identified, the pure network, the hybrid (identified model + network\n"
      "on the residual), and the deployed model pose-wise and in time order (the recording's rows, in float).\n"
      "Example: deltactl table1 --data fit.csv --holdout sweep.csv --holdout experiment1.csv");
  sub->add_option("--data", options->data, "recording the models are fitted on (CSV, docs/contracts.md)")->required();
  sub->add_option("--holdout", options->holdouts, "recording never seen in training (repeatable)")->required();
  sub->add_option("--network", options->network_weights, "use this network W.json instead of training one");
  sub->add_option("--hybrid", options->hybrid_weights, "use this hybrid W.json instead of training one");
  sub->add_option("--save-network", options->save_network, "write the trained network here");
  sub->add_option("--save-hybrid", options->save_hybrid, "write the trained hybrid here");
  sub->add_option("--deployed", options->deployed_weights, "use this deployed W.json instead of training one");
  sub->add_option("--save-deployed", options->save_deployed, "write the trained deployed model here");
  add_training_options(sub, options->training);
  sub->callback([options] { run_table1(*options); });
});

}  // namespace
}  // namespace delta::nn
