// deltactl host: the host controller on the lab PC (docs/contracts.md, "The board and the lab PC"): `status`
// identifies the board and prints its state, `load` loads a model (W.json) onto it
// (delta/controller/model_load.hpp), `home` homes against the robot's references (home
// switches, delta/controller/homing.hpp) or, --by-hand, sets the counts where the arms are, `record` records the
// telemetry with the drives off (the calibration drag), `run` checks a trajectory whole, enables, streams it paced by
// telemetry, stops and disables, recording every telemetry frame (delta/controller/run_job.hpp); `serve` is the
// long-running controller with its control socket and `ctl` its client (serve.hpp); `latency` measures the 1 kHz loop's
// wake latency. Read delta/controller/host_run.hpp first.
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <chrono>
#include <cmath>
#include <csignal>
#include <iostream>
#include <memory>
#include <optional>
#include <system_error>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "delta/board_facts.hpp"
#include "delta/controller/homing.hpp"
#include "delta/controller/host_run.hpp"
#include "delta/controller/model_load.hpp"
#include "delta/controller/realtime.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/controller/serve.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/deploy/config.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/input_error.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/output_file.hpp"
#include "delta/run_files.hpp"
#include "delta/table.hpp"
#include "delta/utf8_text.hpp"
#include "options.hpp"

namespace delta::controller {
namespace {

volatile std::sig_atomic_t stop_signal = 0;
void request_stop(int signal_number) {
  if (stop_signal == 0) stop_signal = signal_number;
}
// SIGINT, SIGTERM, SIGHUP (a closed terminal or SSH session) and SIGQUIT become a stop request (a
// controlled stop, the drives off, the recording kept), not the end of the process. SIGPIPE (a
// closed stdout) is ignored: the run goes on to its end.
void install_stop_handlers() {
  struct sigaction action {};
  action.sa_handler = request_stop;
  sigemptyset(&action.sa_mask);
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) ::sigaction(signal_number, &action, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
}

// SIGUSR1 to `host serve`: an e-stop, latched as a client's is (serve.hpp).
volatile std::sig_atomic_t estop_signals = 0;
void count_estop(int) { estop_signals = estop_signals + 1; }
void install_estop_handler() {
  struct sigaction action {};
  action.sa_handler = count_estop;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGUSR1, &action, nullptr);
}

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "deltactl: error: " << escape_invalid_utf8(message) << '\n';
  throw CommandExit{code};
}

std::string hex(std::uint32_t value) { return golden::hex_word(value, 32); }

// The library's failures as the command line's exit.
template <typename Body>
auto or_exit(Body&& body) -> decltype(body()) {
  try {
    return body();
  } catch (const HostFailure& error) {
    fail(error.code(), error.what());
  }
}

std::unique_ptr<io::SerialPort> open_port(const std::string& port) {
  return or_exit([&] { return open_board_port(port); });
}
link::SessionOptions session_options(int link_timeout_ms) { return host_session_options(link_timeout_ms); }
Connected connect(link::LinkSession& session) {
  return or_exit([&] { return connect_board(session); });
}

// ---------------------------------------------------------------------------------------------
struct StatusOptions {
  std::string port;
  std::string socket;  // the controller's, when it holds the port ("": the config's)
  bool json = false;
  int link_timeout_ms = link::kLinkTimeoutMs;
};
bool status_from_controller(const StatusOptions& options);

