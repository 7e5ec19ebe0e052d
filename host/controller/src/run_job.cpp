// One run of the host controller (see run_job.hpp).
#include "delta/controller/run_job.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <optional>
#include <sstream>
#include <system_error>
#include <thread>

#include "delta/board_facts.hpp"
#include "delta/controller/homing.hpp"
#include "delta/exit_codes.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/setpoint_interpolation.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/output_file.hpp"
#include "delta/run_files.hpp"
#include "delta/run_report.hpp"
#include "delta/table.hpp"

namespace delta::controller {
namespace {

// How far (encoder counts) a referenced joint's count may be on the wrong side of its reference
// for its home switch before a run is refused: the backlash's play and a count of quantisation.
constexpr long long kSwitchMarginCounts = 50;

std::string hex(std::uint32_t value) { return golden::hex_word(value, 32); }

int link_error_code(const link::LinkError& error) {
  return error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault;
}

// With the deployed model's backlash compensation the board holds each joint, from the enable to
// its first answer, at the end of the play on the side where the play was last taken up (the
// telemetry's play sides; reference_interpolator.sv). The approach starts where that answer keeps
// it: C - r = side (H + a sixteenth of a count), so the enable moves no joint. The plain network
// (H = 0): `located`, the network's inverse at the counts.
Vec3 resting_start(const golden::BoardWeights& weights, const link::TelemetryPayload& t0, const Vec3& located) {
  const auto half_plays = golden::interpolation::half_play_counts(weights.network.compensation);
  if (half_plays == std::array<std::int32_t, 3>{}) return located;
  constexpr std::int32_t kBeyondTheEnd = 16;  // Q.8 counts: past the end, so the answer's LSBs never re-enter the play
  std::array<std::int32_t, 3> references{}, delta{}, actual{};
  for (int j = 0; j < 3; ++j) {
    references[j] = golden::interpolation::encoder_reference(t0.counts[j]);
    delta[j] = half_plays[j] == 0 ? 0 : t0.play_side(j) * kBeyondTheEnd;
  }
  const std::array<std::int32_t, 3> codes = jog_setpoint(weights, references, delta, &actual);
  Vec3 start;
  for (int k = 0; k < 3; ++k)
    start[k] = std::ldexp(static_cast<double>(codes[k]), -weights.network.formats.input_fraction_bits);
  return start;
}

}  // namespace

Vec3 start_at_rest(const golden::BoardWeights& weights, const link::TelemetryPayload& rest) {
  Vec3 counts_deg;
  for (int j = 0; j < 3; ++j) counts_deg[j] = rest.count_deg(j);
  // The plan is in plate positions; the setpoints sent are shaped (a joint ripple table): start at
  // the position whose shaped setpoint is the resting one.
  return nn::unshape_setpoint(
      weights.model,
      resting_start(weights, rest, golden::locate_plate(weights.network, Geometry::nominal(), counts_deg)));
}

std::string resolve_port(const std::string& port) {
  if (port.find('/') != std::string::npos) return port;
  const std::string folder = "/dev/serial/by-id/";
  if (port != "icebreaker") {
    // A bare name is looked up under by-id; one that is only a file here (a virtual board's link
    // made with --link tty) is named, with the spelling that opens it.
    if (::access((folder + port).c_str(), F_OK) != 0 && ::access(port.c_str(), F_OK) == 0) {
      throw HostFailure(kExitLinkLost, "--port " + port + ": no " + folder + port +
                                           " (a name without a '/' is looked up there); for the file " + port +
                                           " in this directory write ./" + port);
    }
    return folder + port;
  }
  std::string found;
  if (DIR* dir = ::opendir(folder.c_str())) {
    while (dirent* entry = ::readdir(dir)) {
      const std::string name = entry->d_name;
      if (name.find("iCEBreaker") != std::string::npos && name.find("if01") != std::string::npos) found = folder + name;
    }
    ::closedir(dir);
  }
  if (found.empty()) {
    throw HostFailure(kExitLinkLost, "--port icebreaker: no iCEBreaker UART under " + folder + " (is it plugged in?)");
  }
  return found;
}

std::unique_ptr<io::SerialPort> open_board_port(const std::string& port) {
  const std::string path = resolve_port(port);
  try {
    return std::make_unique<io::SerialPort>(path, static_cast<int>(board::kLinkBaud));
  } catch (const std::system_error& error) {
    throw HostFailure(kExitLinkLost, std::string("--port ") + error.what());
  }
}

link::SessionOptions host_session_options(int link_timeout_ms) {
  link::SessionOptions options;
  options.frame_timeout_ms = link_timeout_ms;
  options.target_fill = static_cast<std::uint32_t>(board::kStreamLeadSetpoints);
  options.keep_telemetry = false;
  return options;
}

Connected connect_board(link::LinkSession& session) {
  try {
    Connected c;
    c.identify = session.identify();
    c.telemetry = session.next_telemetry();
    return c;
  } catch (const link::LinkError& error) {
    throw HostFailure(error.kind() == link::LinkError::Kind::kProtocol ? kExitMismatch : kExitLinkLost, error.what());
  }
}

void check_board_identity(const Connected& board, const golden::BoardWeights& weights, const std::string& weights_path,
                          const std::string& port_name) {
  const std::uint32_t crc = weights_crc(weights.network);
  const std::string load = "deltactl host load --port " + port_name + " --weights " + weights_path;
  if (board.identify.build_id != kGatewareBuildId) {
    throw HostFailure(kExitMismatch, port_name + ": the board runs gateware " + hex(board.identify.build_id) +
                                         "; this host expects gateware " + hex(kGatewareBuildId) +
                                         " (flash this checkout's: deltactl flash)");
  }
  if (!board.telemetry.has(link::TelemetryFlag::kModel)) {
    throw HostFailure(kExitMismatch, port_name + ": the board has no model; load " + weights_path + "'s (CRC " +
                                         hex(crc) + "): " + load);
  }
  if (board.identify.weights_crc != crc) {
    throw HostFailure(kExitMismatch, port_name + ": the board runs another model (CRC " +
                                         hex(board.identify.weights_crc) + "), not " + weights_path + "'s (CRC " +
                                         hex(crc) + "): " + load);
  }
}

// The recording: its name checked (and reserved, kNew*) at construction; created (kReplace:
// replaced) just before the enable; rows appended to a buffer off the streaming thread and written
// to the file every few milliseconds, so that whatever ends the process leaves them under the name.
class RecordingFile {
 public:
  RecordingFile(const std::string& path, RecordMode mode) : path_(path) {
    if (path.empty()) throw InputError("(empty path)", 0, "a recording needs a file name");
    struct stat target {};
    const bool exists = ::lstat(path.c_str(), &target) == 0;
    if (exists && S_ISDIR(target.st_mode)) throw InputError(path, 0, "is a folder, not a file");
    if (exists && mode != RecordMode::kReplace && !S_ISREG(target.st_mode) && !S_ISLNK(target.st_mode)) {
      throw InputError(path, 0, "is not a regular file; a recording is one");
    }
    if (mode == RecordMode::kReplace) {
      if (exists && ::stat(path.c_str(), &target) == 0 && !S_ISREG(target.st_mode)) {
        throw InputError(path, 0, "is not a regular file (a FIFO, a device, ...); a recording is one");
      }
      if (exists && ::access(path.c_str(), W_OK) != 0) throw InputError(path, 0, "is read-only; not overwritten");
      const std::string folder = std::filesystem::path(path).parent_path().string();
      if (::access(folder.empty() ? "." : folder.c_str(), W_OK | X_OK) != 0) {
        throw InputError(path, 0,
                         std::string("cannot write here (") + std::strerror(errno) + "; does the folder exist?)");
      }
      note_output_file(path_);
      noted_ = true;
      return;
    }
    // Created now, exclusively, not through a link: a name is never taken from another file.
    const std::filesystem::path name(path);
    for (int n = 1; n <= 10000; ++n) {
      const std::string candidate =
          n == 1 ? path
                 : (name.parent_path() / (name.stem().string() + "-" + std::to_string(n) + name.extension().string()))
                       .string();
      fd_ = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
      if (fd_ >= 0) {
        path_ = candidate;
        reserved_ = true;
        return;
      }
      if (errno != EEXIST) break;
      if (mode == RecordMode::kNew) {
        throw InputError(path, 0, "exists; a recording never replaces a file (choose another name)");
      }
    }
    throw InputError(path, 0, std::string("cannot be created (") + std::strerror(errno) + ")");
  }
  ~RecordingFile() {
    if (fd_ >= 0) {
      flush();
      ::close(fd_);
    }
    if (reserved_ && !opened_) ::unlink(path_.c_str());  // never used: no empty file left
    if (noted_) forget_output_file(path_);
  }
  RecordingFile(const RecordingFile&) = delete;
  RecordingFile& operator=(const RecordingFile&) = delete;

