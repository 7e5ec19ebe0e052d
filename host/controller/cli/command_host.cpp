// deltactl host: the host controller on the lab PC (SPEC.md, "The board and the lab PC"): `status`
// identifies the board and prints its state, `home` sets the encoders' home with the arms on their
// fixture, `run` checks a trajectory whole, enables, streams it paced by telemetry, stops and
// disables, recording every telemetry frame. Read delta/controller/host_run.hpp first.
#include <dirent.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <iostream>
#include <memory>
#include <optional>
#include <system_error>
#include <thread>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "delta/board_facts.hpp"
#include "delta/command.hpp"
#include "delta/controller/board_network.hpp"
#include "delta/controller/host_run.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/input_error.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/options.hpp"
#include "delta/output_file.hpp"
#include "delta/table.hpp"

namespace delta::controller {
namespace {

constexpr int kExitFault = 3;     // the board faulted (cause printed)
constexpr int kExitLinkLost = 4;  // the link was lost (or the port could not be opened)
constexpr int kExitMismatch = 5;  // the board's gateware or weights differ from W.json
constexpr double kCountDeg = board::kEncoderCountMicrodeg * 1e-6;
constexpr double kCurrentCodeA = board::kCurrentFullScaleMilliamp / 1000.0 / board::kCurrentLimitCode;

volatile std::sig_atomic_t stop_signal = 0;
void request_stop(int signal_number) { stop_signal = signal_number; }

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "deltactl: error: " << message << '\n';
  throw CommandExit{code};
}

std::string hex(std::uint32_t value) { return golden::hex_word(value, 32); }

// PATH as given, or NAME under /dev/serial/by-id, or "icebreaker": the iCEBreaker's UART (the
// FT2232H's second interface, ...-if01-port0).
std::string resolve_port(const std::string& port) {
  if (port.find('/') != std::string::npos) return port;
  const std::string folder = "/dev/serial/by-id/";
  if (port != "icebreaker") return folder + port;
  std::string found;
  if (DIR* dir = ::opendir(folder.c_str())) {
    while (dirent* entry = ::readdir(dir)) {
      const std::string name = entry->d_name;
      if (name.find("iCEBreaker") != std::string::npos && name.find("if01") != std::string::npos) found = folder + name;
    }
    ::closedir(dir);
  }
  if (found.empty())
    fail(kExitLinkLost, "--port icebreaker: no iCEBreaker UART under " + folder + " (is it plugged in?)");
  return found;
}

std::unique_ptr<io::SerialPort> open_port(const std::string& port) {
  const std::string path = resolve_port(port);
  try {
    return std::make_unique<io::SerialPort>(path, static_cast<int>(board::kLinkBaud));
  } catch (const std::system_error& error) {
    fail(kExitLinkLost, std::string("--port ") + error.what());
  }
}

link::SessionOptions session_options(int link_timeout_ms) {
  link::SessionOptions options;
  options.frame_timeout_ms = link_timeout_ms;
  options.keep_telemetry = false;
  return options;
}

// Identify, then the newest telemetry; link errors end the command with exit 4.
struct Connected {
  link::IdentifyPayload identify;
  link::TelemetryPayload telemetry;
};
Connected connect(link::LinkSession& session) {
  try {
    Connected c;
    c.identify = session.identify();
    c.telemetry = session.next_telemetry();
    return c;
  } catch (const link::LinkError& error) {
    fail(error.kind() == link::LinkError::Kind::kProtocol ? kExitMismatch : kExitLinkLost, error.what());
  }
}

// ---------------------------------------------------------------------------------------------
struct StatusOptions {
  std::string port;
  bool json = false;
  int link_timeout_ms = 100;
};

void run_status(const StatusOptions& options) {
  auto port = open_port(options.port);
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  const link::TelemetryPayload& t = c.telemetry;
  const bool gateware_matches = c.identify.build_id == kGatewareBuildId;
  if (options.json) {
    nlohmann::json out = {{"port", port->name()},
                          {"low_latency", port->info().low_latency},
                          {"port_notes", port->info().notes},
                          {"protocol", c.identify.protocol_version},
                          {"gateware_build_id", hex(c.identify.build_id)},
                          {"gateware_matches_host", gateware_matches},
                          {"weights_crc", hex(c.identify.weights_crc)},
                          {"board_clock_hz", c.identify.board_clock_hz},
                          {"network_clock_hz", c.identify.network_clock_hz},
                          {"state", state_name(state_of(t))},
                          {"description", link::describe_state(t)},
                          {"fault_bits", t.fault_cause},
                          {"tick", t.tick},
                          {"sample_index", t.sample_index},
                          {"encoder_deg", {t.counts[0] * kCountDeg, t.counts[1] * kCountDeg, t.counts[2] * kCountDeg}},
                          {"bad_frames", t.bad_frames},
                          {"underruns", t.underruns},
                          {"rejected", t.rejected},
                          {"slew_limits", t.slew_limits},
                          {"saturations", t.saturations}};
    std::cout << out.dump() << '\n';
    return;
  }
  std::cout << "board on " << port->name() << (port->info().low_latency ? " (low latency)" : "") << ": link protocol "
            << c.identify.protocol_version << ", gateware " << hex(c.identify.build_id)
            << (gateware_matches ? " (this checkout's)" : " (not this checkout's " + hex(kGatewareBuildId) + ")")
            << ", weights CRC " << hex(c.identify.weights_crc) << ", board clock " << c.identify.board_clock_hz
            << " Hz\n"
            << "state: " << state_name(state_of(t)) << " (" << link::describe_state(t) << ")\n"
            << "encoders: " << fixed(t.counts[0] * kCountDeg, 2) << ", " << fixed(t.counts[1] * kCountDeg, 2) << ", "
            << fixed(t.counts[2] * kCountDeg, 2) << " deg; board time " << fixed(t.tick / 1e4, 4)
            << " s; counters: bad frames " << t.bad_frames << ", underruns " << t.underruns << ", refused "
            << t.rejected << ", slew limits " << t.slew_limits << ", saturations " << t.saturations << '\n';
}

// ---------------------------------------------------------------------------------------------
struct HomeOptions {
  std::string port;
  int link_timeout_ms = 100;
};

void run_home(const HomeOptions& options) {
  auto port = open_port(options.port);
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  if (c.telemetry.has(link::TelemetryFlag::kDriveEnable)) {
    fail(kExitFault, port->name() + ": the drives are on; home only with the drives off and the arms on their fixture");
  }
  try {
    const link::TelemetryPayload t = session.set_home();
    std::cout << "homed: encoders := " << fixed(board::kHomeCount * kCountDeg, 2) << " deg (" << link::describe_state(t)
              << ")\n";
  } catch (const link::LinkError& error) {
    fail(error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault, error.what());
  }
}

// ---------------------------------------------------------------------------------------------
struct RunOptions {
  std::string port;
  std::string weights;
  std::string trajectory;
  double duration_s = 0.0;
  std::string record;
  int link_timeout_ms = 100;
};

// The recording's rows, off the streaming thread.
struct Recorder {
  OutputFile file;
  TrackingStatistics tracking;
  std::uint64_t rows = 0;
  std::optional<std::uint16_t> underruns_at_first_play;
  std::uint16_t underruns_at_end = 0;