void run_status(const StatusOptions& options) {
  std::unique_ptr<io::SerialPort> port;
  try {
    port = open_board_port(options.port);
  } catch (const HostFailure& error) {
    // Held by the controller (host serve owns the port): its status, the e-stop latch with it.
    if (status_from_controller(options)) return;
    fail(error.code(), error.what());
  }
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  const link::TelemetryPayload& t = c.telemetry;
  const bool gateware_matches = c.identify.build_id == kGatewareBuildId;
  const Referencing referencing = board_referencing(t);
  // Homing not finished (stopped or failed): the board stays homing with provisional counts.
  const bool unfinished = homing_unfinished(t);
  const bool model = board_has_model(t);  // a complete model whose CRC checked (identify's CRC is its)
  if (options.json) {
    nlohmann::json out = {
        {"port", port->name()},
        {"low_latency", port->info().low_latency},
        {"port_notes", port->info().notes},
        {"protocol", c.identify.protocol_version},
        {"gateware_build_id", hex(c.identify.build_id)},
        {"gateware_matches_host", gateware_matches},
        {"weights_crc", model ? nlohmann::json(hex(c.identify.weights_crc)) : nlohmann::json()},
        {"model", model ? "loaded" : "none"},
        {"board_clock_hz", c.identify.board_clock_hz},
        {"network_clock_hz", c.identify.network_clock_hz},
        {"state", state_name(state_of(t))},
        {"description", link::describe_state(t)},
        {"fault_bits", t.fault_cause},
        {"board_fault_bits", t.board_fault},
        {"estop_on_board", t.estop},
        {"fault", t.has(link::TelemetryFlag::kFault) ? nlohmann::json(link::describe_fault(t)) : nlohmann::json()},
        {"tick", t.tick},
        {"sample_index", t.sample_index},
        {"encoder_deg", {t.count_deg(0), t.count_deg(1), t.count_deg(2)}},
        {"homed", referencing != Referencing::kNone},
        {"homed_by", referencing == Referencing::kHomeSwitches ? "reference"
                     : referencing == Referencing::kHand       ? "hand"
                                                               : "none"},
        {"homing_unfinished", unfinished},
        {"homing", t.has(link::TelemetryFlag::kHoming)},
        {"referenced", {t.referenced(0), t.referenced(1), t.referenced(2)}},
        {"home_switches", {t.home_switch(0), t.home_switch(1), t.home_switch(2)}},
        {"play_sides", {t.play_side(0), t.play_side(1), t.play_side(2)}},
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
            << ", board clock " << c.identify.board_clock_hz << " Hz\n"
            << "model: "
            << (model ? "loaded, weights CRC " + hex(c.identify.weights_crc)
                      : "no model (deltactl host load --port " + options.port + " --weights W.json)")
            << '\n'
            << "state: " << state_name(state_of(t)) << " (" << link::describe_state(t) << ")\n"
            << "homed: "
            << (referencing == Referencing::kHomeSwitches ? std::string("at the home switches")
                                                          : "no (" + unreferenced_reason(t) + "; deltactl host home)")
            << '\n'
            << "encoders: " << fixed(t.count_deg(0), 2) << ", " << fixed(t.count_deg(1), 2) << ", "
            << fixed(t.count_deg(2), 2) << " deg; board time " << fixed(t.time_s(), 4) << " s; counters: bad frames "
            << t.bad_frames << ", underruns " << t.underruns << ", refused " << t.rejected << ", slew limits "
            << t.slew_limits << ", saturations " << t.saturations << '\n';
}

// ---------------------------------------------------------------------------------------------
struct LoadOptions {
  std::string port;
  std::string weights;
  bool json = false;
  int link_timeout_ms = link::kLinkTimeoutMs;
};

void run_load(const LoadOptions& options) {
  // W.json read, quantised and imaged before the port is opened: a bad file sends nothing.
  const golden::BoardWeights weights = golden::read_board_weights(options.weights);
  try {
    golden::model_frames(weights.network);
  } catch (const std::invalid_argument& error) {
    fail(kExitBadInput, options.weights + ": not a model this board takes: " + error.what());
  }
  auto port = open_port(options.port);
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  const ModelLoaded loaded = or_exit([&] { return load_board_model(session, c, weights.network, port->name()); });
  if (options.json) {
    std::cout << nlohmann::json{{"port", port->name()},
                                {"weights", options.weights},
                                {"weights_crc", hex(loaded.crc)},
                                {"model", "loaded"},
                                {"frames", loaded.frames},
                                {"attempts", loaded.attempts},
                                {"retry_reason",
                                 loaded.retry_reason.empty() ? nlohmann::json() : nlohmann::json(loaded.retry_reason)},
                                {"seconds", loaded.seconds}}
                     .dump()
              << '\n';
    return;
  }
  std::cout << "load: model " << hex(loaded.crc) << " (" << options.weights << ") on " << port->name() << ", "
            << loaded.frames << " frames in " << fixed(loaded.seconds, 3) << " s"
            << (loaded.attempts > 1 ? " (the second attempt; the first: " + loaded.retry_reason + ")" : "") << '\n';
}

// ---------------------------------------------------------------------------------------------
struct HomeOptions {
  std::string port;
  std::string weights;
  bool by_hand = false;
  bool quiet = false;
  HomingOptions homing;
  int link_timeout_ms = link::kLinkTimeoutMs;
};

void run_home(const HomeOptions& options) {
  // The weights are read (and refused) before the port is opened.
  std::optional<golden::BoardWeights> weights;
  if (!options.by_hand) {
    if (options.weights.empty()) fail(kExitBadInput, "host home: needs --weights W.json (or --by-hand)");
    weights = golden::read_board_weights(options.weights);
  }
  install_stop_handlers();
  auto port = open_port(options.port);
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  if (c.telemetry.has(link::TelemetryFlag::kDriveEnable)) {
    fail(kExitFault, port->name() + ": the drives are on; home only with the drives off");
  }
  if (options.by_hand) {
    try {
      // A homing that did not finish (stopped, failed) leaves the board homing: a hold ends it, so
      // that the board is homed by hand, not homing with provisional counts.
      if (c.telemetry.has(link::TelemetryFlag::kHoming)) {
        session.command(link::Command::kHold,
                        [](const link::TelemetryPayload& f) { return !f.has(link::TelemetryFlag::kHoming); });
      }
      // Set home gives the joints not referenced the home count; referenced joints keep theirs.
      const link::TelemetryPayload homed = session.set_home();
      const int referenced = (homed.home >> 3) & 7;
      std::cout << "homed by hand: encoders := " << fixed(board::kHomeCount * board::kEncoderCountDeg, 2)
                << " deg where the arms are"
                << (referenced != 0 ? " (joints referenced at their switches keep their counts)" : "") << " ("
                << link::describe_state(homed) << ")"
                << (referenced == 7 ? "\n"
                                    : "; runs need --allow-unreferenced until 'deltactl host home' finds the "
                                      "references\n");
    } catch (const link::LinkError& error) {
      fail(error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault, error.what());
    }
    return;
  }
  or_exit([&] { check_board_identity(c, *weights, options.weights, port->name()); });
  const auto log = [&](const std::string& line) {
    if (!options.quiet) std::cerr << line << std::endl;
  };
  // The jogs' watch loop reads every telemetry frame and feeds the board's watchdog: real time when
  // permitted, as a run's streaming thread.
  const std::string realtime_note = make_thread_realtime(80);
  if (!realtime_note.empty() && !options.quiet) std::cerr << "host home: normal scheduling (" << realtime_note << ")\n";
  const HomingReport report =
      or_exit([&] { return home_at_references(session, *weights, options.homing, log, &stop_signal); });
  const link::TelemetryPayload& t = report.final;
  std::cout << "home: ok, every joint at its reference (" << link::describe_state(t) << "); encoders "
            << fixed(t.count_deg(0), 2) << ", " << fixed(t.count_deg(1), 2) << ", " << fixed(t.count_deg(2), 2)
            << " deg; moved " << fixed(report.travelled_deg[0], 1) << ", " << fixed(report.travelled_deg[1], 1) << ", "
            << fixed(report.travelled_deg[2], 1) << " deg in " << fixed(report.seconds, 1) << " s (" << report.enables
            << " jogs)\n";
}

// ---------------------------------------------------------------------------------------------
struct RunOptions {
  std::string port;
  std::string weights;
  std::string trajectory;
  double duration_s = 0.0;
  std::string record;
  int link_timeout_ms = link::kLinkTimeoutMs;
  double following_error_deg = 2.0;
  bool allow_unreferenced = false;
  bool check = false;  // the plan checked, nothing opened or sent
};

// host run --check: the allowed box, then OK or every problem (exit 2).
void run_check(const golden::BoardWeights& weights, const RunRequest& request, const std::string& weights_path) {
  const JointTravel travel = joint_travel();
  std::cout << "allowed box (" << weights_path
            << "'s trained range): " << motion::box_text(weights.trained_min_m, weights.trained_max_m)
            << "; joint travel " << fixed(travel.min_deg, 2) << " .. " << fixed(travel.max_deg, 2) << " deg\n";
  const Path path = load_path(request.trajectory, request.duration_s);
  const std::vector<std::string> problems = check_path(weights, path, request);
  if (problems.empty()) {
    std::cout << "check: OK, " << request.trajectory << " (" << path.samples.size() << " samples, "
              << fixed(path.duration_s(), 3)
              << " s) inside the box and the joint limits; nothing sent (the move from where the encoders put the "
                 "plate to its start is checked when the run starts)\n";
    return;
  }
  for (const std::string& problem : problems) std::cout << "problem: " << problem << '\n';
  fail(kExitBadInput, request.trajectory + ": " + std::to_string(problems.size()) +
                          (problems.size() == 1 ? " problem" : " problems") + " (listed above); nothing sent");
}

// `temporary_record`: the recording is the caller's to remove when the run completes, so the
// summary does not name it then.
void run_run(const RunOptions& options, bool temporary_record = false) {
  // Everything checked before the port is opened (the trajectory whole, the recording's path).
  const golden::BoardWeights weights = golden::read_board_weights(options.weights);
  RunRequest request;
  request.trajectory = options.trajectory;
  request.duration_s = options.duration_s;
  request.record = options.record;
  request.allow_unreferenced = options.allow_unreferenced;
  request.link_timeout_ms = options.link_timeout_ms;
  request.following_error_deg = options.following_error_deg;
  if (options.check) return run_check(weights, request, options.weights);
  for (const auto& [name, value] :
       {std::pair<const char*, const std::string*>{"--port", &options.port}, {"--record", &options.record}}) {
    if (value->empty())
      fail(kExitBadInput, std::string(name) +
                              " is required (see 'deltactl host run --help'; "
                              "--check needs neither)");
  }
  auto job = or_exit([&] { return std::make_unique<RunJob>(weights, request); });

  // disconnected -> idle: identify; the board must run what W.json quantises to.
  auto port = open_port(options.port);
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  or_exit([&] {
    check_board_identity(c, weights, options.weights, port->name());
    return 0;
  });
  install_stop_handlers();
  auto next_print = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  const RunOutcome outcome = or_exit([&] {
    return job->execute(
        session, port->name(), c.telemetry, stop_signal,
        [](const std::string& line) { std::cerr << "host: " << line << '\n'; },
        [&](const RunProgress& p) {
          if (std::chrono::steady_clock::now() < next_print) return;
          std::cerr << "host: " << p.played << " of " << p.planned << " samples played\n";
          next_print += std::chrono::seconds(5);
        });
  });
  std::string summary = outcome.summary;
  if (temporary_record && outcome.error.empty() && outcome.code == kExitOk) {
    const std::size_t line = summary.find("recording: ");
    if (line != std::string::npos && (line == 0 || summary[line - 1] == '\n')) {
      summary.erase(line, summary.find('\n', line) == std::string::npos ? std::string::npos
                                                                        : summary.find('\n', line) + 1 - line);
    }
  }
  std::cout << escape_invalid_utf8(summary);
  if (!outcome.error.empty()) fail(outcome.code, outcome.error);
  if (outcome.code != kExitOk) throw CommandExit{outcome.code};
}

// ---------------------------------------------------------------------------------------------
struct ParkOptions {
  std::string port;
  std::string weights;
  std::vector<double> pose_mm;  // empty: the middle of the network's trained range
  std::string record;           // empty: a temporary recording, removed when the park succeeds
  int link_timeout_ms = link::kLinkTimeoutMs;
  bool allow_unreferenced = false;
};

void run_park(const ParkOptions& options) {
  const golden::BoardWeights weights = golden::read_board_weights(options.weights);
  Vec3 pose = 0.5 * (weights.trained_min_m + weights.trained_max_m);
  if (!options.pose_mm.empty()) {
    for (const double v : options.pose_mm) {
      if (!std::isfinite(v)) fail(kExitBadInput, "--pose: X,Y,Z in millimetres, finite numbers (e.g. 0,0,-75)");
    }
    pose = Vec3(options.pose_mm[0], options.pose_mm[1], options.pose_mm[2]) * 1e-3;
  }
  char move[128];
  std::snprintf(move, sizeof move, "move:%.9f,%.9f,%.9f", pose.x(), pose.y(), pose.z());
  RunOptions run;
  run.port = options.port;
  run.weights = options.weights;
  run.trajectory = move;
  run.link_timeout_ms = options.link_timeout_ms;
  run.allow_unreferenced = options.allow_unreferenced;
  run.record = options.record;
  if (run.record.empty()) {
    run.record =
        (std::filesystem::temp_directory_path() / ("deltactl-park-" + std::to_string(::getpid()) + ".csv")).string();
  }
  run_run(run, options.record.empty());  // exits (keeping the recording, named) unless the plate is parked
  if (options.record.empty()) std::filesystem::remove(run.record);
  std::cout << "park: ok, the plate at " << fixed(pose.x() * 1e3, 3) << ", " << fixed(pose.y() * 1e3, 3) << ", "
            << fixed(pose.z() * 1e3, 3) << " mm (the network's frame), drives off\n";
}

// ---------------------------------------------------------------------------------------------
struct RecordOptions {
  std::string port;
  std::string out;
  double duration_s = 0.0;
  int link_timeout_ms = 100;
  bool unreferenced = false;
};

void run_record(const RecordOptions& options) {
  RecordRequest request;
  request.record = options.out;
  request.duration_s = options.duration_s;
  request.unreferenced = options.unreferenced;
  RecordJob job(request);  // the recording's path refused before the port is opened
  auto port = open_port(options.port);
  link::LinkSession session(*port, session_options(options.link_timeout_ms));
  const Connected c = connect(session);
  install_stop_handlers();
  const RunOutcome outcome = or_exit([&] {
    return job.execute(session, port->name(), c.telemetry, stop_signal,
                       [](const std::string& line) { std::cerr << "host: " << line << '\n'; });
  });
  std::cout << outcome.summary;
  if (!outcome.error.empty()) fail(outcome.code, outcome.error);
  if (outcome.code != kExitOk) throw CommandExit{outcome.code};
}

// ---------------------------------------------------------------------------------------------
struct ServeCliOptions {
  std::string config;
  std::string port, weights, socket, record_folder, http, http_token_file;
  int link_timeout_ms = link::kLinkTimeoutMs;
};

void run_serve(const ServeCliOptions& cli) {
  ServeOptions options;
  options.link_timeout_ms = cli.link_timeout_ms;
  if (!cli.config.empty()) {
    const deploy::DeployConfig config = deploy::read_config(cli.config);  // bad: exit 2, file, line, reason
    options.port = config.port;
    options.weights_path = config.weights;
    options.socket_path = config.socket;
    options.following_error_deg = config.following_error_deg;
    options.limits.joint_velocity_deg_s = config.velocity_deg_s;
    options.http = config.http;
    options.http_token_file = config.http_token_file;
  }
  if (!cli.http.empty()) options.http = cli.http;
  if (!cli.http_token_file.empty()) options.http_token_file = cli.http_token_file;
  if (!cli.port.empty()) options.port = cli.port;
  if (!cli.weights.empty()) options.weights_path = cli.weights;
  if (!cli.socket.empty()) options.socket_path = cli.socket;
  if (options.port.empty() || options.weights_path.empty() || options.socket_path.empty()) {
    fail(kExitBadInput, "host serve: needs --config FILE, or --port, --weights and --socket");
  }
  options.record_folder = cli.record_folder;
  if (options.record_folder.empty()) {
    const char* state = std::getenv("STATE_DIRECTORY");  // systemd's StateDirectory=deltactl
    options.record_folder = std::string(state && *state ? state : ".") + "/runs";
  }
  track_run_files(false);  // many runs over its life: each is checked on its own
  if (!options.http.empty() && options.http_token_file.empty()) {
    const char* state = std::getenv("STATE_DIRECTORY");
    options.http_token_file = std::string(state && *state ? state : ".") + "/http-token";
  }
  install_stop_handlers();
  install_estop_handler();
  auto server = or_exit([&] { return std::make_unique<HostServer>(options); });
  server->set_estop_signal(&estop_signals);
  std::cerr << "host serve: board " << options.port << ", weights " << options.weights_path << ", control socket "
            << options.socket_path << ", recordings in " << options.record_folder << '\n';
  if (!options.http.empty()) {
    std::cerr << "host serve: dashboard on " << server->dashboard_url() << "/ (token in " << options.http_token_file
              << ")" << std::endl;
  }
  const int code = server->run(stop_signal);
  std::cerr << "host serve: stopped by signal " << stop_signal << " (drives off)\n";
  if (code != kExitOk) throw CommandExit{code};
}

// ---------------------------------------------------------------------------------------------
struct CtlOptions {
  std::string socket, config = deploy::kDefaultConfigPath;
  bool json = false;
  std::string command;
  std::string trajectory, record;
  double duration_s = 0.0;
  bool no_wait = false;
};

// The socket: --socket, else the config file's [service] socket, else systemd's default.
std::string control_socket(const CtlOptions& options) {
  if (!options.socket.empty()) return options.socket;
  if (::access(options.config.c_str(), R_OK) == 0) {
    return deploy::read_config(options.config, deploy::FileChecks::kNone).socket;  // the weights are serve's
  }
  return deploy::DeployConfig{}.socket;
}

void run_ctl(const CtlOptions& options);

// `host status` on a port the controller holds: the controller's status, as `host ctl status`
// prints it (false when no controller answers on its socket).
bool status_from_controller(const StatusOptions& options) {
  CtlOptions ctl;
  ctl.socket = options.socket;
  ctl.json = options.json;
  ctl.command = "status";
  std::string path;
  try {
    path = control_socket(ctl);
  } catch (const std::exception&) {
    return false;
  }
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (fd < 0 || path.size() >= sizeof address.sun_path) {
    if (fd >= 0) ::close(fd);
    return false;
  }
  std::copy(path.begin(), path.end(), address.sun_path);
  const bool answers = ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
  ::close(fd);
  if (!answers) return false;
  std::cerr << "host status: " << options.port << " is held by the controller on " << path << "; its status:\n";
  run_ctl(ctl);
  return true;
}

// A connection to the controller; exits 4 when it cannot be reached.
int connect_controller(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.size() >= sizeof address.sun_path) fail(kExitBadInput, "--socket '" + path + "': too long");
  std::copy(path.begin(), path.end(), address.sun_path);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    fail(kExitLinkLost, path + ": cannot reach the controller (" + why +
                            "); is it running? systemctl status deltactl, or deltactl host serve");
  }
  return fd;
}