  const std::string& path() const { return path_; }
  bool opened() const { return opened_; }
  // Just before the enable: the file exists under its name from the first motion on.
  void open(const std::string& header) {
    if (fd_ < 0) {
      fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
      if (fd_ < 0) throw InputError(path_, 0, std::string("cannot be written (") + std::strerror(errno) + ")");
    }
    opened_ = true;
    buffer_ = header;
    flush();
  }
  std::string& buffer() { return buffer_; }
  void flush() {
    std::size_t done = 0;
    while (fd_ >= 0 && error_.empty() && done < buffer_.size()) {
      const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        error_ = std::strerror(errno);
        break;
      }
      done += static_cast<std::size_t>(n);
    }
    buffer_.clear();
  }
  // Written out and closed; "" or why the recording is incomplete (disk full, ...).
  std::string close() {
    flush();
    if (fd_ >= 0) {
      if (::fdatasync(fd_) != 0 && error_.empty() && errno != EINVAL) error_ = std::strerror(errno);
      if (::close(fd_) != 0 && error_.empty()) error_ = std::strerror(errno);
      fd_ = -1;
    }
    return error_;
  }

 private:
  std::string path_;
  int fd_ = -1;
  bool reserved_ = false;  // created at construction
  bool opened_ = false;    // open() called: the run's file, kept whatever happens
  bool noted_ = false;
  std::string buffer_;
  std::string error_;
};

