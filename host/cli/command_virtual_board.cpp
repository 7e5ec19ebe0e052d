// deltactl virtual-board: the virtual robot with its board behind a pseudo-terminal (docs/contracts.md, "The
// board and the lab PC"), so any program that opens PATH as a serial port talks to it as to the
// iCEBreaker. RTL fidelity (the Verilated board) or model fidelity (the C++ model board,
// bit-exact with it): delta/cosim/virtual_board.hpp, model_board.hpp.
#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fstream>
#include <iostream>
#include <memory>
#include <random>
#include <system_error>
#include <thread>
#include <tuple>
#include <vector>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/controller/realtime.hpp"
#include "delta/cosim/board_inputs.hpp"
#include "delta/cosim/measuring_stage.hpp"
#include "delta/cosim/virtual_board.hpp"
#include "delta/csv.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/input_error.hpp"
#include "delta/io/pseudo_terminal.hpp"
#include "delta/output_file.hpp"
#include "delta/shipped_data.hpp"
#include "delta/table.hpp"
#include "delta/temporary_directory.hpp"
#include "options.hpp"

namespace delta::cosim {
namespace {

volatile std::sig_atomic_t stop_requested = 0;
constexpr int kPacedPriority = 70;  // SCHED_FIFO of a paced board (the host controller's loop: 80)
void request_stop(int) { stop_requested = 1; }

struct VirtualBoardCommandOptions {
  std::string link;
  // The shipped weights and the paper-like robot (shipped_data.hpp: this build's, or the package's).
  std::string effects = shipped_data_dir() + "/paper_like_effects.json";
  std::string weights = shipped_data_dir() + "/weights/paper_like_deployed.json";
  bool no_model = false;  // the board starts with no model (else it holds --weights, loaded at start)
  std::string truth;
  std::string fidelity = "rtl";
  double inject_encoder_skip_at_s = -1.0;
  bool free_run = false;
  std::string stage;  // --stage drag:NAME|drag:FILE.csv|follow
  std::string stage_log;
  std::string stage_clock = "0,0";
  double stage_rate_hz = 1000.0;
  double stage_noise_m = 20e-9;
  std::int64_t stage_seed = -1;
  bool stage_no_sync = false;
  double stage_after_home_s = -1.0;         // < 0: the drag's clock starts at the host's first frame
  std::string start_angles;                 // A1,A2,A3 [deg], true shaft angles; empty: the home pose
  int inject_seized_joint = 0;              // 1..3; 0: none
  int inject_missing_home_switch = 0;       // 1..3; 0: none
  std::string inject_count_slip;            // J,COUNTS,S
  std::vector<std::string> estop_open_at;   // S[,UNTIL]
  std::vector<std::string> drive_fault_at;  // J,S[,UNTIL]
};

// --estop-open-at S[,UNTIL] (input 0) and --drive-fault-at J,S[,UNTIL] (input J): the window of
// board time the input is at its stop level.
SafetyInputWindow parse_safety_window(const std::string& option, const std::string& text, bool with_joint) {
  const auto fail = [&](const std::string& why) {
    return InputError(option, 0,
                      "'" + text + "': " + why + "; give " +
                          (with_joint ? "J,S[,UNTIL]: a drive 1-3, " : "S[,UNTIL]: ") +
                          "the board time in s it starts at and, if it ends, the time it ends at (later)");
  };
  std::vector<std::string> fields;
  for (std::size_t at = 0;;) {
    const std::size_t comma = text.find(',', at);
    fields.push_back(text.substr(at, comma == std::string::npos ? std::string::npos : comma - at));
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  const std::size_t first = with_joint ? 1 : 0;
  if (fields.size() < first + 1 || fields.size() > first + 2) throw fail("wrong number of fields");
  SafetyInputWindow window;
  if (with_joint) {
    const std::string& j = fields[0];
    if (j.size() != 1 || j[0] < '1' || j[0] > '3') throw fail("the drive '" + j + "' is not 1, 2 or 3");
    window.input = j[0] - '0';
  }
  window.from_s = parse_decimal(fields[first]).value_or(NAN);
  if (!std::isfinite(window.from_s) || window.from_s < 0.0) throw fail("the start is not a time >= 0");
  if (fields.size() == first + 2) {
    window.until_s = parse_decimal(fields[first + 1]).value_or(NAN);
    if (!std::isfinite(window.until_s) || window.until_s <= window.from_s) throw fail("the end is not after the start");
  }
  return window;
}

// --start-angles A1,A2,A3: three true shaft angles within the board's travel.
Vec3 parse_start_angles(const std::string& text) {
  Vec3 angles = Vec3::Zero();
  std::size_t at = 0;
  for (int j = 0; j < 3; ++j) {
    const std::size_t comma = j < 2 ? text.find(',', at) : text.size();
    const std::string field = comma == std::string::npos ? "" : text.substr(at, comma - at);
    const double value = parse_decimal(field).value_or(NAN);
    if (!std::isfinite(value)) {
      throw InputError("--start-angles", 0, "'" + text + "': give three angles in degrees, A1,A2,A3, e.g. 12.5,40,33");
    }
    const double low = board::kMinTravelBlock * 1024 * board::kEncoderCountDeg,
                 high = ((board::kMaxTravelBlock + 1) * 1024 - 1) * board::kEncoderCountDeg;
    if (value < low || value > high) {
      throw InputError("--start-angles", 0,
                       "joint " + std::to_string(j + 1) + " at " + field + " deg is outside the travel (" +
                           fixed(low, 2) + " .. " + fixed(high, 2) + " deg)");
    }
    angles[j] = value;
    at = comma + 1;
  }
  return angles;
}

// --inject-count-slip J,COUNTS,S: the 0-based joint, the counts, the board time.
std::tuple<int, int, double> parse_count_slip(const std::string& text) {
  const auto fail = [&] {
    return InputError("--inject-count-slip", 0,
                      "'" + text + "': give J,COUNTS,S: a joint 1-3, whole counts, a time in s");
  };
  const auto first = text.find(','), second = first == std::string::npos ? first : text.find(',', first + 1);
  if (second == std::string::npos) throw fail();
  try {
    std::size_t used_j = 0, used_c = 0;
    const std::string js = text.substr(0, first), cs = text.substr(first + 1, second - first - 1),
                      ss = text.substr(second + 1);
    const int joint = std::stoi(js, &used_j);
    const int counts = std::stoi(cs, &used_c);
    const double at = parse_decimal(ss).value_or(NAN);
    if (used_j != js.size() || used_c != cs.size() || joint < 1 || joint > 3 || !std::isfinite(at) || at < 0.0) {
      throw fail();
    }
    return {joint - 1, counts, at};
  } catch (const std::logic_error&) {
    throw fail();
  }
}

// --stage-clock OFFSET_S,PPM.
std::pair<double, double> parse_stage_clock(const std::string& text) {
  const auto comma = text.find(',');
  try {
    if (comma == std::string::npos) throw std::invalid_argument(text);
    const double offset = parse_decimal(text.substr(0, comma)).value_or(NAN);
    const double ppm = parse_decimal(text.substr(comma + 1)).value_or(NAN);
    if (!std::isfinite(offset) || !std::isfinite(ppm) || std::abs(ppm) > 1e5) {
      throw std::invalid_argument(text);
    }
    return {offset, ppm};
  } catch (const std::logic_error&) {
    throw InputError("--stage-clock", 0, "'" + text + "': give OFFSET_S,PPM, e.g. 12.5,-80");
  }
}

// Writes what fits into the pty without waiting: with no program reading PATH the board's bytes
// are dropped, as an FTDI chip drops them with no host attached. Once the pty was full, a poll
// asks whether it has room before a write: a write into a full pty still wakes the kernel's
// worker that moves its bytes (most of a free-running board's time with nobody reading).
std::size_t write_what_fits(int fd, const std::uint8_t* data, std::size_t size, bool* full) {
  if (*full) {
    pollfd room{fd, POLLOUT, 0};
    if (::poll(&room, 1, 0) <= 0 || !(room.revents & POLLOUT)) return 0;
    *full = false;
  }
  std::size_t written = 0;
  while (written < size) {
    const ssize_t n = ::write(fd, data + written, size - written);
    if (n > 0) {
      written += static_cast<std::size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      *full = true;  // EAGAIN: the pty's buffer is full
      break;
    }
  }
  return written;
}

// The virtual board's options from the command's (everything checked before PATH or TRUTH appear).
VirtualBoardOptions board_options_of(const VirtualBoardCommandOptions& options, bool model,
                                     const golden::QuantisedNetwork& quantised, const EffectSet& effects,
                                     const std::string& mem_dir) {
  VirtualBoardOptions board_options;
  board_options.fidelity = model ? BoardFidelity::kModel : BoardFidelity::kRtl;
  board_options.network = options.no_model ? nullptr : &quantised;  // loaded through its frames at start
  board_options.mem_dir = mem_dir;
  board_options.effects = effects;
  board_options.inject_encoder_skip_at_s = options.inject_encoder_skip_at_s;
  if (!options.start_angles.empty()) board_options.start_true_alpha_deg = parse_start_angles(options.start_angles);
  board_options.inject_seized_joint = options.inject_seized_joint - 1;
  board_options.inject_missing_home_switch = options.inject_missing_home_switch - 1;
  if (!options.inject_count_slip.empty()) {
    std::tie(board_options.inject_slip_joint, board_options.inject_slip_counts, board_options.inject_slip_at_s) =
        parse_count_slip(options.inject_count_slip);
  }
  for (const std::string& text : options.estop_open_at)
    board_options.safety_inputs.push_back(parse_safety_window("--estop-open-at", text, false));
  for (const std::string& text : options.drive_fault_at)
    board_options.safety_inputs.push_back(parse_safety_window("--drive-fault-at", text, true));
  if (!model && !board_options.safety_inputs.empty() && !rtl_board_has_safety_inputs()) {
    throw InputError(options.estop_open_at.empty() ? "--drive-fault-at" : "--estop-open-at", 0,
                     "this build's RTL board core has no safety input ports: use --fidelity model");
  }
  return board_options;
}

// The measuring stage beside the robot (--stage, --stage-log), its drag into *board_options; none
// without --stage.
std::unique_ptr<MeasuringStage> make_stage(const VirtualBoardCommandOptions& options, const EffectSet& effects,
                                           VirtualBoardOptions* board_options) {
  if (options.stage.empty() && options.stage_log.empty()) return nullptr;
  if (options.stage.empty() || options.stage_log.empty()) {
    throw InputError("--stage", 0, "--stage and --stage-log go together");
  }
  StageOptions stage_options;
  stage_options.mode = options.stage;
  stage_options.log_path = options.stage_log;
  std::tie(stage_options.clock_offset_s, stage_options.clock_ppm) = parse_stage_clock(options.stage_clock);
  stage_options.rate_hz = options.stage_rate_hz;
  stage_options.noise_m = options.stage_noise_m;
  stage_options.log_sync = !options.stage_no_sync;
  if (options.stage_after_home_s >= 0.0) {
    if (options.stage.rfind("drag:", 0) != 0) throw InputError("--stage-after-home", 0, "needs --stage drag:...");
    stage_options.after_home_s = options.stage_after_home_s;
  }
  stage_options.seed = options.stage_seed >= 0 ? static_cast<std::uint64_t>(options.stage_seed)
                                               : static_cast<std::uint64_t>(std::random_device{}()) & 0xffffffffu;
  auto stage = std::make_unique<MeasuringStage>(stage_options, effects, Geometry::nominal());
  if (stage->drags()) board_options->drag = [s = stage.get()](double t) { return s->drag(t); };
  std::cout << "virtual-board: stage " << options.stage << ", log " << options.stage_log << " on its clock "
            << options.stage_clock << " (offset s, ppm) at " << format_number(options.stage_rate_hz) << " Hz, noise "
            << format_number(options.stage_noise_m) << " m RMS, seed " << stage_options.seed
            << (stage_options.after_home_s >= 0.0
                    ? "; the drag takes hold " + format_number(stage_options.after_home_s) +
                          " s after the first command that follows the homing at the references starts"
                    : "")
            << std::endl;
  return stage;
}

// --truth: the CSV's header, and a row per millisecond of board time as the board runs.
void record_truth(const std::string& path, VirtualBoard& board, std::ofstream& truth) {
  truth.open(path, std::ios::trunc);
  if (!truth) throw InputError(path, 0, "cannot be written");
  truth << "t_s,x_m,y_m,z_m,true_alpha1_deg,true_alpha2_deg,true_alpha3_deg,drives_enabled,"
           "encoder1_deg,encoder2_deg,encoder3_deg,current1_a,current2_a,current3_a,"
           "estop_open,drive_fault1,drive_fault2,drive_fault3\n";
  board.observe_truth([&truth](const TruthSample& s, const RobotWorld&) {
    truth << format_number(s.t_s);
    for (int k = 0; k < 3; ++k) truth << ',' << format_number(s.position_m[k]);
    for (int k = 0; k < 3; ++k) truth << ',' << format_number(s.true_alpha_deg[k]);
    truth << ',' << (s.drives_enabled ? 1 : 0);
    for (int k = 0; k < 3; ++k) truth << ',' << format_number(s.encoder_deg[k]);
    for (int k = 0; k < 3; ++k) truth << ',' << format_number(s.current_a[k]);
    truth << ',' << (s.estop_open ? 1 : 0);
    for (int k = 0; k < 3; ++k) truth << ',' << ((s.drive_fault >> k) & 1);
    truth << '\n';
  });
}

// What the line carried, for the stop's summary.
struct LineCounts {
  std::chrono::steady_clock::duration largest_lag{};
  std::uint64_t bytes_in = 0, bytes_out = 0, bytes_dropped = 0;
};

// Runs the board behind the pty until SIGINT or SIGTERM.
LineCounts serve_line(VirtualBoard& board, io::PseudoTerminal& pty, MeasuringStage* stage, std::ofstream& truth,
                      bool model, bool paced, bool free_running, std::chrono::steady_clock::time_point start) {
  // One control period of board time per turn (100 us): the pty's bytes join the line at the board's
  // bit timing, the board's bytes go out as they complete. Paced: each turn waits until its board
  // time is due on the wall clock (a board that behaves like the real one for a host in a dry run).
  // The model board free-running: a millisecond of board time per turn (the pty's read and write
  // per turn cost more than the model board's periods; a host's bytes join the line within 1 ms of
  // board time). The RTL board, slower than real time, keeps to a period per turn.
  // Board time is real time, as on the real board: a paced board that fell behind (this process
  // not scheduled) catches up, a millisecond per turn, on the bytes that arrived meanwhile (at
  // most as late as they really came) and sends its telemetry of the time it missed at once, as a
  // real board's would reach a host that could not read. The largest lag is printed on exit.
  // The host's bytes wait in the pty while the line holds kReceiveQueueBytes (the FT2232H's 4 KiB
  // buffer): a writer faster than the line is slowed down and finally blocked, as by a real port.
  constexpr std::size_t kReceiveQueueBytes = 4096;
  // The wall time of board time 0 while pacing (the model's load at start took board time: now is that).
  auto origin = start - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(board.time_s()));
  // Free-running, the model board still keeps to real time while its drives are on: a host's homing
  // or run then meets the board's watchdog (250 ms of board time) as on the real board, whatever the
  // host's scheduling; with them off it runs free again.
  const bool free_run = model && free_running;
  bool pacing = paced;
  LineCounts counts;
  std::chrono::steady_clock::duration& largest_lag = counts.largest_lag;
  auto last_flush = start;
  std::uint64_t& bytes_in = counts.bytes_in;
  std::uint64_t& bytes_out = counts.bytes_out;
  std::uint64_t& bytes_dropped = counts.bytes_dropped;
  std::uint64_t turns = 0;
  bool pty_full = false, behind = false;
  std::uint8_t buffer[kReceiveQueueBytes];
  const int fd = pty.fd();
  while (!stop_requested) {
    const std::size_t queued = board.bytes_to_board();
    if (queued < kReceiveQueueBytes) {
      const ssize_t got = ::read(fd, buffer, kReceiveQueueBytes - queued);
      if (got > 0) {
        board.write(buffer, static_cast<std::size_t>(got));
        if (stage) stage->host_bytes(buffer, static_cast<std::size_t>(got), board.time_s());
        bytes_in += static_cast<std::uint64_t>(got);
      }
    }
    if (++turns % 128 == 0) pty.release_exclusive();
    if (free_run && board.pins().drive_enable != pacing) {
      pacing = !pacing;
      behind = false;
      if (pacing) {
        origin = std::chrono::steady_clock::now() - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                        std::chrono::duration<double>(board.time_s()));
      }
    }
    board.step((model && !pacing) || behind ? kClocksPerMillisecond : kClocksPerTick);
    const std::size_t out = board.read(buffer, sizeof buffer);
    if (out > 0) {
      if (stage) stage->board_bytes(buffer, out, board.time_s());
      const std::size_t written = write_what_fits(fd, buffer, out, &pty_full);
      bytes_out += written;
      bytes_dropped += out - written;
    }
    auto now = std::chrono::steady_clock::now();
    if (pacing) {
      const auto due = origin + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                    std::chrono::duration<double>(board.time_s()));
      behind = now - due > std::chrono::milliseconds(1);
      if (due > now) {
        std::this_thread::sleep_until(due);
        now = std::chrono::steady_clock::now();
      } else {
        largest_lag = std::max(largest_lag, now - due);
      }
    }
    if (now - last_flush >= std::chrono::milliseconds(500)) {
      if (truth.is_open()) truth.flush();
      if (stage) stage->flush();
      last_flush = now;
    }
  }
  return counts;
}