bool send_request(int fd, const nlohmann::json& request) {
  const std::string line = request.dump() + "\n";
  return ::send(fd, line.data(), line.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(line.size());
}

// A stop for the run the controller streams, on a connection of its own (the run's connection
// waits for its end). "" when the controller took it, else why not.
std::string ask_stop(const std::string& path) {
  const int fd = connect_controller(path);
  std::string reply;
  if (send_request(fd, {{"cmd", "stop"}})) {
    char chunk[4096];
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (reply.find('\n') == std::string::npos) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      pollfd p{fd, POLLIN, 0};
      if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
      const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n <= 0) break;
      reply.append(chunk, static_cast<std::size_t>(n));
    }
  }
  ::close(fd);
  if (reply.find('\n') == std::string::npos) return "no answer within 2 s";
  try {
    const nlohmann::json answer = nlohmann::json::parse(reply.substr(0, reply.find('\n')));
    return answer.value("ok", false) ? "" : answer.value("error", std::string("refused"));
  } catch (const nlohmann::json::exception&) {
    return "the reply is not JSON";
  }
}

// The request of `host ctl COMMAND`: for run, the trajectory as the controller sees it.
nlohmann::json ctl_request(const CtlOptions& options) {
  nlohmann::json request = {{"cmd", options.command}};
  if (options.command == "run") {
    // The trajectory as the controller sees it: absolute (it runs elsewhere, maybe as another
    // user). The recording's name as given: the controller writes it in its recordings folder.
    auto absolute = [](const std::string& file) { return std::filesystem::absolute(file).lexically_normal().string(); };
    request["trajectory"] =
        options.trajectory.find('/') != std::string::npos || options.trajectory.find(".csv") != std::string::npos
            ? absolute(options.trajectory)
            : options.trajectory;
    if (options.duration_s > 0.0) request["duration"] = options.duration_s;
    if (!options.record.empty()) request["record"] = options.record;
    // The socket carries UTF-8 text only: a name with other bytes cannot reach the controller.
    for (const auto& [flag, name] :
         {std::pair{"--trajectory", request["trajectory"].get<std::string>()}, std::pair{"--record", options.record}}) {
      if (escape_invalid_utf8(name) != name) {
        fail(kExitBadInput,
             std::string(flag) + " '" + escape_invalid_utf8(name) +
                 "': the name is not UTF-8, and the control socket carries UTF-8 only (rename the file)");
      }
    }
    request["wait"] = !options.no_wait;
  }
  return request;
}