// The recording's rows, off the streaming thread.
struct TelemetryRecorder {
  RecordingFile file;
  TrackingStatistics tracking;  // the path (tau >= 0) with the drives on
  TrackingStatistics ramp_in;   // from the enable to the path: the approach to its start
  std::uint64_t rows = 0;
  std::optional<std::uint16_t> underruns_at_first_play;
  std::uint16_t underruns_at_end = 0;
  std::optional<TelemetryRecord> last;

  // streaming: a run's rows (the positions sent and the stream's columns); else `host record`'s.
  TelemetryRecorder(const std::string& path, RecordMode mode, bool streaming)
      : file(path, mode), streaming(streaming) {}
  const bool streaming;
  // `referencing`: how the counts the rows carry were referenced (recording.hpp), stated in the header.
  void open(Referencing referencing) {
    std::string header = "# " + referencing_comment(referencing) + "\n";
    header += streaming
                  ? "# deltactl host run: one row per board telemetry frame (1 kHz of board time), up to the final\n"
                    "# hold and disable\n"
                    "# t_s: board time; *_ref_m: the position sent for the sample whose answer is the joint\n"
                    "# reference at t_s; alpha*_ref_deg: the board's joint references; alpha*_deg: encoders\n"
                    "t_s,x_ref_m,y_ref_m,z_ref_m,"
                  : "# deltactl host record: one row per board telemetry frame (1 kHz of board time), drives off\n"
                    "# t_s: board time; alpha*_deg: encoders; alpha*_ref_deg: the board's joint references\n"
                    "t_s,";
    header +=
        "alpha1_ref_deg,alpha2_ref_deg,alpha3_ref_deg,alpha1_deg,alpha2_deg,alpha3_deg,current1_a,current2_a,"
        "current3_a,fault_bits,flags,drives_enabled,sample_index,fill,";
    if (streaming) header += "tau_s,stream_sample,";
    header += "bad_frames,underruns,rejected,slew_limits,board_fault_bits,estop\n";
    file.open(header);
  }
  // The last line: how the run ended, at the board time of the last frame the host acted on
  // (`deltactl plot` bands an end that is not a normal one: an e-stop, a fault, a lost link).
  void write_outcome(const std::string& outcome, std::uint32_t tick, int code, std::string error) {
    for (char& c : error) c = c == '\n' || c == '\r' ? ' ' : c;
    file.buffer() += "# outcome: " + outcome + " at board time " + format_number(tick / 1e4) + " s (exit " +
                     std::to_string(code) + ")" + (error.empty() ? "" : ": " + error) + "\n";
  }
  void write(const TelemetryRecord& r) {
    const link::TelemetryPayload& t = r.telemetry;
    std::string& out = file.buffer();
    out += format_number(t.time_s());
    if (streaming) {
      for (int k = 0; k < 3; ++k) out += ',' + format_number(r.reference_m[k]);
    }
    for (int k = 0; k < 3; ++k) out += ',' + format_number(t.reference_deg(k));
    for (int k = 0; k < 3; ++k) out += ',' + format_number(t.count_deg(k));
    for (int k = 0; k < 3; ++k) out += ',' + format_number(t.currents[k] * kCurrentCodeA);
    for (const long long value : {static_cast<long long>(t.fault_cause), static_cast<long long>(t.flags),
                                  static_cast<long long>(t.has(link::TelemetryFlag::kDriveEnable) ? 1 : 0),
                                  static_cast<long long>(t.sample_index), static_cast<long long>(t.fill)}) {
      out += ',' + std::to_string(value);
    }
    if (streaming) out += ',' + format_number(r.tau_s) + ',' + std::to_string(r.stream_sample);
    for (const long long value : {static_cast<long long>(t.bad_frames), static_cast<long long>(t.underruns),
                                  static_cast<long long>(t.rejected), static_cast<long long>(t.slew_limits),
                                  static_cast<long long>(t.board_fault), static_cast<long long>(t.estop ? 1 : 0)}) {
      out += ',' + std::to_string(value);
    }
    out += '\n';
    ++rows;
    last = r;
    if (streaming && t.has(link::TelemetryFlag::kDriveEnable) && (r.stream_sample < 0 || r.tau_s < 0.0)) {
      ramp_in.add(t);
    }
    if (r.stream_sample >= 0 && t.has(link::TelemetryFlag::kDriveEnable)) {
      if (r.tau_s >= 0.0) tracking.add(t);
      if (!underruns_at_first_play) underruns_at_first_play = t.underruns;
      underruns_at_end = t.underruns;
    }
  }
};

