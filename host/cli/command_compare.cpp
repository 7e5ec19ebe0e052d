// deltactl compare: the math model against a recording (Table 1 layout, FK error ranges, plot).
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/model_error.hpp"
#include "delta/plot.hpp"
#include "delta/recording.hpp"
#include "delta/table.hpp"

namespace delta {
namespace {

struct CompareOptions {
  std::string data;
  std::string plot;
};

void write_error_plot(const std::string& path, const Recording& recording, const ModelComparison& comparison) {
  PlotSpec spec;
  spec.title = "Math model vs " + recording.path;
  PlotPanel joints{"Joint error: measured - IK(measured position)", "t [s]", "error [deg]", {}, false};
  PlotPanel axes{"Position error: FK(measured angles) - measured position", "t [s]", "error [um]", {}, false};
  for (int k = 0; k < 3; ++k) {
    PlotSeries joint{"alpha" + std::to_string(k + 1), {}, {}, false};
    PlotSeries axis{std::string(1, "xyz"[k]), {}, {}, false};
    for (std::size_t i = 0; i < recording.samples.size(); ++i) {
      joint.x.push_back(recording.samples[i].t_s);
      joint.y.push_back(comparison.joint_error_deg[i][k]);
      axis.x.push_back(recording.samples[i].t_s);
      axis.y.push_back(comparison.position_error_m[i][k] * 1e6);
    }
    joints.series.push_back(std::move(joint));
    axes.series.push_back(std::move(axis));
  }
  spec.panels = {joints, axes};
  write_plot(path, spec);
}

void run_compare(const CompareOptions& options) {
  const Recording recording = read_recording(options.data);
  const ModelComparison comparison = compare_model(Geometry::nominal(), recording);
  std::cout << "Math model (nominal geometry) against " << options.data << ", " << recording.samples.size()
            << " samples\n\n";
  Table joints({"joint", "math model RMSE [deg]", "math model MAE [deg]", "max abs error [deg]"});
  for (int j = 0; j < 3; ++j) {
    joints.add_row({"alpha_" + std::to_string(j + 1), fixed(comparison.joints.rmse_deg[j], 4),
                    fixed(comparison.joints.mae_deg[j], 4), fixed(comparison.joints.max_abs_deg[j], 4)});
  }
  joints.print(std::cout);
  std::cout << "\nForward kinematics of the measured angles minus the measured position:\n\n";
  Table axes({"axis", "min error [um]", "max error [um]"});
  for (int k = 0; k < 3; ++k) {
    axes.add_row({std::string(1, "xyz"[k]), fixed(comparison.position_error_min_m[k] * 1e6, 2),
                  fixed(comparison.position_error_max_m[k] * 1e6, 2)});
  }
  axes.print(std::cout);
  if (!options.plot.empty()) {
    write_error_plot(options.plot, recording, comparison);
    std::cout << "\nplot: " << options.plot << '\n';
  }
}

const RegisterCommand command("compare", 20, [](CLI::App& root) {
  auto options = std::make_shared<CompareOptions>();
  CLI::App* sub = root.add_subcommand("compare", "Math model against a recording: Table 1 errors and FK error ranges");
  sub->footer(
      "\nPrints RMSE and MAE per joint of measured angles against the nominal inverse kinematics of the\n"
      "measured positions (the paper's Table 1, math-model column), and the range per axis of the\n"
      "forward kinematics of the measured angles against the measured positions (the paper's Fig. 4/5).\n"
      "Example: deltactl compare --data rec.csv --plot rec_errors.png");
  sub->add_option("--data", options->data, "recording (CSV, docs/contracts.md)")->required();
  sub->add_option("--plot", options->plot, "PNG of the errors along the trajectory");
  sub->callback([options] { run_compare(*options); });
});

}  // namespace
}  // namespace delta