// `host ctl status`'s reply, in words.
void print_controller_status(const nlohmann::json& reply) {
  std::cout << "controller: " << reply.value("state", std::string()) << " (" << reply.value("connection", std::string())
            << ": " << reply.value("note", std::string()) << ")\n"
            << "board: " << reply.value("port", std::string());
  if (reply.contains("description")) std::cout << ", " << reply["description"].get<std::string>();
  std::cout << "\n";
  if (reply.contains("estop") && reply["estop"].value("latched", false)) {
    const nlohmann::json& e = reply["estop"];
    std::cout << "e-stop: latched, by the " << e.value("source", std::string("?"))
              << (e["board_time_s"].is_number() ? " at board time " + fixed(e["board_time_s"].get<double>(), 3) + " s"
                                                : std::string())
              << "; home, enable and run are refused until 'deltactl host ctl clear-fault'\n";
  }
  if (reply.contains("run")) {
    std::cout << "run: " << reply["run"].value("played", 0) << " of " << reply["run"].value("planned", 0)
              << " samples played (" << reply["run"].value("feed", std::string()) << ")\n";
  }
  if (reply.contains("last_run") && reply["last_run"].is_object()) {
    std::cout << "last run: " << reply["last_run"].value("outcome", std::string("refused")) << ", exit "
              << reply["last_run"].value("exit", 0) << ' ' << reply["last_run"].value("error", std::string()) << '\n';
  }
}