namespace {

std::string tracking_line(const std::string& what, const TrackingStatistics& tracking) {
  const Vec3 rms = tracking.rms_deg();
  return what + ", " + std::to_string(tracking.frames) + " frames): rms " + fixed(rms[0], 4) + " / " +
         fixed(rms[1], 4) + " / " + fixed(rms[2], 4) + " deg, max " + fixed(tracking.max_abs_deg[0], 3) + " / " +
         fixed(tracking.max_abs_deg[1], 3) + " / " + fixed(tracking.max_abs_deg[2], 3) + " deg\n";
}

std::string summary_text(const StreamingResult& s, const link::LinkSession& session, const TrackingStatistics& tracking,
                         const TrackingStatistics& ramp_in, std::uint64_t underruns, std::uint64_t rows,
                         const std::string& record_path, double wall_s) {
  const link::LinkStatistics& link = session.statistics();
  const link::TelemetryPayload& last = *session.last_telemetry();
  const std::uint64_t host_bad = link.decoder.bad_crc + link.decoder.bad_length + link.decoder.unknown_type;
  std::ostringstream out;
  out << "stream: " << s.played << " of " << s.planned << " samples played from board index " << s.first_index << " ("
      << fixed(board_seconds_between(s.first, s.last), 3) << " s of board time, " << fixed(wall_s, 1) << " s wall)";
  if (s.holds > 0) out << "; " << s.holds << " feed holds, " << fixed(s.held_s, 3) << " s held";
  out << "\nlink: " << link.telemetry_frames << " telemetry frames (lost " << link.lost_telemetry << ", skipped "
      << link.skipped_telemetry << "), longest gap " << fixed(s.longest_telemetry_gap_ms, 1)
      << " ms wall; setpoints sent " << link.setpoints_sent << " (resent " << link.setpoints_resent
      << "); bad frames: board " << last.bad_frames - s.first.bad_frames << ", host " << host_bad << " (crc "
      << link.decoder.bad_crc << ", length " << link.decoder.bad_length << ", type " << link.decoder.unknown_type
      << "); refused " << last.rejected - s.first.rejected << "; underruns while streaming " << underruns
      << "; slew limits " << last.slew_limits - s.first.slew_limits << '\n'
      << "loop (" << (s.realtime_note.empty() ? "SCHED_FIFO" : "normal scheduling")
      << ", 1 ms absolute deadlines): wake latency p50 " << fixed(s.latency.percentile_us(50), 0) << " us, p99 "
      << fixed(s.latency.percentile_us(99), 0) << " us, p99.9 " << fixed(s.latency.percentile_us(99.9), 0)
      << " us, max " << fixed(s.latency.max_us(), 0) << " us; overruns " << s.overruns << " in " << s.cycles
      << " cycles\n"
      << tracking_line("tracking (encoder - joint reference on the path", tracking)
      << tracking_line("ramp-in (the same from the enable to the path's start", ramp_in) << "recording: " << record_path
      << " (" << rows << " rows)\n";
  return out.str();
}

// The headline of `deltactl run-report --run RECORD` (the recording read back as written): the joint
// tracking, and the plate when the recording has it; why not (no row with the drives on), or "" without one.
std::string run_headline(const std::string& record) {
  if (record.empty()) return "";
  try {
    std::string text;
    std::istringstream lines(report_headline(run_report_of_file(record)));
    for (std::string line; std::getline(lines, line);) text += "run-report: " + line + "\n";
    return text;
  } catch (const InputError& error) {
    return "run-report: " + std::string(error.what()) + "\n";
  }
}

}  // namespace

double board_seconds_between(const link::TelemetryPayload& from, const link::TelemetryPayload& to) {
  const auto ticks = static_cast<std::int32_t>(to.tick - from.tick);  // modulo 2^32: across a wrap
  return ticks > 0 ? ticks * link::kTickSeconds : 0.0;
}

std::vector<std::string> check_path(const golden::BoardWeights& weights, const Path& path, const RunRequest& request) {
  // The path alone (from its own start): the approach is checked once the pose is known.
  const StreamPlan plan(path, path.samples.front().position_m, request.limits);
  return check_plan_all(plan, request.trajectory, weights.trained_min_m, weights.trained_max_m, request.limits,
                        &weights.model);
}

std::vector<std::string> check_run(const golden::BoardWeights& weights, const RunRequest& request) {
  return check_path(weights, load_path(request.trajectory, request.duration_s), request);
}

RunJob::RunJob(const golden::BoardWeights& weights, const RunRequest& request)
    : weights_(weights), request_(request), path_(load_path(request.trajectory, request.duration_s)) {
  const std::vector<std::string> problems = check_path(weights_, path_, request_);
  if (!problems.empty()) throw HostFailure(kExitBadInput, problems.front() + "; nothing sent");
  // Refuses a bad path before the port (kNew*: the name is reserved now).
  recorder_ = std::make_unique<TelemetryRecorder>(request_.record, request_.record_mode, true);
}

RunJob::~RunJob() = default;

const std::string& RunJob::record_path() const { return recorder_->file.path(); }

bool RunJob::request(FeedRequest request) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (request == FeedRequest::kEstop) estop_.store(true);
  if (finished_) return request == FeedRequest::kEstop;
  if (!loop_) {
    if (request == FeedRequest::kEstop) return true;  // execute() refuses to enable
    if (request != FeedRequest::kStop) return false;
    stop_pending_ = true;  // taken before the enable, or by the loop at its first frame
    return true;
  }
  loop_->request(request);
  return true;
}

RunProgress RunJob::progress() const {
  std::lock_guard<std::mutex> lock(mutex_);
  RunProgress p;
  if (loop_) {
    p.played = loop_->played();
    p.planned = loop_->planned();
    p.feed = loop_->feed();
  }
  p.telemetry = newest_;
  return p;
}