  explicit Recorder(const std::string& path) : file(path) {
    file.stream() << "# deltactl host run: one row per board telemetry frame (1 kHz of board time)\n"
                     "# t_s: board time; *_ref_m: the position sent for the sample whose answer is the joint\n"
                     "# reference at t_s; alpha*_ref_deg: the board's joint references; alpha*_deg: encoders\n"
                     "t_s,x_ref_m,y_ref_m,z_ref_m,alpha1_ref_deg,alpha2_ref_deg,alpha3_ref_deg,alpha1_deg,alpha2_deg,"
                     "alpha3_deg,current1_a,current2_a,current3_a,fault_bits,flags,drives_enabled,sample_index,fill,"
                     "tau_s,stream_sample,bad_frames,underruns,rejected,slew_limits\n";
  }
  void write(const TelemetryRecord& r) {
    const link::TelemetryPayload& t = r.telemetry;
    std::ostream& out = file.stream();
    out << format_number(t.tick / 1e4);
    for (int k = 0; k < 3; ++k) out << ',' << format_number(r.reference_m[k]);
    for (int k = 0; k < 3; ++k) out << ',' << format_number(t.references[k] / 256.0 * kCountDeg);
    for (int k = 0; k < 3; ++k) out << ',' << format_number(t.counts[k] * kCountDeg);
    for (int k = 0; k < 3; ++k) out << ',' << format_number(t.currents[k] * kCurrentCodeA);
    out << ',' << int(t.fault_cause) << ',' << int(t.flags) << ',' << (t.has(link::TelemetryFlag::kDriveEnable) ? 1 : 0)
        << ',' << t.sample_index << ',' << t.fill << ',' << format_number(r.tau_s) << ',' << r.stream_sample << ','
        << t.bad_frames << ',' << t.underruns << ',' << t.rejected << ',' << t.slew_limits << '\n';
    ++rows;
    if (r.stream_sample >= 0 && t.has(link::TelemetryFlag::kDriveEnable)) {
      tracking.add(t);
      if (!underruns_at_first_play) underruns_at_first_play = t.underruns;
      underruns_at_end = t.underruns;
    }
  }
};

void print_summary(const StreamingResult& s, const link::LinkSession& session, const Recorder& recorder,
                   const std::string& record_path, double wall_s, bool fifo) {
  const link::LinkStatistics& link = session.statistics();
  const link::TelemetryPayload& last = *session.last_telemetry();
  const Vec3 rms = recorder.tracking.rms_deg();
  const std::uint64_t host_bad = link.decoder.bad_crc + link.decoder.bad_length + link.decoder.unknown_type;
  std::cout << "stream: " << s.played << " of " << s.planned << " samples played from board index " << s.first_index
            << " (" << fixed((s.last.tick - s.first.tick) / 1e4, 3) << " s of board time, " << fixed(wall_s, 1)
            << " s wall)\n"
            << "link: " << link.telemetry_frames << " telemetry frames (lost " << link.lost_telemetry << ", skipped "
            << link.skipped_telemetry << "), longest gap " << fixed(s.longest_telemetry_gap_ms, 1)
            << " ms wall; setpoints sent " << link.setpoints_sent << " (resent " << link.setpoints_resent
            << "); bad frames: board " << last.bad_frames - s.first.bad_frames << ", host " << host_bad << " (crc "
            << link.decoder.bad_crc << ", length " << link.decoder.bad_length << ", type " << link.decoder.unknown_type
            << "); refused " << last.rejected - s.first.rejected << "; underruns while streaming "
            << (recorder.underruns_at_first_play ? recorder.underruns_at_end - *recorder.underruns_at_first_play : 0)
            << "; slew limits " << last.slew_limits - s.first.slew_limits << '\n'
            << "loop (" << (fifo ? "SCHED_FIFO" : "normal scheduling")
            << ", 1 ms absolute deadlines): wake latency p50 " << fixed(s.latency.percentile_us(50), 0) << " us, p99 "
            << fixed(s.latency.percentile_us(99), 0) << " us, p99.9 " << fixed(s.latency.percentile_us(99.9), 0)
            << " us, max " << fixed(s.latency.max_us(), 0) << " us; overruns " << s.overruns << " in " << s.cycles
            << " cycles\n"
            << "tracking (encoder - joint reference while streaming, " << recorder.tracking.frames << " frames): rms "
            << fixed(rms[0], 4) << " / " << fixed(rms[1], 4) << " / " << fixed(rms[2], 4) << " deg, max "
            << fixed(recorder.tracking.max_abs_deg[0], 3) << " / " << fixed(recorder.tracking.max_abs_deg[1], 3)
            << " / " << fixed(recorder.tracking.max_abs_deg[2], 3) << " deg\n"
            << "recording: " << record_path << " (" << recorder.rows << " rows)\n";
}

void run_run(const RunOptions& options) {
  // ---- everything checked before the port is opened ----
  const BoardWeights weights = read_board_weights(options.weights);
  const Path path = load_path(options.trajectory, options.duration_s);
  const StreamLimits limits;
  {
    // The path alone (from its own start): the approach is checked once the pose is known.
    const StreamPlan plan(path, path.samples.front().position_m, limits);
    if (auto violation = check_plan(plan, options.trajectory, weights.trained_min_m, weights.trained_max_m, limits)) {
      fail(kExitBadInput, *violation + "; nothing sent");
    }
  }
  auto recorder = std::make_unique<Recorder>(options.record);  // refuses a bad path before the port

  // ---- disconnected -> idle: identify, the board must run what W.json quantises to ----
  auto port = open_port(options.port);
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  const std::uint32_t crc = weights_crc(weights.network);
  if (c.identify.build_id != kGatewareBuildId || c.identify.weights_crc != crc) {
    fail(kExitMismatch, port->name() + ": the board runs gateware " + hex(c.identify.build_id) + " with weights CRC " +
                            hex(c.identify.weights_crc) + "; this host expects gateware " + hex(kGatewareBuildId) +
                            " and weights CRC " + hex(crc) + " (" + options.weights + ")");
  }
  const link::TelemetryPayload& t0 = c.telemetry;
  std::cerr << "host: " << state_name(HostState::kDisconnected) << " -> " << state_name(state_of(t0)) << " ("
            << link::describe_state(t0) << ")\n";
  if (t0.has(link::TelemetryFlag::kFault)) {
    fail(kExitFault, port->name() + ": the board has a latched fault: " + link::describe_fault(t0.fault_cause) +
                         " (clear it deliberately; this host re-enables nothing by itself)");
  }
  if (t0.has(link::TelemetryFlag::kDriveEnable)) {
    fail(kExitFault, port->name() + ": the drives are already on (another controller?); refusing to run");
  }
  if (!t0.has(link::TelemetryFlag::kHomed)) {
    fail(kExitFault, port->name() + ": the board is not homed (put the arms on their fixture: deltactl host home)");
  }

  // ---- the approach from the pose the encoders report, checked with the rest ----
  Vec3 counts_deg;
  for (int j = 0; j < 3; ++j) counts_deg[j] = t0.counts[j] * kCountDeg;
  Vec3 start;
  try {
    start = locate_plate(weights.network, Geometry::nominal(), counts_deg);
  } catch (const std::runtime_error& error) {
    fail(kExitFault, port->name() + ": the encoders' pose: " + error.what());
  }
  StreamPlan plan(path, start, limits);
  if (auto violation = check_plan(plan, options.trajectory, weights.trained_min_m, weights.trained_max_m, limits)) {
    fail(kExitBadInput, *violation + " (from the encoders' pose; no motion)");
  }

  // ---- homed -> running ----
  const std::string lock_note = lock_memory();
  struct sigaction action {};
  action.sa_handler = request_stop;
  sigemptyset(&action.sa_mask);
  for (int signal_number : {SIGINT, SIGTERM}) ::sigaction(signal_number, &action, nullptr);
  try {
    session.enable();
  } catch (const link::LinkError& error) {
    fail(error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault, error.what());
  }
  std::cerr << "host: homed -> running: " << plan.size() << " samples (" << plan.approach_samples()
            << " to the start, then " << options.trajectory << " for " << fixed(path.duration_s(), 3) << " s)\n";

  RecordQueue queue(1 << 14);
  StreamingOptions streaming;
  streaming.link_timeout_ms = options.link_timeout_ms;
  streaming.session = session.options();
  StreamingLoop loop(session, plan, weights.network, start, queue, streaming, stop_signal);
  const auto wall_start = std::chrono::steady_clock::now();
  std::thread streamer([&loop] { loop.run(); });
  // This thread: the recording and the progress.
  std::atomic<bool> streaming_done{false};
  std::thread waiter([&] {
    streamer.join();
    streaming_done.store(true);
  });
  TelemetryRecord r;
  auto next_progress = wall_start + std::chrono::seconds(5);
  bool warned = false;
  while (!streaming_done.load()) {
    while (queue.pop(r)) recorder->write(r);
    if (!warned && !loop.result().realtime_note.empty() && loop.result().cycles > 0) {
      std::cerr << "host: warning: real-time scheduling not granted (" << loop.result().realtime_note
                << (lock_note.empty() ? "" : "; " + lock_note) << "): running with normal priority\n";
      warned = true;
    }
    if (std::chrono::steady_clock::now() >= next_progress) {
      std::cerr << "host: " << loop.played() << " of " << plan.size() << " samples played\n";
      next_progress += std::chrono::seconds(5);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  waiter.join();
  while (queue.pop(r)) recorder->write(r);
  const StreamingResult& result = loop.result();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // ---- stop: hold and disable (nothing is ever re-enabled here) ----
  int code = kExitOk;
  std::string error_line;
  switch (result.outcome) {
    case StreamingResult::Outcome::kCompleted:
    case StreamingResult::Outcome::kStopped:
      try {
        session.hold();
        session.disable();
        std::cerr << "host: running -> homed (drives off)\n";
      } catch (const link::LinkError& error) {
        code = error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault;
        error_line = std::string("stopping: ") + error.what();
      }
      if (code == kExitOk && result.outcome == StreamingResult::Outcome::kStopped) {
        std::cerr << "host: stopped by signal " << stop_signal << " (controlled stop, drives off)\n";
        code = 128 + static_cast<int>(stop_signal);
      }
      break;
    case StreamingResult::Outcome::kFault:
      code = kExitFault;
      error_line = port->name() + ": the board faulted: " + result.cause + " (" + link::describe_state(result.last) +
                   "); drives off, nothing re-enabled";
      try {
        session.send_command(link::Command::kDisable);
      } catch (const link::LinkError&) {
      }
      break;
    case StreamingResult::Outcome::kLinkLost:
      code = kExitLinkLost;
      error_line =
          port->name() + ": link lost: " + result.cause + "; the board's watchdog stops the torque; nothing re-enabled";
      try {
        session.send_command(link::Command::kDisable);  // in case the line is still there
      } catch (const link::LinkError&) {
      }
      break;
  }
  recorder->file.commit();
  print_summary(result, session, *recorder, options.record, wall, result.realtime_note.empty());
  if (queue.dropped() > 0) std::cerr << "host: warning: " << queue.dropped() << " telemetry records not recorded\n";
  if (!error_line.empty()) fail(code, error_line);
  if (code != kExitOk) throw CommandExit{code};
}

const RegisterCommand command("host", 75, [](CLI::App& root) {
  CLI::App* host = root.add_subcommand("host", "The host controller: talk to the board (or the virtual board)");
  host->require_subcommand(1);
  host->footer(
      "\nPORT: a serial device path (/dev/ttyUSB1, a virtual board's --link PATH), a name under\n"
      "/dev/serial/by-id/, or 'icebreaker' (the iCEBreaker's UART found there). Opened raw 8N1 at\n"
      "1 Mbaud, exclusively, with the driver's low-latency flag where it has one.\n"
      "Exit codes: 0 completed; 2 bad input, found before any motion; 3 the board faulted or is not\n"
      "ready (the cause is printed); 4 the link was lost (or the port cannot be opened); 5 the board's\n"
      "gateware or weights differ from W.json; 128+N after a controlled stop on signal N (SIGINT, SIGTERM).");

  auto status = std::make_shared<StatusOptions>();
  CLI::App* s = host->add_subcommand("status", "Identify the board and print its state");
  s->add_option("--port", status->port, "serial port (see 'deltactl host --help')")->required();
  s->add_flag("--json", status->json, "one JSON object on stdout");
  s->add_option("--link-timeout-ms", status->link_timeout_ms, "wall time without a frame: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  s->callback([status] { run_status(*status); });

  auto home = std::make_shared<HomeOptions>();
  CLI::App* h = host->add_subcommand("home", "Set the encoders' home count (arms on their home fixture, drives off)");
  h->add_option("--port", home->port, "serial port")->required();
  h->add_option("--link-timeout-ms", home->link_timeout_ms, "wall time without a frame: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  h->callback([home] { run_home(*home); });

  auto run = std::make_shared<RunOptions>();
  CLI::App* r = host->add_subcommand("run", "Check a trajectory, enable, stream it, stop, disable; record the run");
  r->footer(
      "\nThe whole plan is checked before the port is opened (and again with the move from the pose the\n"
      "encoders report): every 1 kHz sample reachable, inside the network's trained range and the joint\n"
      "travel, joint velocity <= 100 deg/s, acceleration <= 1e4 deg/s^2, jerk <= 1e6 deg/s^3; the first\n"
      "offending sample is named (FILE:LINE: reason), exit 2, no byte sent. The board must be homed and\n"
      "free of faults. The plate moves in a jerk-limited straight line to the trajectory's start, then\n"
      "along it, its time ramped in and out (0.3 s); SIGINT or SIGTERM ramps it to rest on the path,\n"
      "then holds and disables. A streaming thread with 1 ms absolute deadlines (SCHED_FIFO and locked\n"
      "memory when permitted) sends setpoints paced by the board's telemetry; no telemetry for\n"
      "--link-timeout-ms of wall time is link loss (exit 4). OUT.csv: one row per telemetry frame.");
  r->add_option("--port", run->port, "serial port")->required();
  r->add_option("--weights", run->weights, "W.json the board must run (its CRC and this checkout's gateware)")
      ->required();
  r->add_option("--trajectory", run->trajectory,
                "a trajectory of 'deltactl simulate' (experiment1, ...) or FILE.csv with t_s,x_m,y_m,z_m")
      ->required();
  r->add_option("--duration", run->duration_s, "seconds of trajectory time (default: all of it)")
      ->check(options::real_number(0, 86400, true));
  r->add_option("--record", run->record, "OUT.csv: one row per telemetry frame")->required();
  r->add_option("--link-timeout-ms", run->link_timeout_ms, "wall time without telemetry: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  r->callback([run] { run_run(*run); });
});

}  // namespace
}  // namespace delta::controller