void run_virtual_board(const VirtualBoardCommandOptions& options) {
  const bool model = options.fidelity == "model";
  // The model keeps to wall-clock time unless told to run free; the RTL cannot keep up anyway.
  const bool paced = model && !options.free_run;
  // Everything is checked before PATH or TRUTH appear.
  // (--no-model: the shipped weights only for the gateware's files, whose identify.mem and tables
  // are the same for every model.)
  const golden::QuantisedNetwork quantised = read_board_network(options.weights);
  const EffectSet effects = read_board_effects(options.effects);

  const TemporaryDirectory mem("deltactl_virtual_board");  // the gateware's .mem files and identify.mem
  golden::write_export(quantised, mem.path());
  VirtualBoardOptions board_options = board_options_of(options, model, quantised, effects, mem.path());
  const std::unique_ptr<MeasuringStage> stage = make_stage(options, effects, &board_options);
  const auto make_board = [&]() {
    try {
      return std::make_unique<VirtualBoard>(board_options);
    } catch (const std::invalid_argument& error) {  // the arms placed where the plate has no pose
      throw InputError("--start-angles", 0, "'" + options.start_angles + "': " + error.what());
    }
  };
  const std::unique_ptr<VirtualBoard> board_owner = make_board();
  VirtualBoard& board = *board_owner;
  if (stage) {
    board.observe_periods([s = stage.get()](std::uint64_t clocks, const BoardPins& pins, const RobotWorld& world) {
      s->sample(static_cast<double>(clocks) / kBoardClockHz, world, pins.stage_sync);
    });
  }

  std::ofstream truth;
  if (!options.truth.empty()) record_truth(options.truth, board, truth);

  std::unique_ptr<io::PseudoTerminal> pty;
  try {
    pty = std::make_unique<io::PseudoTerminal>(options.link);
  } catch (const std::system_error& error) {
    std::cerr << "deltactl: error: --link " << error.what() << '\n';
    throw CommandExit{kExitBadInput};
  }
  struct sigaction action {};
  action.sa_handler = request_stop;
  sigemptyset(&action.sa_mask);
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(signal_number, &action, nullptr);

  // A paced board runs as the real board's hardware does, whatever else the PC runs: SCHED_FIFO
  // (below the host controller's 80) when permitted, so that a busy PC does not stop its clock.
  const std::string scheduling = paced ? controller::make_thread_realtime(kPacedPriority) : "";
  std::cout << "virtual-board: ready on " << options.link << " (" << pty->slave_path() << "), "
            << (model ? "model" : "RTL") << " fidelity" << (paced ? " (real time)" : "")
            << (options.no_model ? ", no model" : ", weights CRC " + golden::hex_word(weights_crc(quantised), 32))
            << ", gateware " << golden::hex_word(kGatewareBuildId, 32)
            << (!paced               ? ""
                : scheduling.empty() ? ", SCHED_FIFO " + std::to_string(kPacedPriority)
                                     : ", normal scheduling (" + scheduling + ")")
            << std::endl;

  const auto start = std::chrono::steady_clock::now();
  const LineCounts counts = serve_line(board, *pty, stage.get(), truth, model, paced, options.free_run, start);
  if (truth.is_open()) {
    truth.close();
    if (!truth) std::cerr << "deltactl: error: " << options.truth << ": write failed\n";
  }
  if (stage) {
    if (!stage->finish()) std::cerr << "deltactl: error: " << options.stage_log << ": write failed\n";
    std::cerr << "virtual-board: stage: " << stage->samples() << " samples logged"
              << (stage->drags()
                      ? (stage->drag_start_s() < 0 ? (stage->after_home() ? "; the board was never homed at its "
                                                                            "references, the plate never moved"
                                                                          : "; no valid frame came, the plate never "
                                                                            "moved")
                                                   : "; drag from board time " + fixed(stage->drag_start_s(), 4) +
                                                         " s, " + fixed(stage->path_duration_s(), 1) + " s long")
                      : "")
              << '\n';
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cerr << "virtual-board: stopped after " << fixed(board.time_s(), 3) << " s of board time in " << fixed(wall, 1)
            << " s wall"
            << (paced ? "; at most " + fixed(std::chrono::duration<double>(counts.largest_lag).count() * 1e3, 1) +
                            " ms behind the wall clock (caught up)"
                      : "")
            << "; " << counts.bytes_in << " bytes from the host, " << counts.bytes_out << " to it, "
            << counts.bytes_dropped << " dropped (nobody reading)\n";
  pty.reset();  // removes PATH
}

// deltactl virtual-board --help's text after the options.
std::string virtual_board_footer() {
  const std::string sync_period_s = format_number(board::kStageSyncLevelSeconds);
  return std::string(
             "\nCreates a pseudo-terminal (raw, no echo) whose slave is linked at PATH; any program that opens\n"
             "PATH as a serial port talks the board link v2 (docs/board_link.md) to the virtual board: the\n"
             "Verilated board core as built for the iCEBreaker (23.25 MHz board clock, 46.5 MHz network\n"
             "clock, 23 clocks per bit at 1 Mbaud) with the robot world (three joint plants, the effects'\n"
             "sensor chain, quadrature encoders, PWM averaging). Bytes from PATH enter the board's UART at its\n"
             "bit timing; the board's bytes come back as they leave its TX pin. The simulation runs as fast as\n"
             "it can, about 0.4 x real time: a host paces itself by the board's telemetry, never by its\n"
             "own clock. --fidelity model runs the C++ model board instead (bit-exact with the RTL at its\n"
             "pins: the same bytes, PWM and encoder counts), kept to wall-clock time unless --free-run (over\n"
             "100 x real time with nobody reading, and at real time while its drives are on, so that a host's\n"
             "homing or run meets the board's watchdog as on the real board), as SCHED_FIFO 70 when permitted (the "
             "board's hardware\n"
             "never waits for the PC). Board time is real time, as on the real board: a paced\n"
             "board that falls behind, its process not scheduled, catches up on the bytes that arrived\n"
             "meanwhile and sends the telemetry of the time it missed at once; the largest lag is printed\n"
             "on exit. The board's receive queue holds 4 KiB (the FT2232H's buffer): a program writing\n"
             "faster than the line is slowed down and blocked, as by a real port.\n"
             "Bytes the board sends while nobody reads PATH are dropped once the pty is full.\n"
             "A program's exclusive mode on PATH (TIOCEXCL) ends when it closes PATH, as on a serial port.\n"
             "A --link that names a live virtual board's link is refused.\n"
             "Prints one line naming PATH when ready; runs until SIGINT or SIGTERM, then removes PATH.\n"
             "--truth: CSV at 1 kHz of board time, written as it runs (flushed twice a second, complete on\n"
             "exit): t_s (board time since reset), x/y/z_m (the plate as the measuring stage sees it),\n"
             "true_alpha*_deg (plant angles), drives_enabled, encoder*_deg, current*_a, estop_open and\n"
             "drive_fault1..3 (the board's safety inputs, 1 = at the stop level).\n"
             "--estop-open-at S[,UNTIL]: the board's e-stop chain opens at board time S (closes at UNTIL);\n"
             "--drive-fault-at J,S[,UNTIL] (repeatable): drive J (1-3) reports a fault from S (to UNTIL) and\n"
             "gives no current meanwhile. The board latches the cause (e-stop input open, drive J fault)\n"
             "after 3 control periods at the stop level; a clear-fault is refused while the input stays there.\n"
             "The board holds a model when the host starts: before the first host byte the virtual board\n"
             "loads --weights over its link as 'deltactl host load' does (the model's frames, docs/board_link.md\n"
             "\"The model\"; 26 ms of board time) and the ready line names its CRC. --no-model: it starts as a\n"
             "board after power-up, with no model (enable refused) until a host loads one.\n"
             "Defaults: the deployed model (weights/paper_like_deployed.json; the plain\n"
             "network: --weights weights/paper_like.json) and the paper-like robot\n"
             "(sim/paper_like_effects.json), both of the checkout deltactl was built from; --effects '' is the\n"
             "nominal robot.\n"
             "--inject-encoder-skip-at S: at board time S joint 1's A and B lines both invert (a skipped\n"
             "quadrature state: the board latches fault cause 0, encoder skip), for the host's fault tests.\n"
             "--stage: a measuring stage beside the robot (docs/contracts.md, \"The lab's measurements\"). drag:NAME "
             "or\n"
             "drag:FILE.csv (t_s,x_m,y_m,z_m): with the drives off the stage moves the plate, the arms following\n"
             "through the true geometry and every effect; it takes hold at the board's first valid frame (with\n"
             "--stage-after-home S: S seconds of board time after the first command that follows the board's\n"
             "homing at its references starts, 'host record' after 'host home': homing runs undisturbed and the\n"
             "drag starts with the recording; telemetry with the drives on or homing before then waits for the\n"
             "homing's end again, so the stage never takes hold sooner than S after the drives went off),\n"
             "moves the plate to the trajectory's start in one second (quintic), along the trajectory, then\n"
             "holds it at the end.\n"
             "follow: it only measures. --stage-log gets the stage controller's own log,\n"
             "t_s,x_m,y_m,z_m, on its clock (t_stage = OFFSET + (1 + PPM 1e-6) t_board) at --stage-rate, the\n"
             "plate through the frame misalignment with --stage-noise, quantised to 6.87 nm; the seed is printed.\n"
             "A fifth column, sync, is the board's stage sync output (bit ") +
         std::to_string(board::kStageSyncBit) + " of its control periods, a level\nthat changes every " +
         sync_period_s +
         " s of board time) on the stage's digital input, sampled with the\n"
         "positions: merge aligns the clocks on it. --stage-no-sync: a stage without that wire.\n"
         "Merge it with a host recording: deltactl merge (docs/lab_loop.md).\n"
         "Example: deltactl virtual-board --link /tmp/delta-tty --truth truth.csv &\n"
         "         deltactl host status --port /tmp/delta-tty";
}

// The virtual board's options, into *options.
void add_virtual_board_options(CLI::App* sub, const std::shared_ptr<VirtualBoardCommandOptions>& options) {
  sub->add_option("--link", options->link, "path at which to link the pseudo-terminal (a serial port to open)")
      ->required();
  sub->add_option("--effects", options->effects,
                  "virtual robot's effects (JSON; default: the paper-like robot, sim/paper_like_effects.json)");
  CLI::Option* weights = sub->add_option(
      "--weights", options->weights,
      "the model the board holds at start, loaded over its link (W.json: model 'deployed' or 'network', 25 hidden; "
      "default: weights/paper_like_deployed.json)");
  sub->add_flag("--no-model", options->no_model,
                "the board starts with no model, as after power-up: enable is refused until a host loads one "
                "(deltactl host load)")
      ->excludes(weights);
  sub->add_option("--truth", options->truth, "CSV of the ground truth at 1 kHz of board time");
  sub->add_option("--fidelity", options->fidelity, "rtl: the Verilated board core; model: the C++ model board")
      ->capture_default_str()
      ->check(CLI::IsMember({"rtl", "model"}));
  sub->add_flag("--free-run", options->free_run,
                "model fidelity: run as fast as possible while the drives are off (at real time while they are on)");
  sub->add_option("--inject-encoder-skip-at", options->inject_encoder_skip_at_s,
                  "fault injection: from this board time [s] joint 1's encoder skips a quadrature state")
      ->check(options::real_number(0, 1e6));
  sub->add_option("--start-angles", options->start_angles,
                  "A1,A2,A3: true shaft angles [deg] the arms rest at when the board starts (default: the home pose, "
                  "where the encoders read the home count); the board counts from its home count wherever they are: "
                  "`deltactl host home` finds the references");
  sub->add_option("--inject-seized-joint", options->inject_seized_joint,
                  "J (1-3): that arm never moves, whatever the drive (a test's fault injection)")
      ->check(CLI::Range(1, 3));
  sub->add_option("--inject-missing-home-switch", options->inject_missing_home_switch,
                  "J (1-3): that joint's home switch never closes (a test's fault injection)")
      ->check(CLI::Range(1, 3));
  sub->add_option("--inject-count-slip", options->inject_count_slip,
                  "J,COUNTS,S: at board time S joint J's encoder silently gains COUNTS (valid quadrature steps, as "
                  "from noise; the board cannot see it): a test's fault injection");
  sub->add_option("--estop-open-at", options->estop_open_at,
                  "S[,UNTIL]: the board's e-stop chain opens at board time S [s] (and closes at UNTIL); repeatable")
      ->type_name("S[,UNTIL]");
  sub->add_option("--drive-fault-at", options->drive_fault_at,
                  "J,S[,UNTIL]: drive J (1-3) reports a fault (and gives no current) from board time S [s] to UNTIL; "
                  "repeatable")
      ->type_name("J,S[,UNTIL]");
  sub->add_option("--stage", options->stage,
                  "measuring stage: drag:NAME|drag:FILE.csv (drags the plate, drives off) or follow")
      ->type_name("MODE");
  sub->add_option("--stage-log", options->stage_log, "STAGE.csv: the stage's own log (t_s,x_m,y_m,z_m,sync)");
  sub->add_option("--stage-clock", options->stage_clock, "OFFSET_S,PPM: t_stage = OFFSET + (1 + PPM 1e-6) t_board")
      ->capture_default_str();
  sub->add_option("--stage-rate", options->stage_rate_hz, "stage samples per second of its clock")
      ->check(options::real_number(1, 100000))
      ->capture_default_str();
  sub->add_option("--stage-noise", options->stage_noise_m, "stage noise, RMS per axis [m]")
      ->check(options::real_number(0, 1e-3))
      ->capture_default_str();
  sub->add_option("--stage-seed", options->stage_seed, "seed of the stage's noise (default: drawn, printed)")
      ->check(options::whole_number(0, 4294967295LL));
  sub->add_option("--stage-after-home", options->stage_after_home_s,
                  "S: the drag takes hold S seconds of board time after the first command that follows the "
                  "board's homing at its references starts (host record after host home), not at the host's first "
                  "frame")
      ->check(options::real_number(0, 3600));
  sub->add_flag("--stage-no-sync", options->stage_no_sync,
                "the stage logs no sync column (its input not wired to the board's sync output)");
}

const RegisterCommand command("virtual-board", 72, [](CLI::App& root) {
  auto options = std::make_shared<VirtualBoardCommandOptions>();
  CLI::App* sub = root.add_subcommand(
      "virtual-board", "The virtual robot and its board behind a pseudo-terminal at PATH (talk to it as to the board)");
  sub->footer(virtual_board_footer());
  add_virtual_board_options(sub, options);
  sub->callback([options] { run_virtual_board(*options); });
});

}  // namespace
}  // namespace delta::cosim