// Ready to run: no fault latched, the drives off, homed at the references (or by hand, allowed),
// and each home switch closed above its reference, open below (HostFailure, exit 3).
void RunJob::check_ready(const std::string& port_name, const link::TelemetryPayload& t0,
                         const std::function<void(const std::string&)>& log) const {
  if (t0.has(link::TelemetryFlag::kFault)) {
    throw HostFailure(kExitFault, port_name + ": the board has a latched fault: " + link::describe_fault(t0) +
                                      " (clear it deliberately; this host re-enables nothing by itself)");
  }
  if (t0.has(link::TelemetryFlag::kDriveEnable)) {
    throw HostFailure(kExitFault, port_name + ": the drives are already on (another controller?); refusing to run");
  }
  if (!t0.has(link::TelemetryFlag::kReferenced)) {
    if (!t0.has(link::TelemetryFlag::kHomed)) {
      throw HostFailure(kExitFault, port_name + ": the board is not homed (deltactl host home); nothing moved");
    }
    if (!request_.allow_unreferenced) {
      throw HostFailure(kExitFault, port_name + ": the board was homed by hand, not at its references (" +
                                        link::describe_state(t0) +
                                        "): run deltactl host home, or allow it explicitly (--allow-unreferenced); "
                                        "nothing moved");
    }
    log("the board was homed by hand (--allow-unreferenced): its counts are where the arms were then");
  }

  // ---- the counts against the robot: each home switch is closed above its reference, open below ----
  for (int j = 0; j < 3; ++j) {
    if (!t0.referenced(j)) continue;
    const long long above = t0.counts[j] - board::kHomeCount;
    const bool closed = t0.home_switch(j);
    if ((above > kSwitchMarginCounts && !closed) || (above < -kSwitchMarginCounts && closed)) {
      throw HostFailure(kExitFault, port_name + ": joint " + std::to_string(j + 1) + "'s encoder reads " +
                                        fixed(t0.count_deg(j), 2) + " deg, " +
                                        fixed(std::abs(above) * board::kEncoderCountDeg, 2) + " deg " +
                                        (above > 0 ? "above" : "below") + " its reference, but its home switch is " +
                                        (closed ? "closed" : "open") +
                                        ": the counts are not where the arm is (counts lost or gained since "
                                        "homing); run deltactl host home; nothing moved");
    }
  }
}

// The arms at rest with the drives off (HostFailure, exit 3 or 4).
link::TelemetryPayload RunJob::wait_at_rest(link::LinkSession& session, const std::string& port_name) const {
  // ---- the arms at rest: a run that follows another (or a drag) within milliseconds finds them still
  // settling with the drives off; enabled in motion, a joint's last counts land after the first
  // answer and its correction crosses the play (arms_at_rest: still for 30 frames, at most 2 s). ----
  std::optional<link::TelemetryPayload> at_rest;
  try {
    at_rest = arms_at_rest(session);
  } catch (const link::LinkError& error) {
    throw HostFailure(link_error_code(error), error.what());
  }
  if (!at_rest)
    throw HostFailure(kExitFault, port_name + ": the arms do not come to rest with the drives off; nothing moved");
  const link::TelemetryPayload rest = *at_rest;
  return rest;
}

// The plan from the pose the encoders report at rest, checked whole (HostFailure, exit 2 or 3).
StreamPlan RunJob::plan_from_rest(const std::string& port_name, const link::TelemetryPayload& rest,
                                  Vec3* start_out) const {
  // ---- the approach from the pose the encoders report, checked with the rest ----
  Vec3 start;
  try {
    start = start_at_rest(weights_, rest);
  } catch (const std::runtime_error& error) {
    throw HostFailure(kExitFault, port_name + ": the encoders' pose: " + error.what());
  }
  StreamPlan plan(path_, start, request_.limits);
  if (auto violation = check_plan(plan, request_.trajectory, weights_.trained_min_m, weights_.trained_max_m,
                                  request_.limits, &weights_.model)) {
    throw HostFailure(kExitBadInput, *violation + " (from the encoders' pose; no motion)");
  }
  *start_out = start;
  return plan;
}

// Homed -> running: the recording opened, the drives enabled and the board holding, its buffer
// empty (HostFailure; a failure after the enable disables). Returns the memory lock's note.
std::string RunJob::enable_primed(link::LinkSession& session, const std::string& port_name,
                                  const link::TelemetryPayload& t0, RunOutcome* out) {
  // ---- homed -> running ----
  const std::string lock_note = lock_memory();
  if (estop_.load()) throw HostFailure(kExitFault, port_name + ": e-stop before the run started; nothing enabled");
  recorder_->open(board_referencing(t0));  // under its name before the first motion
  out->record = recorder_->file.path();
  link::TelemetryPayload enabled;
  try {
    enabled = session.enable();
  } catch (const link::LinkError& error) {
    try {
      session.send_command(link::Command::kDisable);  // whatever the enable did
    } catch (const link::LinkError&) {
    }
    throw HostFailure(link_error_code(error), error.what());
  }
  auto disable_and_fail = [&](int code, const std::string& why) {
    try {
      session.send_command(link::Command::kDisable);
    } catch (const link::LinkError&) {
    }
    throw HostFailure(code, port_name + ": " + why + "; disabled, nothing streamed");
  };
  if (enabled.fill != 0) {  // the board takes setpoints only with the drives on (docs/board_link.md)
    disable_and_fail(kExitFault, "the board holds " + std::to_string(enabled.fill) +
                                     " setpoints this host did not send (gateware older than the link's contract?)");
  }
  try {
    session.hold();  // the streaming loop sends the lead, then enables: the buffer is full when play starts
  } catch (const link::LinkError& error) {
    disable_and_fail(link_error_code(error), error.what());
  }
  return lock_note;
}