void run_ctl(const CtlOptions& options) {
  const std::string path = control_socket(options);
  const nlohmann::json request = ctl_request(options);
  const bool waits = options.command == "run" && !options.no_wait;
  // While a run streams for this client: Ctrl-C (and SIGTERM, SIGHUP, SIGQUIT) stops it at rest.
  if (waits) install_stop_handlers();
  const int fd = connect_controller(path);
  if (!send_request(fd, request)) {
    ::close(fd);
    fail(kExitLinkLost, path + ": the controller closed the connection");
  }
  std::string buffer;
  char chunk[4096];
  bool stop_sent = false;    // the controller took the stop
  std::string stop_refused;  // why it did not (asked again every 0.5 s)
  auto next_ask = std::chrono::steady_clock::now();
  for (;;) {
    std::size_t end;
    while ((end = buffer.find('\n')) == std::string::npos) {
      if (waits && stop_signal != 0 && !stop_sent && std::chrono::steady_clock::now() >= next_ask) {
        if (stop_refused.empty()) {
          std::cerr << "host ctl: signal " << stop_signal
                    << ": asking the controller to stop the run (at rest, drives off)\n";
        }
        const std::string why = ask_stop(path);
        stop_sent = why.empty();
        if (!stop_sent && why != stop_refused)
          std::cerr << "host ctl: the stop was not taken: " << why << " (asking again)\n";
        stop_refused = why;
        next_ask = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
      }
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;  // a signal or nothing yet
      const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n <= 0) {
        ::close(fd);
        fail(kExitLinkLost, path + ": the controller closed the connection before answering");
      }
      buffer.append(chunk, static_cast<std::size_t>(n));
    }
    nlohmann::json reply;
    try {
      reply = nlohmann::json::parse(buffer.substr(0, end));
    } catch (const nlohmann::json::exception&) {
      ::close(fd);
      fail(kExitFailure, path + ": the controller's reply is not JSON");
    }
    buffer.erase(0, end + 1);
    const std::string event = reply.value("event", std::string());
    if (options.json) std::cout << reply.dump() << '\n' << std::flush;
    if (event == "started") {
      if (!options.json)
        std::cerr << "host ctl: run started, recording " << reply.value("record", std::string()) << '\n';
      continue;
    }
    if (event == "progress") {
      if (!options.json) {
        std::cerr << "host ctl: " << reply.value("played", 0) << " of " << reply.value("planned", 0)
                  << " samples played (" << reply.value("feed", std::string()) << ")\n";
      }
      continue;
    }
    ::close(fd);
    int code = reply.value("exit", reply.value("ok", false) ? 0 : kExitFailure);
    if (stop_sent && code == 0 && reply.value("outcome", std::string()) == "stopped") code = 128 + stop_signal;
    if (waits && stop_signal != 0 && !stop_sent && code == 0) {  // interrupted, but the run went on to its end
      std::cerr << "host ctl: the controller never took the stop (" << stop_refused << "); the run "
                << reply.value("outcome", std::string("ended")) << '\n';
      code = 128 + stop_signal;
    }
    if (!options.json) {
      if (options.command == "status" && reply.value("ok", false)) {
        print_controller_status(reply);
      } else if (reply.contains("summary")) {
        std::cout << reply["summary"].get<std::string>();
        if (code == 0 || code > 128) std::cerr << "host ctl: run " << reply.value("outcome", std::string()) << '\n';
      } else if (code == 0) {
        std::cout << options.command << ": ok"
                  << (reply.contains("state") ? " (" + reply["state"].get<std::string>() + ")" : "")
                  << (reply.contains("record") ? ", recording " + reply["record"].get<std::string>() : "") << '\n';
      }
    }
    if (code != 0) {
      const std::string error = reply.value("error", std::string());
      if (!options.json && !error.empty()) std::cerr << "deltactl: error: " << error << '\n';
      if (!options.json && error.empty() && code <= 128) std::cerr << "deltactl: error: refused\n";
      throw CommandExit{code};
    }
    return;
  }
}

// ---------------------------------------------------------------------------------------------
struct LatencyOptions {
  double seconds = 10.0;
  bool normal = false;
  bool json = false;
};

void run_latency(const LatencyOptions& options) {
  const std::string lock_note = options.normal ? "" : lock_memory();
  const WakeLatencyProbe probe = measure_wake_latency(options.seconds, options.normal ? 0 : 80);
  const WakeLatency& w = probe.latency;
  const std::string scheduling = probe.realtime_note.empty() ? "SCHED_FIFO 80" : "normal scheduling";
  if (options.json) {
    std::cout << nlohmann::json{{"seconds", options.seconds},    {"scheduling", scheduling},
                                {"note", probe.realtime_note},   {"cycles", w.count()},
                                {"overruns", probe.overruns},    {"p50_us", w.percentile_us(50)},
                                {"p99_us", w.percentile_us(99)}, {"p999_us", w.percentile_us(99.9)},
                                {"max_us", w.max_us()}}
                     .dump()
              << '\n';
    return;
  }
  std::cout << "1 kHz loop, " << fixed(options.seconds, 0) << " s, " << scheduling
            << (probe.realtime_note.empty() || options.normal ? "" : " (" + probe.realtime_note + ")")
            << ": wake latency p50 " << fixed(w.percentile_us(50), 0) << " us, p99 " << fixed(w.percentile_us(99), 0)
            << " us, p99.9 " << fixed(w.percentile_us(99.9), 0) << " us, max " << fixed(w.max_us(), 0)
            << " us; overruns " << probe.overruns << " in " << w.count() << " cycles\n";
}

