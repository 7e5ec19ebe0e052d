// deltactl accuracy: the fixed-point network against its float original over a dense grid of the
// 10 mm cube plus a margin and along the paper's trajectories, and the word-length sweep.
#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <memory>
#include <thread>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/plot.hpp"
#include "delta/table.hpp"
#include "delta/trajectory.hpp"
#include "options.hpp"

namespace delta::golden {
namespace {

struct AccuracyOptions {
  std::string weights;
  int grid_points = 101;  // per axis: 101^3 = 1030301 poses
  double margin_mm = 1.0;
  int sweep_grid_points = 41;  // per axis for each sweep point: 68921 poses
  double bound_deg = 0.001;
  std::string plot;
  bool sweep = true;
};

// The paper's 10 mm cube (metres).
const Vec3 kCubeMin(-0.005, -0.005, -0.08084);
const Vec3 kCubeMax(0.005, 0.005, -0.07084);

struct ErrorStats {
  Vec3 max_abs = Vec3::Zero();
  Vec3 sum_squares = Vec3::Zero();
  std::size_t count = 0;
  SaturationCounters saturations;
  void add(const Vec3& error) {
    max_abs = max_abs.cwiseMax(error.cwiseAbs());
    sum_squares += error.cwiseProduct(error);
    ++count;
  }
  void merge(const ErrorStats& other) {
    max_abs = max_abs.cwiseMax(other.max_abs);
    sum_squares += other.sum_squares;
    count += other.count;
    saturations.add(other.saturations);
  }
  Vec3 rms() const { return count ? Vec3((sum_squares / static_cast<double>(count)).cwiseSqrt()) : Vec3::Zero(); }
};

struct GridStats {
  ErrorStats inside;   // inside the trained input range of W.json
  ErrorStats outside;  // the margin beyond it
};

Vec3 grid_point(const Vec3& low, const Vec3& high, int points, std::size_t index) {
  const std::size_t n = static_cast<std::size_t>(points);
  const Vec3 t(static_cast<double>(index / (n * n)), static_cast<double>((index / n) % n),
               static_cast<double>(index % n));
  return low + (high - low).cwiseProduct(t / (points - 1));
}

bool inside_training_range(const nn::Network& network, const Vec3& p) {
  return (p.array() >= network.input_min.array()).all() && (p.array() <= network.input_max.array()).all();
}

Vec3 fixed_error(const QuantisedNetwork& q, const Vec3& p, const Vec3& reference, SaturationCounters* counters) {
  const RawOutput out = evaluate_raw(q, encode_position(q.formats, p), counters);
  Vec3 error;
  for (int o = 0; o < 3; ++o) error[o] = decode_angle_deg(q.formats, out.alpha[o]) - reference[o];
  return error;
}

// Runs body(begin, end, worker) over [0, count) on two threads (the machine has two cores).
void parallel_for(std::size_t count, const std::function<void(std::size_t, std::size_t, int)>& body) {
  constexpr int kWorkers = 2;
  std::vector<std::thread> threads;
  for (int w = 0; w < kWorkers; ++w) {
    threads.emplace_back(body, count * w / kWorkers, count * (w + 1) / kWorkers, w);
  }
  for (std::thread& thread : threads) thread.join();
}

GridStats grid_accuracy(const nn::Network& network, const QuantisedNetwork& q, const Vec3& low, const Vec3& high,
                        int points) {
  const std::size_t count = static_cast<std::size_t>(points) * points * points;
  std::vector<GridStats> partial(2);
  parallel_for(count, [&](std::size_t begin, std::size_t end, int worker) {
    for (std::size_t i = begin; i < end; ++i) {
      const Vec3 p = grid_point(low, high, points, i);
      GridStats& stats = partial[worker];
      ErrorStats& part = inside_training_range(network, p) ? stats.inside : stats.outside;
      part.add(fixed_error(q, p, network.evaluate(p), &part.saturations));
    }
  });
  GridStats total;
  for (const GridStats& part : partial) {
    total.inside.merge(part.inside);
    total.outside.merge(part.outside);
  }
  return total;
}

// One field of Formats varied by the sweep; set() keeps its integer bits when fraction bits change.
struct SweepField {
  std::string name;
  std::function<int(const Formats&)> get;
  std::function<void(Formats&, int)> set;
};

std::vector<SweepField> sweep_fields() {
  return {
      {"scaled input u bits (Q1.x)", [](const Formats& f) { return f.scaled_input_bits; },
       [](Formats& f, int v) { f.scaled_input_bits = v; }},
      {"IW' fraction bits", [](const Formats& f) { return f.input_weight_fraction_bits; },
       [](Formats& f, int v) {
         f.input_weight_bits += v - f.input_weight_fraction_bits;
         f.input_weight_fraction_bits = v;
       }},
      {"tanh input n fraction bits", [](const Formats& f) { return f.tanh_input_fraction_bits; },
       [](Formats& f, int v) {
         f.tanh_input_bits += v - f.tanh_input_fraction_bits;
         f.tanh_input_fraction_bits = v;
       }},
      {"tanh segments per unit (log2)", [](const Formats& f) { return f.tanh_segments_per_unit_log2; },
       [](Formats& f, int v) { f.tanh_segments_per_unit_log2 = v; }},
      {"tanh guard bits", [](const Formats& f) { return f.tanh_guard_bits; },
       [](Formats& f, int v) { f.tanh_guard_bits = v; }},
      {"hidden h fraction bits", [](const Formats& f) { return f.hidden_fraction_bits; },
       [](Formats& f, int v) { f.hidden_fraction_bits = v; }},
      {"LW' fraction bits", [](const Formats& f) { return f.output_weight_fraction_bits; },
       [](Formats& f, int v) {
         f.output_weight_bits += v - f.output_weight_fraction_bits;
         f.output_weight_fraction_bits = v;
       }},
      {"output alpha fraction bits", [](const Formats& f) { return f.output_fraction_bits; },
       [](Formats& f, int v) {
         f.output_bits += v - f.output_fraction_bits;
         f.output_fraction_bits = v;
       }},
  };
}

// Worst |tanh table - tanh| over every tanh input code, in LSB of h.
double tanh_worst_lsb(const QuantisedNetwork& q) {
  const Formats& f = q.formats;
  const std::int64_t limit = std::int64_t{1} << (f.tanh_input_bits - 1);
  double worst = 0.0;
  for (std::int64_t n = 0; n < limit; ++n) {  // odd symmetry: n >= 0 covers -n too, n = -limit clamps to the end
    const double exact =
        std::ldexp(std::tanh(std::ldexp(static_cast<double>(n), -f.tanh_input_fraction_bits)), f.hidden_fraction_bits);
    worst = std::max(worst, std::abs(static_cast<double>(tanh_code(q, n)) - exact));
  }
  const double end = std::ldexp(1.0, f.hidden_fraction_bits);  // tanh(-2^range) ~ -1
  return std::max(worst, std::abs(static_cast<double>(tanh_code(q, -limit)) + end));
}

void print_stats_table(const std::string& title, const std::vector<std::pair<std::string, ErrorStats>>& rows) {
  std::cout << title << "\n\n";
  Table table({"set", "poses", "max |err| a1 [deg]", "max |err| a2 [deg]", "max |err| a3 [deg]", "RMS a1 [deg]",
               "RMS a2 [deg]", "RMS a3 [deg]", "sat. u", "sat. n (harmless)", "sat. alpha"});
  for (const auto& [name, stats] : rows) {
    const Vec3 rms = stats.rms();
    table.add_row({name, std::to_string(stats.count), fixed(stats.max_abs[0], 6), fixed(stats.max_abs[1], 6),
                   fixed(stats.max_abs[2], 6), fixed(rms[0], 6), fixed(rms[1], 6), fixed(rms[2], 6),
                   std::to_string(stats.saturations.scaled_input), std::to_string(stats.saturations.tanh_input),
                   std::to_string(stats.saturations.output)});
  }
  table.print(std::cout);
  std::cout << '\n';
}

// Returns true when the chosen formats are the smallest meeting the bound in every field.
bool run_sweep(const AccuracyOptions& options, const nn::Network& network, const Vec3& low, const Vec3& high) {
  const Formats chosen;
  const int points = options.sweep_grid_points;
  const std::size_t count = static_cast<std::size_t>(points) * points * points;
  std::vector<Vec3> positions(count);
  std::vector<Vec3> references(count);
  for (std::size_t i = 0; i < count; ++i) {
    positions[i] = grid_point(low, high, points, i);
    references[i] = network.evaluate(positions[i]);
  }
  std::cout << "Word-length sweep: one field at a time, the others at the chosen formats; max |fixed - float| over\n"
               "all joints on a "
            << points << "^3 grid (" << count << " poses) of the same region; bound " << options.bound_deg
            << " deg.\n\n";
  Table table({"field", "bits", "vs chosen", "max |err| [deg]", "sat. u inside", "tanh worst [LSB]", "meets bound"});
  Table summary({"field", "chosen", "smallest meeting the bound", "max |err| at chosen - 1 [deg]"});
  PlotPanel panel{"max |fixed - float| against word length (one field varied, others chosen)",
                  "bits relative to the chosen format",
                  "max |error| [deg]",
                  {},
                  true};
  bool all_minimal = true;
  const std::vector<SweepField> fields = sweep_fields();
  for (std::size_t f = 0; f < fields.size(); ++f) {
    const SweepField& field = fields[f];
    // Progress on stderr (the tables go to stdout): the sweep is the long part.
    std::cerr << "accuracy: word-length sweep, field " << f + 1 << " of " << fields.size() << " (" << field.name
              << ")\n";
    const int chosen_value = field.get(chosen);
    PlotSeries series{field.name, {}, {}, false};
    int smallest = -1;
    double error_below = -1.0;
    for (int delta = -4; delta <= 2; ++delta) {
      Formats formats = chosen;
      field.set(formats, chosen_value + delta);
      std::string verdict;
      double worst = -1.0;
      std::size_t saturated_inside = 0;
      double tanh_lsb = 0.0;
      try {
        const QuantisedNetwork q = quantise(network, formats);
        std::vector<double> worst_part(2, 0.0);
        std::vector<std::size_t> saturated_part(2, 0);
        parallel_for(count, [&](std::size_t begin, std::size_t end, int worker) {
          for (std::size_t i = begin; i < end; ++i) {
            SaturationCounters counters;
            const Vec3 error = fixed_error(q, positions[i], references[i], &counters);
            worst_part[worker] = std::max(worst_part[worker], error.cwiseAbs().maxCoeff());
            if (counters.errors() && inside_training_range(network, positions[i])) ++saturated_part[worker];
          }
        });
        worst = std::max(worst_part[0], worst_part[1]);
        saturated_inside = saturated_part[0] + saturated_part[1];
        tanh_lsb = tanh_worst_lsb(q);
        const bool meets = worst <= options.bound_deg && saturated_inside == 0 && tanh_lsb <= 1.0;
        verdict = meets ? "yes" : "no";
        if (meets && smallest < 0) smallest = chosen_value + delta;
        if (!meets && smallest >= 0 && delta <= 0) smallest = -1;  // must hold from here up to the chosen value
        series.x.push_back(delta);
        series.y.push_back(worst);
      } catch (const std::invalid_argument& error) {
        verdict = "refused (weights saturate)";
        if (delta <= 0) smallest = -1;
      }
      if (delta == -1) error_below = worst;
      table.add_row({field.name, std::to_string(chosen_value + delta), (delta > 0 ? "+" : "") + std::to_string(delta),
                     worst < 0 ? "-" : fixed(worst, 6), std::to_string(saturated_inside),
                     worst < 0 ? "-" : fixed(tanh_lsb, 3), verdict});
    }
    all_minimal = all_minimal && smallest == chosen_value;
    summary.add_row({field.name, std::to_string(chosen_value), smallest < 0 ? "none" : std::to_string(smallest),
                     error_below < 0 ? "-" : fixed(error_below, 6)});
    panel.series.push_back(std::move(series));
  }
  table.print(std::cout);
  std::cout << "\nSmallest value of each field meeting the bound (error <= bound, no saturation inside the trained\n"
               "range, tanh table within 1 LSB), the other fields at the chosen formats:\n\n";
  summary.print(std::cout);
  std::cout << '\n';
  if (!options.plot.empty()) {
    PlotSeries bound{
        "bound " + fixed(options.bound_deg, 4) + " deg", {-4.0, 2.0}, {options.bound_deg, options.bound_deg}, false};
    panel.series.push_back(bound);
    PlotSpec spec;
    spec.title = "Fixed-point network: word-length sweep";
    spec.panels = {panel};
    write_plot(options.plot, spec);
    std::cout << "plot: " << options.plot << "\n\n";
  }
  return all_minimal;
}

void run_accuracy(const AccuracyOptions& options) {
  if (options.grid_points < 2 || options.sweep_grid_points < 2)
    throw std::invalid_argument("grid needs >= 2 points per axis");
  const nn::WeightsFile weights = nn::read_weights_file(options.weights);
  const nn::Network& network = weights.network;
  QuantisedNetwork q;
  try {
    q = quantise(network);
  } catch (const std::invalid_argument& error) {
    throw InputError(options.weights, 0, std::string("cannot be quantised: ") + error.what());
  }
  const Vec3 margin = Vec3::Constant(options.margin_mm * 1e-3);
  const Vec3 low = kCubeMin - margin;
  const Vec3 high = kCubeMax + margin;
  const std::size_t poses = static_cast<std::size_t>(options.grid_points) * options.grid_points * options.grid_points;
  std::cout << "Fixed-point (golden model, hls/README.md) against float, " << options.weights
            << (weights.hybrid() ? " (network part of a hybrid model)" : "") << "\n"
            << "Grid: " << options.grid_points << "^3 = " << poses << " poses over the 10 mm cube plus "
            << options.margin_mm << " mm: x, y in [" << low[0] * 1e3 << ", " << high[0] * 1e3 << "] mm, z in ["
            << low[2] * 1e3 << ", " << high[2] * 1e3 << "] mm. Trained input range: x [" << network.input_min[0] * 1e3
            << ", " << network.input_max[0] * 1e3 << "], y [" << network.input_min[1] * 1e3 << ", "
            << network.input_max[1] * 1e3 << "], z [" << network.input_min[2] * 1e3 << ", "
            << network.input_max[2] * 1e3 << "] mm.\n\n";
  std::cerr << "accuracy: grid of " << poses << " poses\n";
  const GridStats grid = grid_accuracy(network, q, low, high, options.grid_points);
  std::cerr << "accuracy: trajectories\n";
  ErrorStats all = grid.inside;
  all.merge(grid.outside);
  std::vector<std::pair<std::string, ErrorStats>> rows = {
      {"grid, inside trained range", grid.inside}, {"grid, outside (margin)", grid.outside}, {"grid, all", all}};
  for (const char* name : {"validation", "experiment1", "experiment2"}) {
    const Trajectory trajectory = make_trajectory(name);
    ErrorStats stats;
    for (std::size_t i = 0; i < trajectory.samples; ++i) {
      const Vec3 p = trajectory.position_m(static_cast<double>(i) / trajectory.rate_hz);
      stats.add(fixed_error(q, p, network.evaluate(p), &stats.saturations));
    }
    rows.emplace_back(std::string("trajectory ") + name, stats);
  }
  print_stats_table("Accuracy of the chosen formats (|fixed - float| per joint):", rows);
  const bool meets = all.max_abs.maxCoeff() <= options.bound_deg && grid.inside.saturations.errors() == 0;
  std::cout << "Bound " << options.bound_deg
            << " deg on the whole grid with no saturation inside the trained range: " << (meets ? "met" : "NOT met")
            << "\n\n";
  bool minimal = true;
  if (options.sweep) minimal = run_sweep(options, network, low, high);
  if (options.sweep)
    std::cout << "Chosen formats are the smallest meeting the bound in every field: " << (minimal ? "yes" : "no")
              << '\n';
  if (!meets) throw CommandExit{kExitFailure};
}

const RegisterCommand command("accuracy", 46, [](CLI::App& root) {
  auto options = std::make_shared<AccuracyOptions>();
  CLI::App* sub =
      root.add_subcommand("accuracy", "Fixed-point network against float: grid, trajectories, word-length sweep");
  sub->footer(
      "\nEvaluates the golden fixed-point model (the formats of hls/README.md) and the float network of\n"
      "W.json on a grid of the paper's 10 mm cube plus a margin and along the validation, experiment1\n"
      "and experiment2 trajectories: max and RMS |fixed - float| per joint and saturation counts, inside\n"
      "and outside the trained input range. Then varies each format one at a time (word-length sweep)\n"
      "and reports the smallest width that still meets the bound. Exit 1 if the chosen formats miss it.\n"
      "Example: deltactl accuracy --weights weights/paper_like.json --plot sweep.png");
  sub->add_option("--weights", options->weights, "network weights (W.json)")->required();
  sub->add_option("--grid-points", options->grid_points, "grid points per axis")
      ->capture_default_str()
      ->check(options::whole_number(2, 301));
  sub->add_option("--margin-mm", options->margin_mm, "margin around the 10 mm cube [mm]")
      ->capture_default_str()
      ->check(options::real_number(0, 20));
  sub->add_option("--sweep-grid-points", options->sweep_grid_points, "grid points per axis for each sweep point")
      ->capture_default_str()
      ->check(options::whole_number(2, 201));
  sub->add_option("--bound-deg", options->bound_deg, "accuracy bound [deg]")
      ->capture_default_str()
      ->check(options::real_number(0, 10, true));
  CLI::Option* plot = sub->add_option("--plot", options->plot, "PNG of the word-length sweep");
  sub->add_flag("!--no-sweep", options->sweep, "skip the word-length sweep (no --plot then: it draws the sweep)")
      ->excludes(plot);
  sub->callback([options] { run_accuracy(*options); });
});

}  // namespace
}  // namespace delta::golden