// Streams the plan on its own thread while this one writes the recording and reports progress.
StreamingResult RunJob::stream_and_record(link::LinkSession& session, StreamPlan& plan, const Vec3& start,
                                          RecordQueue& queue, const volatile std::sig_atomic_t& stop_signal,
                                          const std::string& lock_note,
                                          const std::function<void(const std::string&)>& log,
                                          const std::function<void(const RunProgress&)>& progress) {
  StreamingOptions streaming;
  streaming.link_timeout_ms = request_.link_timeout_ms;
  streaming.following_error_deg = request_.following_error_deg;
  streaming.session = session.options();
  StreamingLoop loop(session, plan, weights_, start, queue, streaming, stop_signal);
  const auto wall_start = std::chrono::steady_clock::now();
  std::atomic<bool> streaming_done{false};
  std::thread streamer([&loop, &streaming_done] {
    loop.run();
    streaming_done.store(true);
  });
  {
    std::lock_guard<std::mutex> lock(mutex_);
    loop_ = &loop;
    if (stop_pending_) loop.request(FeedRequest::kStop);
    if (estop_.load()) loop.request(FeedRequest::kEstop);  // asked between the enable and now
  }
  // This thread: the recording and the progress.
  TelemetryRecord r;
  auto write_queued = [&] {
    bool any = false;
    while (queue.pop(r)) {
      recorder_->write(r);
      if (tap_) tap_(r);
      any = true;
    }
    if (!any) return;
    recorder_->file.flush();
    std::lock_guard<std::mutex> lock(mutex_);
    newest_ = r.telemetry;
  };
  auto next_progress = wall_start + std::chrono::milliseconds(200);
  bool warned = false;
  while (!streaming_done.load()) {
    write_queued();
    if (!warned && !loop.result().realtime_note.empty() && loop.result().cycles > 0) {
      log("warning: real-time scheduling not granted (" + loop.result().realtime_note +
          (lock_note.empty() ? "" : "; " + lock_note) + "): running with normal priority");
      warned = true;
    }
    if (std::chrono::steady_clock::now() >= next_progress) {
      progress(RunJob::progress());
      next_progress += std::chrono::milliseconds(200);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  streamer.join();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    loop_ = nullptr;
  }
  write_queued();
  return loop.result();
}

// Stop: hold (after a completed or stopped run) and disable, always; nothing is ever re-enabled
// here. Every frame meanwhile goes into the recording: it ends with the drives off.
void RunJob::stop(link::LinkSession& session, const std::string& port_name, const StreamingResult& result,
                  const Vec3& start, const volatile std::sig_atomic_t& stop_signal,
                  const std::function<void(const std::string&)>& log, RunOutcome* out_ptr) {
  RunOutcome& out = *out_ptr;
  TelemetryRecord final_row;
  if (recorder_->last) {
    final_row = *recorder_->last;
    final_row.stream_sample = -1;  // the stop's frames are not the stream's (its statistics end with it)
  } else {
    final_row.reference_m = start;
  }
  auto record_frame = [&](const link::TelemetryPayload& t) {
    final_row.telemetry = t;
    recorder_->write(final_row);
    recorder_->file.flush();
    std::lock_guard<std::mutex> lock(mutex_);
    newest_ = t;
  };
  auto command = [&](link::Command command, const std::function<bool(const link::TelemetryPayload&)>& done) {
    session.poll_frames();
    while (auto frame = session.take_telemetry()) record_frame(*frame);
    session.command(command, [&](const link::TelemetryPayload& t) {
      record_frame(t);
      return done(t);
    });
  };
  auto drives_off = [](const link::TelemetryPayload& t) { return !t.has(link::TelemetryFlag::kDriveEnable); };
  auto disable = [&]() -> std::string {  // "" once the telemetry shows the drives off
    try {
      command(link::Command::kDisable, drives_off);
      return "";
    } catch (const link::LinkError& error) {
      try {
        session.send_command(link::Command::kDisable);  // once more, in case the line is still there
      } catch (const link::LinkError&) {
      }
      return error.what();
    }
  };
  switch (result.outcome) {
    case StreamingResult::Outcome::kCompleted:
    case StreamingResult::Outcome::kStopped: {
      out.outcome = outcome_name(result.outcome);
      std::string failed;
      try {
        if (!estop_.load()) {  // an e-stop asked as the run ended: no hold first
          command(link::Command::kHold, [](const link::TelemetryPayload& t) {
            return t.has(link::TelemetryFlag::kHolding) || !t.has(link::TelemetryFlag::kDriveEnable);
          });
        }
      } catch (const link::LinkError& error) {
        out.code = link_error_code(error);
        failed = std::string("the board did not hold: ") + error.what();
      }
      const std::string disabled = disable();  // even when the hold failed
      if (disabled.empty()) {
        log("running -> homed (drives off)");
        if (!failed.empty()) {
          out.code = kExitFault;  // the link is up: the drives went off by the disable
          out.error = "stopping: " + failed + "; the drives are off (disable sent)";
        }
      } else {
        out.code = kExitLinkLost;
        out.error = "stopping: " + (failed.empty() ? std::string() : failed + "; ") + "disable: " + disabled;
      }
      if (out.code == kExitOk && !result.cause.empty()) {
        out.code = kExitFault;
        out.error = port_name + ": " + result.cause + "; drives off";
      }
      if (out.code == kExitOk && result.outcome == StreamingResult::Outcome::kStopped && stop_signal != 0) {
        log("stopped by signal " + std::to_string(stop_signal) + " (controlled stop, drives off)");
        out.code = 128 + static_cast<int>(stop_signal);
      }
      break;
    }
    case StreamingResult::Outcome::kFault:
      out.outcome = estop_.load() ? "e-stop" : outcome_name(result.outcome);
      out.code = kExitFault;
      out.error = estop_.load() ? port_name + ": e-stop on request: drives off, nothing re-enabled"
                                : port_name + ": the board faulted: " + result.cause + " (" +
                                      link::describe_state(result.last) + "); drives off, nothing re-enabled";
      disable();
      break;
    case StreamingResult::Outcome::kDrivesOff:
      out.outcome = outcome_name(result.outcome);
      out.code = kExitFault;
      out.error = port_name + ": " + result.cause + "; the run ended, disable sent, nothing re-enabled";
      disable();
      break;
    case StreamingResult::Outcome::kLinkLost:
      out.outcome = outcome_name(result.outcome);
      out.code = kExitLinkLost;
      out.error =
          port_name + ": link lost: " + result.cause + "; the board's watchdog stops the torque; nothing re-enabled";
      try {
        session.send_command(link::Command::kDisable);  // in case the line is still there
      } catch (const link::LinkError&) {
      }
      break;
  }
}

RunOutcome RunJob::execute(link::LinkSession& session, const std::string& port_name, const link::TelemetryPayload& t0,
                           const volatile std::sig_atomic_t& stop_signal,
                           const std::function<void(const std::string&)>& log,
                           const std::function<void(const RunProgress&)>& progress) {
  struct Finished {  // whatever way execute() ends, later requests are refused
    RunJob& job;
    ~Finished() {
      std::lock_guard<std::mutex> lock(job.mutex_);
      job.loop_ = nullptr;
      job.finished_ = true;
    }
  } finished{*this};
  log(std::string(state_name(HostState::kDisconnected)) + " -> " + state_name(state_of(t0)) + " (" +
      link::describe_state(t0) + ")");
  check_ready(port_name, t0, log);

  const link::TelemetryPayload rest = wait_at_rest(session, port_name);

  Vec3 start;
  StreamPlan plan = plan_from_rest(port_name, rest, &start);

  RunOutcome out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_signal != 0 || stop_pending_) {  // stopped before anything moved
      out.outcome = "stopped";
      out.code = stop_signal != 0 ? 128 + static_cast<int>(stop_signal) : kExitOk;
      out.summary = "stopped before the enable: nothing moved, nothing recorded\n";
      return out;
    }
  }

  const std::string lock_note = enable_primed(session, port_name, t0, &out);
  log(std::string("homed -> running: ") + std::to_string(plan.size()) + " samples (" +
      std::to_string(plan.approach_samples()) + " to the start, then " + request_.trajectory + " for " +
      fixed(path_.duration_s(), 3) + " s)");

  RecordQueue queue(1 << 14);
  const auto wall_start = std::chrono::steady_clock::now();
  const StreamingResult result = stream_and_record(session, plan, start, queue, stop_signal, lock_note, log, progress);

  stop(session, port_name, result, start, stop_signal, log, &out);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  recorder_->write_outcome(out.outcome, result.last.tick, out.code, out.error);
  const std::string record_error = recorder_->file.close();
  const std::uint64_t underruns =
      recorder_->underruns_at_first_play ? recorder_->underruns_at_end - *recorder_->underruns_at_first_play : 0;
  out.summary = summary_text(result, session, recorder_->tracking, recorder_->ramp_in, underruns, recorder_->rows,
                             out.record, wall);
  if (!record_error.empty()) out.summary += "warning: the recording is incomplete: " + record_error + "\n";
  out.summary += run_headline(out.record);
  if (queue.dropped() > 0)
    out.summary += "warning: " + std::to_string(queue.dropped()) + " telemetry records not recorded\n";
  out.played = result.played;
  out.planned = result.planned;
  return out;
}