// deltactl host status.
void add_status_command(CLI::App* host) {
  auto status = std::make_shared<StatusOptions>();
  CLI::App* s = host->add_subcommand("status", "Identify the board and print its state");
  s->add_option("--port", status->port, "serial port (see 'deltactl host --help')")->required();
  s->add_flag("--json", status->json, "one JSON object on stdout");
  s->add_option("--socket", status->socket,
                "when 'host serve' holds the port: its control socket (default: the config's), whose status "
                "(with the e-stop latch) is printed instead");
  s->add_option("--link-timeout-ms", status->link_timeout_ms, "wall time without a frame: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  s->callback([status] { run_status(*status); });
}

// deltactl host load.
void add_load_command(CLI::App* host) {
  auto load = std::make_shared<LoadOptions>();
  CLI::App* ld = host->add_subcommand("load", "Load a model (W.json) onto the board, drives off: seconds, no flashing");
  ld->footer(
      "\nThe gateware is the same for every model: the network's weights and biases, the deployed model's\n"
      "half-plays and the input scaling are data the board takes over the link (docs/board_link.md, \"The\n"
      "model\"). A board starts with no model and refuses to enable until a load has checked.\n"
      "host load identifies the board (its protocol and gateware build id must be this checkout's, else\n"
      "exit 5 naming both), needs the drives off (else exit 3, nothing sent), sends W.json's 185 model\n"
      "frames paced by the board's acceptance (26 ms of line time) and confirms the load: the telemetry's\n"
      "model flag and the identify's weights CRC equal to W.json's. A refused frame or a mismatch is\n"
      "tried once more from frame 0; then exit 3 naming what failed (the frame refused, the board's CRC\n"
      "against the file's). Prints one line: the model's CRC, the frames sent, the seconds taken.\n"
      "A bad W.json: exit 2, one line, nothing sent. The model stays until the board is reset, powered\n"
      "down, flashed or loaded again; 'host status' says which is loaded ('no model' after a reset).\n"
      "'host run', 'home' and 'park' refuse (exit 5) a board without W.json's model, naming this command.\n"
      "Example: deltactl host load --port icebreaker --weights weights/paper_like_deployed.json");
  ld->add_option("--port", load->port, "serial port (see 'deltactl host --help')")->required();
  ld->add_option("--weights", load->weights, "W.json: the model to load (deltactl train or quantise writes one)")
      ->required();
  ld->add_flag("--json", load->json, "one JSON object on stdout");
  ld->add_option("--link-timeout-ms", load->link_timeout_ms, "wall time without a frame: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  ld->callback([load] { run_load(*load); });
}

// deltactl host home.
void add_home_command(CLI::App* host) {
  auto home = std::make_shared<HomeOptions>();
  CLI::App* h = host->add_subcommand("home", "Home against the robot's references (its home switches)");
  h->footer(
      "\nWith the drives off: the board forgets its references; every arm moves down off its home switch\n"
      "(0.5 deg below it), then up at --search-speed until its switch closes, where the board sets\n"
      "that joint's encoder to the home count (30.00 deg) and stops the drives; the others go on.\n"
      "Works from any start within the travel; the arms rest at their references at the end. A joint\n"
      "that does not reach its switch (stuck, blocked, the switch missing) faults or runs out of travel:\n"
      "exit 3 naming the joint, drives off. --by-hand instead sets the counts to 30.00 deg wherever the\n"
      "arms are (the old fixture homing): 'host run' then needs --allow-unreferenced. docs/homing.md.");
  h->add_option("--port", home->port, "serial port")->required();
  h->add_option("--weights", home->weights, "W.json the board runs (the jog's setpoints are its network's answers)");
  h->add_flag("--by-hand", home->by_hand, "set the counts where the arms are (no motion; not a reference)");
  h->add_option("--search-speed", home->homing.search_deg_s, "deg/s up toward the switches")
      ->check(options::real_number(0.2, 20.0))
      ->capture_default_str();
  h->add_option("--max-travel", home->homing.max_travel_deg,
                "deg a joint moves one way without finding its switch before homing gives up (default: the travel)")
      ->check(options::real_number(1.0, 150.0))
      ->capture_default_str();
  h->add_option("--timeout", home->homing.timeout_s, "seconds for the whole homing")
      ->check(options::real_number(5.0, 600.0))
      ->capture_default_str();
  h->add_flag("--quiet", home->quiet, "no progress lines on stderr");
  h->add_option("--link-timeout-ms", home->link_timeout_ms, "wall time without a frame: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  h->callback([home] { run_home(*home); });
}

// deltactl host run.
void add_run_command(CLI::App* host) {
  auto run = std::make_shared<RunOptions>();
  CLI::App* r = host->add_subcommand("run", "Check a trajectory, enable, stream it, stop, disable; record the run");
  r->footer(
      "\nThe whole plan is checked before the port is opened (and again with the move from the pose the\n"
      "encoders report): every 1 kHz sample reachable, inside the network's trained range and the joint\n"
      "travel, joint velocity <= 100 deg/s, acceleration <= 1e4 deg/s^2, jerk <= 1e6 deg/s^3; the first\n"
      "offending sample is named (FILE:LINE: reason), exit 2, no byte sent. The board must be homed at\n"
      "its references ('host home'; homed by hand only with --allow-unreferenced) and free of faults. The plate moves "
      "in a jerk-limited straight line to the trajectory's start, then\n"
      "along it, its time ramped in and out (0.3 s); Ctrl-C (SIGINT), SIGTERM, SIGHUP (the terminal or\n"
      "SSH session closed) or SIGQUIT ramps it to rest (within about 0.5 s), then holds and disables.\n"
      "The drives going off by another cause (a disable from another program, a board reset) ends the\n"
      "run at once (exit 3). A streaming thread with 1 ms absolute deadlines (SCHED_FIFO and locked\n"
      "memory when permitted) sends setpoints paced by the board's telemetry; no telemetry for\n"
      "--link-timeout-ms of wall time is link loss (exit 4). OUT.csv: one row per telemetry frame up to\n"
      "the final hold and disable, written under its name from the enable on (whatever ends the\n"
      "process, the rows so far are there). A run lasts at most 600 s of trajectory time. The summary\n"
      "ends with the headline of 'deltactl run-report --run OUT.csv' (the joint tracking; the plate\n"
      "needs the stage's log: run-report --stage).\n"
      "--check: the plan checked as above with nothing opened or sent (no --port, no --record): the\n"
      "allowed box (W.json's trained range; 'deltactl limits') is printed, then OK or every problem\n"
      "(the first sample of each kind; a path outside the box names every axis it leaves it on), exit 2\n"
      "on any. The move from the pose the encoders report to the path's start is checked at the run.\n"
      "Example: deltactl host run --weights W.json --trajectory path.csv --check");
  r->add_option("--port", run->port, "serial port (not with --check)");
  r->add_option("--weights", run->weights,
                "W.json the board must run (its model CRC, loaded by 'host load', and this checkout's gateware)")
      ->required();
  r->add_option("--trajectory", run->trajectory,
                "a trajectory of 'deltactl simulate' (experiment1, ...), FILE.csv with t_s,x_m,y_m,z_m, or "
                "move:X,Y,Z[;X,Y,Z...] (point-to-point, jerk-limited, metres)")
      ->required();
  r->add_option("--duration", run->duration_s, "seconds of trajectory time (default: all of it; at most 600)")
      ->check(options::real_number(0, kMaxRunSeconds, true));
  r->add_option("--record", run->record, "OUT.csv: one row per telemetry frame (not with --check)");
  r->add_flag("--check", run->check, "check the whole plan, print the allowed box, send nothing (no port needed)");
  r->add_flag("--allow-unreferenced", run->allow_unreferenced,
              "run on a board homed by hand ('host home --by-hand'), not at its references");
  r->add_option("--link-timeout-ms", run->link_timeout_ms, "wall time without telemetry: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  r->add_option("--following-error-deg", run->following_error_deg,
                "the host's own bound on |encoder - joint reference|, > 0 and <= 45 deg (the board's own is 5.12 deg)")
      ->check(options::real_number(0, 45, true))
      ->capture_default_str();
  r->callback([run] { run_run(*run); });
}

// deltactl host park.
void add_park_command(CLI::App* host) {
  auto park = std::make_shared<ParkOptions>();
  CLI::App* pk = host->add_subcommand("park", "Move the plate to a rest pose and turn the drives off");
  pk->footer(
      "\nA 'host run' of one point: the plate moves in a jerk-limited straight line from where the encoders\n"
      "say it is to --pose (default: the middle of the network's trained range, where the paper's\n"
      "trajectories start from), holds, and the drives go off; every check of 'host run' applies (the\n"
      "board homed at its references, the counts against the home switches, the move inside the\n"
      "trained range). Park after a run stopped mid-path, before powering down, or before a drag\n"
      "calibration, so the next run starts where it should. Exit codes as 'host run'.\n"
      "Example: deltactl host park --port /dev/ttyUSB1 --weights weights/paper_like_deployed.json");
  pk->add_option("--port", park->port, "serial port")->required();
  pk->add_option("--weights", park->weights, "W.json the board must run")->required();
  pk->add_option("--pose", park->pose_mm, "X,Y,Z: the rest pose [mm] (default: the middle of the trained range)")
      ->delimiter(',')
      ->expected(3);
  pk->add_option("--record", park->record, "OUT.csv: keep the move's recording (default: kept only on a failure)");
  pk->add_flag("--allow-unreferenced", park->allow_unreferenced,
               "park a board homed by hand ('host home --by-hand'), not at its references");
  pk->add_option("--link-timeout-ms", park->link_timeout_ms, "wall time without telemetry: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  pk->callback([park] { run_park(*park); });
}

// deltactl host record.
void add_record_command(CLI::App* host) {
  auto record = std::make_shared<RecordOptions>();
  CLI::App* rec =
      host->add_subcommand("record", "Record the board's telemetry with the drives off (a calibration drag)");
  rec->footer(
      "\nThe lab's calibration run: the drives stay off (nothing but identify is sent) while the measuring\n"
      "stage drags the plate; every telemetry frame becomes one row of RUN.csv (t_s board time,\n"
      "alpha*_deg encoders, alpha*_ref_deg, currents, fault_bits, flags, drives_enabled, counters) for\n"
      "--duration seconds of board time (default: until SIGINT or SIGTERM). Then merge it with the\n"
      "stage's own log: deltactl merge --run RUN.csv --stage STAGE.csv --out DATA.csv (docs/lab_loop.md).\n"
      "The board must be homed at its references first ('host home'): counts set by hand or never set\n"
      "(30.00 deg wherever the arms were at power-up) would enter the calibration as joint offsets; such\n"
      "a board is refused (exit 3, nothing recorded) unless --unreferenced. RUN.csv's header states it:\n"
      "'# referenced: home switches' (or hand, or none); diagnose and train refuse the last two unless\n"
      "told. Frames lost on the way (the line, or a host that did not keep up) are counted in the\n"
      "summary, with a warning; the rows there are keep their board time.\n"
      "Exit codes as 'host run' (3 also when the drives are on, or go on during the recording).");
  rec->add_option("--port", record->port, "serial port")->required();
  rec->add_option("--out", record->out, "RUN.csv: one row per telemetry frame")->required();
  rec->add_option("--duration", record->duration_s, "seconds of board time (default: until a signal)")
      ->check(options::real_number(0, 1e6, true));
  rec->add_flag("--unreferenced", record->unreferenced,
                "record a board not homed at its references (homed by hand, never homed, or a homing that did not "
                "finish); the header says so");
  rec->add_option("--link-timeout-ms", record->link_timeout_ms, "wall time without telemetry: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  rec->callback([record] { run_record(*record); });
}

// deltactl host serve.
void add_serve_command(CLI::App* host) {
  auto serve = std::make_shared<ServeCliOptions>();
  CLI::App* sv = host->add_subcommand("serve", "The long-running controller: owns the port, answers a control socket");
  sv->footer(
      "\nOwns the board's port (reconnects every second when it vanishes, e.g. while flashing; never\n"
      "enables by itself); at each connection it loads W.json's model onto a board without it, the\n"
      "drives off (as 'host load'; status says how: model_load), and answers JSON lines on a local\n"
      "socket: status, run, hold, resume, stop,\n"
      "home, enable, disable, clear-fault ('deltactl host ctl' is its client; the protocol is in\n"
      "host/controller/include/delta/controller/serve.hpp). Runs are those of 'host run', recorded\n"
      "in --record-folder (a client names a file there, never elsewhere, and never replaces one; runs\n"
      "that name none get a new run-TIME.csv). Under systemd (deltactl.service): READY=1, STATUS= and\n"
      "WATCHDOG=1 by sd_notify. SIGTERM, SIGINT, SIGHUP or SIGQUIT: a run stops at rest, the drives go\n"
      "off, exit 0. SIGUSR1 is an e-stop. After 'enable' the drives hold the arms where they are until\n"
      "'disable' (the controller keeps the link alive meanwhile).\n"
      "An e-stop (estop from any client, the dashboard's E-STOP, SIGUSR1) turns the drives off at once\n"
      "(a run at its next cycle, a homing at its next frame) and latches: home, enable and run are\n"
      "refused for every client (status says e-stopped) until an explicit clear-fault.\n"
      "--http ADDR:PORT also serves the operator's dashboard (a page with live plots and the controls,\n"
      "docs/dashboard.md); loopback unless told otherwise. Every changing request needs the token of\n"
      "--http-token-file (created with mode 0600 when absent) as 'Authorization: Bearer TOKEN'.\n"
      "Example: deltactl host serve --config /etc/deltactl/deltactl.conf --http 127.0.0.1:8080");
  sv->add_option("--config", serve->config, "the lab PC's configuration (port, weights, limits, socket)");
  sv->add_option("--port", serve->port, "serial port (overrides the config)");
  sv->add_option("--weights", serve->weights,
                 "W.json the board runs, loaded onto it when it has another model or none "
                 "(overrides the config)");
  sv->add_option("--socket", serve->socket, "control socket path (overrides the config)");
  sv->add_option("--record-folder", serve->record_folder,
                 "recordings of runs that name none (default: $STATE_DIRECTORY/runs, else ./runs)");
  sv->add_option("--link-timeout-ms", serve->link_timeout_ms, "wall time without telemetry: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
  sv->add_option("--http", serve->http, "the dashboard's ADDR:PORT, e.g. 127.0.0.1:8080 (overrides the config)");
  sv->add_option("--http-token-file", serve->http_token_file,
                 "the dashboard's token (default: $STATE_DIRECTORY/http-token, else ./http-token)");
  sv->callback([serve] { run_serve(*serve); });
}

// deltactl host ctl.
void add_ctl_command(CLI::App* host) {
  auto ctl = std::make_shared<CtlOptions>();
  CLI::App* c = host->add_subcommand("ctl", "Talk to a running 'host serve': status, run, hold, resume, stop, ...");
  c->footer(
      "\nCOMMAND: status | run | hold | resume | stop | estop | home | enable | disable | clear-fault | load.\n"
      "load loads the controller's configured model onto the board again (the drives off; as it does\n"
      "at each connection).\n"
      "run streams --trajectory (NAME or FILE.csv) through the controller and prints its progress every\n"
      "second and its summary; hold and resume are a feed hold (the plate slows to rest on the path,\n"
      "then comes back to speed); stop ends the run at rest and disables. Ctrl-C (or SIGTERM, SIGHUP,\n"
      "SIGQUIT) during a run sends stop: the run ends at rest, exit 128+N; a run also stops when its\n"
      "client goes away (use --no-wait to leave it running). enable turns the drives on holding the arms\n"
      "where they are; disable turns them off. estop turns the drives off at once and latches: home,\n"
      "enable and run are refused (exit 3, from every client) until clear-fault, which clears it and the\n"
      "board's fault. stop also ends a homing. Exit codes as 'host run'; 4 when the controller cannot\n"
      "be reached.");
  c->add_option("command", ctl->command, "what to ask")
      ->required()
      ->check(CLI::IsMember(
          {"status", "run", "hold", "resume", "stop", "estop", "home", "enable", "disable", "clear-fault", "load"}));
  c->add_option("--socket", ctl->socket, "control socket (default: the config's [service] socket)");
  c->add_option("--config", ctl->config, "configuration file naming the socket")->capture_default_str();
  c->add_flag("--json", ctl->json, "print the controller's JSON replies as they come");
  c->add_option("--trajectory", ctl->trajectory, "run: NAME, FILE.csv or move:X,Y,Z[;...] (as 'host run')");
  c->add_option("--duration", ctl->duration_s, "run: seconds of trajectory time (at most 600)")
      ->check(options::real_number(0, kMaxRunSeconds, true));
  c->add_option("--record", ctl->record,
                "run: NAME.csv in the controller's recordings folder, a new name (default: a new run-TIME.csv)");
  c->add_flag("--no-wait", ctl->no_wait, "run: return once queued");
  c->callback([ctl] {
    if (ctl->command == "run" && ctl->trajectory.empty()) fail(kExitBadInput, "host ctl run: needs --trajectory");
    run_ctl(*ctl);
  });
}

// deltactl host latency.
void add_latency_command(CLI::App* host) {
  auto latency = std::make_shared<LatencyOptions>();
  CLI::App* l = host->add_subcommand("latency", "Wake latency of a 1 kHz loop with absolute deadlines (no board)");
  l->add_option("--seconds", latency->seconds, "how long")
      ->check(options::real_number(0.1, 3600))
      ->capture_default_str();
  l->add_flag("--normal", latency->normal, "normal scheduling (default: SCHED_FIFO and locked memory when permitted)");
  l->add_flag("--json", latency->json, "one JSON object");
  l->callback([latency] { run_latency(*latency); });
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
      "gateware is not this checkout's, or it holds no model or another than W.json's (deltactl host\n"
      "load); 128+N after a controlled stop on signal N (SIGINT, SIGTERM, SIGHUP, SIGQUIT).");
  for (const auto add : {add_status_command, add_load_command, add_home_command, add_run_command, add_park_command,
                         add_record_command, add_serve_command, add_ctl_command, add_latency_command})
    add(host);
});

}  // namespace
}  // namespace delta::controller
