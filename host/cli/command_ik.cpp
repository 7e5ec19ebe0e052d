// deltactl ik: joint angles for plate positions, by the math model or a network back end.
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/csv.hpp"
#include "delta/ik_backend.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "delta/output_file.hpp"
#include "delta/recording.hpp"

namespace delta {
namespace {

// The closed-form math model on the nominal geometry.
class NominalIkBackend : public IkBackend {
 public:
  std::vector<IkRow> evaluate(const std::vector<Vec3>& positions_m, bool) override {
    std::vector<IkRow> rows(positions_m.size());
    const Geometry geometry = Geometry::nominal();
    for (std::size_t i = 0; i < positions_m.size(); ++i) {
      const IkSolution solution = inverse_kinematics(geometry, positions_m[i]);
      if (solution.ok())
        rows[i].alpha_deg = solution.alpha_deg;
      else
        rows[i].error = solution.reason();
    }
    return rows;
  }
};

const RegisterIkBackend nominal_backend("nominal", "closed-form math model, nominal geometry",
                                        [](const std::string&) { return std::make_unique<NominalIkBackend>(); });

struct IkOptions {
  std::string model;
  std::string weights;
  std::string backend = "float";
  std::string in;
  std::string out;
  bool pose_wise = false;
};

void run_ik(const IkOptions& options) {
  if (options.model.empty() == options.weights.empty()) {
    throw std::invalid_argument("give exactly one of --model nominal or --weights W.json");
  }
  if (!options.model.empty() && options.model != "nominal") {
    throw std::invalid_argument("unknown --model '" + options.model + "' (the math model is 'nominal')");
  }
  const std::string backend_name = options.model.empty() ? options.backend : "nominal";
  std::unique_ptr<IkBackend> backend = make_ik_backend(backend_name, options.weights);
  const CsvTable table = read_csv(options.in, {"x_m", "y_m", "z_m"}, {"t_s"});
  std::vector<Vec3> positions;
  positions.reserve(table.rows.size());
  for (const auto& row : table.rows) positions.emplace_back(row[0], row[1], row[2]);
  // Rows with t_s are a recording in time order (SPEC): the model's time-ordered parts follow them.
  const bool timed = table.present[3];
  for (std::size_t i = 0; timed && i < table.rows.size(); ++i) check_time_order(table, i, 3);
  const bool in_time_order = timed && !options.pose_wise;
  const std::vector<IkRow> rows = backend->evaluate(positions, in_time_order);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!rows[i].error.empty()) throw InputError(options.in, table.line_numbers[i], rows[i].error);
  }
  OutputFile file(options.out);
  std::ostream& out = file.stream();
  const bool raw = backend->has_raw_codes();
  out << "alpha1_deg,alpha2_deg,alpha3_deg" << (raw ? ",alpha1_raw,alpha2_raw,alpha3_raw" : "") << '\n';
  for (const IkRow& row : rows) {
    out << format_number(row.alpha_deg[0]) << ',' << format_number(row.alpha_deg[1]) << ','
        << format_number(row.alpha_deg[2]);
    if (raw) out << ',' << row.raw[0] << ',' << row.raw[1] << ',' << row.raw[2];
    out << '\n';
  }
  file.commit();
  std::cerr << "ik: " << rows.size() << " poses through '" << backend_name << "' -> " << options.out << '\n';
  if (backend->has_time_ordered_parts()) {
    std::cerr << "ik: time-ordered parts (backlash compensation) "
              << (in_time_order ? "applied in row order"
                                : (timed ? "off (--pose-wise)" : "off (the input has no t_s column)"))
              << '\n';
  }
  for (const std::string& line : backend->report()) std::cerr << "ik: " << line << '\n';
}

const RegisterCommand command("ik", 30, [](CLI::App& root) {
  auto options = std::make_shared<IkOptions>();
  std::string backends;
  for (const IkBackendEntry& entry : ik_backends()) {
    if (entry.name != "nominal") backends += "\n  " + entry.name + ": " + entry.summary;
  }
  CLI::App* sub = root.add_subcommand("ik", "Inverse kinematics: joint angles for plate positions");
  sub->footer("\nBack ends for --weights:" + (backends.empty() ? std::string("\n  (none in this build)") : backends) +
              "\nIN needs columns x_m,y_m,z_m (others ignored). OUT has alpha1_deg..alpha3_deg, plus\n"
              "alpha1_raw..alpha3_raw (integer output codes) for fixed-point back ends.\n"
              "With a t_s column the rows are a recording in time order: a deployed model (train's default)\n"
              "then applies its backlash compensation row by row, from the first row (--pose-wise: not).\n"
              "An unreachable pose is an error naming its line; no output is written.\n"
              "Example: deltactl ik --model nominal --in poses.csv --out angles.csv");
  sub->add_option("--model", options->model, "math model: 'nominal'");
  sub->add_option("--weights", options->weights, "network weights (W.json from 'deltactl train')");
  sub->add_option("--backend", options->backend, "network back end (with --weights)")
      ->capture_default_str()
      ->excludes("--model");
  sub->add_option("--in", options->in, "CSV of plate positions (x_m,y_m,z_m; t_s: rows in time order)")->required();
  sub->add_flag("--pose-wise", options->pose_wise,
                "each row stands alone: no time-ordered parts (backlash compensation) even with t_s");
  sub->add_option("--out", options->out, "CSV of joint angles to write")->required();
  sub->callback([options] { run_ik(*options); });
});

}  // namespace
}  // namespace delta