// Beyond this share of the frames lost, the record's warning says what to do about it.
constexpr double kLostFramesAdvicePercent = 1.0;

RecordJob::RecordJob(const RecordRequest& request)
    : request_(request), recorder_(std::make_unique<TelemetryRecorder>(request.record, RecordMode::kReplace, false)) {}

RecordJob::~RecordJob() = default;

RunOutcome RecordJob::execute(link::LinkSession& session, const std::string& port_name,
                              const link::TelemetryPayload& t0, const volatile std::sig_atomic_t& stop_signal,
                              const std::function<void(const std::string&)>& log) {
  const Referencing referencing = board_referencing(t0);
  if (referencing != Referencing::kHomeSwitches && !request_.unreferenced) {  // one line, before anything else
    throw HostFailure(kExitFault, port_name + ": the board is not homed at its references (" + unreferenced_reason(t0) +
                                      "): a calibration drag would carry that pose as joint offsets; run "
                                      "deltactl host home first (or record anyway with --unreferenced); "
                                      "nothing recorded");
  }
  log(std::string(state_name(HostState::kDisconnected)) + " -> " + state_name(state_of(t0)) + " (" +
      link::describe_state(t0) + ")");
  if (t0.has(link::TelemetryFlag::kDriveEnable)) {
    throw HostFailure(kExitFault, port_name + ": the drives are on (another controller?); record only with them off");
  }
  if (referencing != Referencing::kHomeSwitches) {
    log("warning: the board is not homed at its references (" + unreferenced_reason(t0) +
        "); recording anyway (--unreferenced): the recording says 'referenced: " + referencing_name(referencing) +
        "', and diagnose and train refuse it unless told");
  }
  RunOutcome out;
  out.outcome = "completed";
  const auto wall_start = std::chrono::steady_clock::now();
  auto next_progress = wall_start + std::chrono::seconds(5);
  const std::int64_t end_tick =
      request_.duration_s > 0.0 ? static_cast<std::int64_t>(t0.tick) + std::llround(request_.duration_s * 1e4) : -1;
  link::TelemetryPayload t = t0, first = t0;
  std::uint64_t frames = 1;
  recorder_->open(referencing);
  TelemetryRecord r0;
  r0.telemetry = t0;
  recorder_->write(r0);
  try {
    for (;;) {
      if (stop_signal != 0) {
        out.outcome = "stopped";
        out.code = 128 + static_cast<int>(stop_signal);
        log("stopped by signal " + std::to_string(stop_signal) + " (the drives were off throughout)");
        break;
      }
      t = session.next_telemetry();
      if (end_tick >= 0 && static_cast<std::int64_t>(t.tick) > end_tick) break;
      TelemetryRecord r;
      r.telemetry = t;
      recorder_->write(r);
      if (++frames % 64 == 0) recorder_->file.flush();
      if (t.has(link::TelemetryFlag::kDriveEnable)) {  // not this host's doing: stop recording, say so
        out.outcome = "fault";
        out.code = kExitFault;
        out.error = port_name + ": the drives went on during the recording (another controller?)";
        break;
      }
      if (std::chrono::steady_clock::now() >= next_progress) {
        log(fixed(link::ticks_s(t.tick - first.tick), 1) + " s of board time recorded");
        next_progress += std::chrono::seconds(5);
      }
    }
  } catch (const link::LinkError& error) {
    out.outcome = "link lost";
    out.code = kExitLinkLost;
    out.error = port_name + ": link lost: " + error.what();
  }
  recorder_->write_outcome(out.outcome, t.tick, out.code, out.error);
  const std::string incomplete = recorder_->file.close();
  if (!incomplete.empty() && out.code == kExitOk) {
    out.code = kExitBadInput;
    out.error = request_.record + ": " + incomplete;
  }
  const link::LinkStatistics& link = session.statistics();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  // Frames the board sent that never became rows (the line dropped them, or the host did not read in
  // time and the port's buffer overflowed): each row keeps its board time, so merge and the fits
  // are right on the rows there are, but the drag's coverage has gaps.
  const std::uint64_t lost = link.lost_telemetry + link.skipped_telemetry;
  const double lost_percent = 100.0 * static_cast<double>(lost) / static_cast<double>(frames + lost);
  std::ostringstream summary;
  summary << "record: " << frames << " telemetry frames over " << fixed(link::ticks_s(t.tick - first.tick), 3)
          << " s of board time (" << fixed(wall, 1) << " s wall), drives off; " << lost << " lost ("
          << fixed(lost_percent, 2) << " %: on the line " << link.lost_telemetry << ", skipped "
          << link.skipped_telemetry << "); referenced: " << referencing_name(referencing)
          << "\nrecording: " << request_.record << " (" << recorder_->rows << " rows)\n";
  if (lost > 0) {
    const std::string warning = "warning: " + std::to_string(lost) + " of " + std::to_string(frames + lost) +
                                " telemetry frames (" + fixed(lost_percent, 2) +
                                " %) were lost and are missing from the recording" +
                                (lost_percent > kLostFramesAdvicePercent
                                     ? ": the host did not keep up or the line drops frames; give the host a core of "
                                       "its own (or a low-latency port) and record again"
                                     : "");
    log(warning);
    summary << warning << '\n';
  }
  out.summary = summary.str();
  out.played = frames;
  return out;
}

}  // namespace delta::controller
