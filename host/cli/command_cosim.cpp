// deltactl cosim: the whole robot around the board RTL (see delta/cosim/board_cosim.hpp).
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/board_facts.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/cosim/board_cosim.hpp"
#include "delta/cosim/board_inputs.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"
#include "delta/plot.hpp"
#include "delta/run_report.hpp"
#include "delta/table.hpp"
#include "delta/temporary_directory.hpp"
#include "options.hpp"

namespace delta::cosim {
namespace {

struct CosimCommandOptions {
  std::string weights;
  std::string effects;
  std::string trajectory = "experiment1";
  double duration_s = 2.0;
  double settle_s = 0.4;
  std::uint32_t target_fill = 20;
  std::string out;
  std::string plot;
  std::string fidelity = "rtl";
};

std::string micrometres(double metres) { return fixed(metres * 1e6, 2); }

void write_samples(const std::string& path, const CosimResult& result, const std::string& command_line) {
  OutputFile file(path);
  std::ostream& out = file.stream();
  out << "# " << command_line << "\n"
      << "# t_s: board time since the first stream sample became the joint reference; tau_s: its path time (-1: the "
         "approach);\n"
      << "# alpha*_deg: encoder readings; x/y/z_m: measured plate position; ref_*: the host's reference;\n"
      << "# net*_deg: the network's answer for the reference (the joint reference due); true*_deg: plant angles; "
         "current*_a: drive currents;\n"
      << "# netideal_*, bookideal_*: the plate if the encoders read the network's answer or the textbook IK\n"
      << "t_s,tau_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m,ref_x_m,ref_y_m,ref_z_m,net1_deg,net2_deg,net3_deg,"
         "true1_deg,true2_deg,true3_deg,current1_a,current2_a,current3_a,"
         "netideal_x_m,netideal_y_m,netideal_z_m,bookideal_x_m,bookideal_y_m,bookideal_z_m,drives_enabled\n";
  for (const CosimSample& s : result.samples) {
    out << format_number(s.t_s) << ',' << format_number(s.tau_s);
    for (const Vec3* v : {&s.encoder_deg, &s.position_m, &s.reference_m, &s.network_deg, &s.true_alpha_deg,
                          &s.current_a, &s.network_ideal_m, &s.textbook_ideal_m}) {
      for (int k = 0; k < 3; ++k) out << ',' << format_number((*v)[k]);
    }
    out << ',' << (s.drives_enabled ? 1 : 0) << '\n';
  }
  file.commit();
}

void write_cosim_plot(const std::string& path, const CosimResult& result, const std::string& title) {
  PlotPanel position{"Plate position error (measured - reference)", "t [s]", "error [um]", {}, false};
  PlotPanel joints{"Joint tracking (encoder - network reference)", "t [s]", "error [deg]", {}, false};
  PlotPanel currents{"Drive currents", "t [s]", "current [A]", {}, false};
  const char* axis[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    PlotSeries p{axis[k], {}, {}, false}, j{"alpha" + std::to_string(k + 1), {}, {}, false},
        c{"joint " + std::to_string(k + 1), {}, {}, false};
    for (const CosimSample& s : result.samples) {
      p.x.push_back(s.t_s);
      p.y.push_back((s.position_m[k] - s.reference_m[k]) * 1e6);
      j.x.push_back(s.t_s);
      j.y.push_back(s.encoder_deg[k] - s.network_deg[k]);
      c.x.push_back(s.t_s);
      c.y.push_back(s.current_a[k]);
    }
    position.series.push_back(p);
    joints.series.push_back(j);
    currents.series.push_back(c);
  }
  PlotSpec spec;
  spec.title = title;
  spec.panels = {position, joints, currents};
  write_plot(path, spec);
}

// The closed loop's plate by what the reference does (the run-report's segments and dwells: where
// a part is set down), from the same path time on.
void print_where_it_rests(const CosimResult& result, double from_s) {
  RunReport report;
  try {
    report = run_report_of(result, from_s);
  } catch (const InputError&) {  // no sample with the drives on from from_s: the table above says so
    return;
  }
  std::cout << "closed loop, where it moves, rests and reverses (" << report.dwells.size() << " dwells, "
            << report.reversals.size() << " reversals of an axis or a joint; the definitions: run-report --help)\n\n"
            << plate_segments_text(report) << dwells_text(report);
}

// Runs the co-simulation with its progress on stderr (a line rewriting itself on a terminal, else a
// line per simulated second) and its speed after it; a refused plan is bad input.
CosimResult simulate(const CosimCommandOptions& options, CosimOptions& cosim) {
  const auto start = std::chrono::steady_clock::now();
  auto wall_s = [&start] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  // On a terminal the progress line rewrites itself; in a log, one line per simulated second.
  const bool terminal = ::isatty(2) != 0;
  cosim.progress = [&, terminal](double simulated_s, double total_s) {
    const long tenths = std::lround(simulated_s * 10.0);
    if (!terminal && tenths % 10 != 0) return;
    std::cerr << (terminal ? "\r" : "") << "cosim: " << fixed(simulated_s, 1) << " / " << fixed(total_s, 1)
              << " s of board time, " << fixed(wall_s(), 0) << " s wall" << (terminal ? "" : "\n") << std::flush;
  };
  std::cerr << "cosim: host over link v2 -> virtual board ("
            << (options.fidelity == "model" ? "C++ model board" : "board core RTL, Verilator")
            << ") + 3 joint plants + virtual robot ("
            << (options.effects.empty() ? std::string("nominal") : options.effects) << "), '" << options.trajectory
            << "' for " << options.duration_s << " s\n";
  CosimResult result;
  try {
    result = run_cosim(cosim);
  } catch (const InputError&) {
    throw;
  } catch (const PlanRefused& error) {
    std::cerr << (terminal ? "\n" : "") << "deltactl: error: " << error.what() << '\n';
    throw CommandExit{kExitBadInput};
  } catch (const std::runtime_error& error) {
    std::cerr << (terminal ? "\n" : "") << "deltactl: error: " << error.what() << '\n';
    throw CommandExit{kExitFailure};
  }
  const double wall = wall_s();
  std::cerr << (terminal ? "\r" : "") << "cosim: " << fixed(result.board_cycles / kBoardClockHz, 3)
            << " s of board time in " << fixed(wall, 1) << " s wall (" << fixed(result.board_cycles / wall / 1e6, 2)
            << " M board cycles/s)\n";
  if (result.board_busy_s > 0.0) {  // the board and the world without the host and the truth recording
    const double alone = result.board_cycles / result.board_busy_s;
    std::cerr << "cosim: the board and the world alone: " << fixed(result.board_busy_s, 2) << " s wall, "
              << fixed(alone / 1e6, 2) << " M board cycles/s, " << fixed(alone / kBoardClockHz, 1)
              << " x real time (the rest: the host, the truth recording)\n";
  }
  return result;
}

// The plate error of the closed loop, of the network's answers and of the textbook IK, and the
// joint tracking.
void print_accuracy_tables(const CosimCommandOptions& options, const golden::QuantisedNetwork& quantised,
                           const TrackingSummary& summary) {
  Table plate({"plate error (measured - reference)", "rms x [um]", "rms y [um]", "rms z [um]", "rms distance [um]",
               "max distance [um]"});
  auto add = [&plate](const std::string& label, const ErrorStats& e) {
    plate.add_row({label, micrometres(e.rms_m.x()), micrometres(e.rms_m.y()), micrometres(e.rms_m.z()),
                   micrometres(e.rms_distance_m), micrometres(e.max_distance_m)});
  };
  add(options.fidelity == "model" ? "closed loop: model board, plants, effects"
                                  : "closed loop: board RTL, plants, effects",
      summary.closed_loop);
  add(quantised.compensation.any() ? "network + backlash compensation, joints exact" : "network answers, joints exact",
      summary.network_ideal);
  add("textbook IK, joints exact", summary.textbook_ideal);
  plate.print(std::cout);
  std::cout << '\n';
  Table joints({"joint tracking", "alpha_1", "alpha_2", "alpha_3"});
  joints.add_row({quantised.compensation.any() ? "encoder - compensated answer due [deg rms] (truth, 1 kHz)"
                                               : "encoder - network answer due [deg rms] (truth, 1 kHz)",
                  fixed(summary.joint_rms_deg[0], 4), fixed(summary.joint_rms_deg[1], 4),
                  fixed(summary.joint_rms_deg[2], 4)});
  joints.add_row({"count - joint reference [deg rms] (telemetry)", fixed(summary.board_joint_rms_deg[0], 4),
                  fixed(summary.board_joint_rms_deg[1], 4), fixed(summary.board_joint_rms_deg[2], 4)});
  joints.print(std::cout);
  std::cout << '\n';
}

// The link's and the board's counters over the run.
void print_link_table(const CosimResult& result, const CosimOptions& cosim) {
  const link::LinkStatistics& s = result.link;
  const controller::StreamingResult& r = result.stream;
  Table link({"link v2 and board", "value"});
  link.add_row({"identify: protocol, build id, weights CRC", std::to_string(result.identify.protocol_version) + ", " +
                                                                 golden::hex_word(result.identify.build_id, 32) + ", " +
                                                                 golden::hex_word(result.identify.weights_crc, 32) +
                                                                 " (match the host's)"});
  link.add_row({"stream: outcome, setpoints played / planned (approach)",
                std::string(controller::outcome_name(r.outcome)) + ", " + std::to_string(r.played) + " / " +
                    std::to_string(r.planned) + " (" + std::to_string(result.approach_samples) + ")"});
  link.add_row({"setpoint frames sent (resent)",
                std::to_string(s.setpoints_sent) + " (" + std::to_string(s.setpoints_resent) + ")"});
  link.add_row({"telemetry frames received (lost, skipped)", std::to_string(s.telemetry_frames) + " (" +
                                                                 std::to_string(s.lost_telemetry) + ", " +
                                                                 std::to_string(s.skipped_telemetry) + ")"});
  link.add_row({"host decoder drops / skipped bytes",
                std::to_string(s.decoder.bad_crc + s.decoder.bad_length + s.decoder.unknown_type) + " / " +
                    std::to_string(s.decoder.skipped_bytes)});
  link.add_row(
      {"board: bad frames, refused", std::to_string(result.bad_frames) + ", " + std::to_string(result.rejected)});
  link.add_row({"board: underruns while streaming", std::to_string(result.underruns_while_streaming)});
  link.add_row({"board: slew limits, controller saturations",
                std::to_string(result.slew_limits) + ", " + std::to_string(result.saturations)});
  link.add_row(
      {"setpoints the host keeps ahead of the board (target fill)", std::to_string(cosim.session.target_fill)});
  link.add_row({"stream sample 0 is the joint reference at board time [ms]", fixed(1e3 * result.t0_s, 1)});
  link.add_row({"the plan's start: the pose the encoders report (network inverted at the home count) [mm]",
                fixed(result.start_position_m.x() * 1e3, 4) + ", " + fixed(result.start_position_m.y() * 1e3, 4) +
                    ", " + fixed(result.start_position_m.z() * 1e3, 4)});
  link.add_row({"encoder errors (sticky, bit per joint)", std::to_string(result.pins.encoder_error_bits)});
  link.add_row({"joint controller saturations (sticky)", result.pins.joint_limited ? "yes" : "no"});
  link.add_row({"joint fault, torque off (causes: 1 encoder, 2 following, 4 watchdog, 8 travel)",
                result.pins.fault_cause_bits ? std::to_string(result.pins.fault_cause_bits) : "none"});
  link.add_row({"samples with a current at the 0.5 A limit", std::to_string(result.full_scale_current_samples)});
  link.print(std::cout);
}

void run_cosim_command(const CosimCommandOptions& options, const std::string& command_line) {
  const golden::BoardWeights weights = golden::read_board_weights(options.weights);
  const golden::QuantisedNetwork& quantised = weights.network;
  const EffectSet effects = read_board_effects(options.effects);
  try {
    controller::load_path(options.trajectory, options.duration_s);  // a bad name or file: before the board is built
  } catch (const std::invalid_argument& error) {
    std::cerr << "deltactl: error: --trajectory: " << error.what() << '\n';
    throw CommandExit{kExitBadInput};
  }
  // Probe the output paths before minutes of simulation (OutputFile refuses an unwritable folder).
  if (!options.out.empty()) OutputFile probe(options.out);
  if (!options.plot.empty()) OutputFile probe(options.plot);

  const TemporaryDirectory mem("deltactl_cosim");  // the network's .mem files and identify.mem
  golden::write_export(quantised, mem.path());
  CosimOptions cosim;
  cosim.model = &weights.model;
  cosim.fidelity = options.fidelity == "model" ? BoardFidelity::kModel : BoardFidelity::kRtl;
  cosim.mem_dir = mem.path();
  cosim.network = &quantised;
  cosim.trained_min_m = weights.trained_min_m;
  cosim.trained_max_m = weights.trained_max_m;
  cosim.effects = effects;
  cosim.trajectory = options.trajectory;
  cosim.duration_s = options.duration_s;
  cosim.session.target_fill = options.target_fill;
  const CosimResult result = simulate(options, cosim);
  const double from_s = options.settle_s;
  const TrackingSummary summary = summarise(result, from_s);
  const double path_s = static_cast<double>(result.stream.planned - result.approach_samples) / 1e3;
  std::cout << "Co-simulation: '" << options.trajectory << "', " << fixed(path_s, 3) << " s of path after a "
            << fixed(result.approach_samples / 1e3, 3)
            << " s approach, as `host run` streams it; statistics from path time " << from_s << " s ("
            << summary.samples << " samples at 1 kHz)\n\n";
  print_accuracy_tables(options, quantised, summary);
  print_where_it_rests(result, from_s);
  print_link_table(result, cosim);
  const controller::StreamingResult& r = result.stream;
  if (!options.out.empty()) {
    write_samples(options.out, result, command_line);
    std::cout << "\nrecording: " << options.out << '\n';
  }
  if (!options.plot.empty()) {
    write_cosim_plot(options.plot, result,
                     std::string("Co-simulation: ") + (options.fidelity == "model" ? "model board" : "board RTL") +
                         " + plants + virtual robot, " + options.trajectory);
    std::cout << "plot: " << options.plot << '\n';
  }
  if (r.outcome != controller::StreamingResult::Outcome::kCompleted || r.played != r.planned ||
      result.pins.encoder_error_bits != 0 || result.pins.fault_cause_bits != 0) {
    std::cerr << "deltactl: cosim: the stream did not complete, or the encoders or the joint safety faulted (see the "
                 "table)\n";
    throw CommandExit{kExitFailure};
  }
}

const RegisterCommand command("cosim", 70, [](CLI::App& root) {
  auto options = std::make_shared<CosimCommandOptions>();
  CLI::App* sub = root.add_subcommand(
      "cosim", "Co-simulate the whole robot: the board RTL (network, joint controllers) with plants and effects");
  sub->footer(
      "\nThe lab's host (what `deltactl host run` runs) streams the trajectory's plate positions as 1 kHz\n"
      "setpoints over the board link v2\n"
      "(docs/board_link.md) to the virtual board: the Verilated board core as built for the iCEBreaker\n"
      "(23.25 MHz board clock, 46.5 MHz network clock, 1 Mbaud link; rtl/board/board_core.sv: link,\n"
      "setpoint buffer, network, 10 kHz interpolation, three joint controllers, PWM) driving three joint\n"
      "plants (sim/joint_plant: motor, 66:1 gearbox, friction, gravity); their angles pass the virtual\n"
      "robot's sensor effects into quadrature encoder signals, and the plate position is the true\n"
      "geometry's forward kinematics seen through the frame misalignment. --fidelity model runs the C++\n"
      "model board instead (bit-exact with the RTL, many times faster).\n"
      "The host knows only the link: it identifies the board (weights CRC and build id must match),\n"
      "sets home, plans from the pose the encoders report (a checked jerk-limited approach to the\n"
      "path's start, the path entered and left by ramps of its rate: the plan `host run` streams), and\n"
      "runs the lab's streaming loop, every deadline kept in board time. Statistics start at path time\n"
      "--settle; t = 0 is when the first sample became the joint reference.\n"
      "Output: tables on stdout; --out: a CSV with the recording columns (docs/contracts.md: t_s,\n"
      "alpha*_deg = encoder readings, x/y/z_m = measured plate) plus references, network answers, plant\n"
      "angles, currents.\n"
      "Exit 1 when the stream does not complete, an encoder skips a state or the board's joint safety\n"
      "stops the torque (following error, watchdog, travel limits). Exit 2 on bad input, including a\n"
      "trajectory the host's check refuses before any motion (as host run: a sample beyond the joint\n"
      "limits or the weights' trained range; its file and line named).\n"
      "Example: deltactl cosim --weights weights/paper_like.json --effects sim/paper_like_effects.json \\\n"
      "           --duration 2 --out cosim.csv --plot cosim.png");
  sub->add_option("--weights", options->weights, "network weights (W.json: model 'deployed' or 'network', 25 hidden)")
      ->required();
  sub->add_option("--effects", options->effects, "virtual robot's effects (JSON); none: the nominal robot");
  sub->add_option("--trajectory", options->trajectory,
                  "NAME (experiment1, experiment2, validation, sweep, pick-place, ...), FILE.csv or move:X,Y,Z;... as "
                  "host run takes it")
      ->capture_default_str();
  sub->add_option("--duration", options->duration_s, "seconds of trajectory time (0: the trajectory's own length)")
      ->capture_default_str()
      ->check(options::real_number(0, 600));
  sub->add_option("--settle", options->settle_s, "statistics from this path time on [s]")
      ->capture_default_str()
      ->check(options::real_number(0, 3600));
  sub->add_option("--fidelity", options->fidelity,
                  "rtl: the Verilated board core; model: the C++ model board (bit-exact, faster)")
      ->capture_default_str()
      ->check(CLI::IsMember({"rtl", "model"}));
  sub->add_option("--fill", options->target_fill,
                  "setpoints the host keeps ahead of the board (1 .. its buffer's depth)")
      ->capture_default_str()
      ->check(CLI::Range(1, static_cast<int>(board::kSetpointDepth)));
  sub->add_option("--out", options->out, "CSV of the run at 1 kHz");
  sub->add_option("--plot", options->plot, "PNG: plate error, joint tracking, currents");
  sub->callback([options] {
    run_cosim_command(*options, "deltactl cosim --weights " + options->weights +
                                    (options->effects.empty() ? "" : " --effects " + options->effects) +
                                    " --trajectory " + options->trajectory + " --duration " +
                                    format_number(options->duration_s));
  });
});

}  // namespace
}  // namespace delta::cosim
