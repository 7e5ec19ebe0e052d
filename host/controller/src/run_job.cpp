// One run of the host controller (see run_job.hpp).
#include "delta/controller/run_job.hpp"

#include <dirent.h>

#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <system_error>
#include <thread>

#include "delta/board_facts.hpp"
#include "delta/command.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/output_file.hpp"
#include "delta/table.hpp"

namespace delta::controller {
namespace {

constexpr double kCountDeg = board::kEncoderCountMicrodeg * 1e-6;

std::string hex(std::uint32_t value) { return golden::hex_word(value, 32); }

int link_error_code(const link::LinkError& error) {
  return error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault;
}

}  // namespace

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

void check_board_identity(const link::IdentifyPayload& identify, const BoardWeights& weights,
                          const std::string& weights_path, const std::string& port_name) {
  const std::uint32_t crc = weights_crc(weights.network);
  if (identify.build_id != kGatewareBuildId || identify.weights_crc != crc) {
    throw HostFailure(kExitMismatch, port_name + ": the board runs gateware " + hex(identify.build_id) +
                                         " with weights CRC " + hex(identify.weights_crc) +
                                         "; this host expects gateware " + hex(kGatewareBuildId) + " and weights CRC " +
                                         hex(crc) + " (" + weights_path + ")");
  }
}

// The recording's rows, off the streaming thread.
struct RunJob::Recorder {
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

namespace {

std::string summary_text(const StreamingResult& s, const link::LinkSession& session, const TrackingStatistics& tracking,
                         std::uint64_t underruns, std::uint64_t rows, const std::string& record_path, double wall_s) {
  const link::LinkStatistics& link = session.statistics();
  const link::TelemetryPayload& last = *session.last_telemetry();
  const Vec3 rms = tracking.rms_deg();
  const std::uint64_t host_bad = link.decoder.bad_crc + link.decoder.bad_length + link.decoder.unknown_type;
  std::ostringstream out;
  out << "stream: " << s.played << " of " << s.planned << " samples played from board index " << s.first_index << " ("
      << fixed((s.last.tick - s.first.tick) / 1e4, 3) << " s of board time, " << fixed(wall_s, 1) << " s wall)";
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
      << "tracking (encoder - joint reference while streaming, " << tracking.frames << " frames): rms "
      << fixed(rms[0], 4) << " / " << fixed(rms[1], 4) << " / " << fixed(rms[2], 4) << " deg, max "
      << fixed(tracking.max_abs_deg[0], 3) << " / " << fixed(tracking.max_abs_deg[1], 3) << " / "
      << fixed(tracking.max_abs_deg[2], 3) << " deg\n"
      << "recording: " << record_path << " (" << rows << " rows)\n";
  return out.str();
}

}  // namespace

RunJob::RunJob(const BoardWeights& weights, const RunRequest& request)
    : weights_(weights), request_(request), path_(load_path(request.trajectory, request.duration_s)) {
  // The path alone (from its own start): the approach is checked once the pose is known.
  const StreamPlan plan(path_, path_.samples.front().position_m, request_.limits);
  if (auto violation =
          check_plan(plan, request_.trajectory, weights_.trained_min_m, weights_.trained_max_m, request_.limits)) {
    throw HostFailure(kExitBadInput, *violation + "; nothing sent");
  }
  recorder_ = std::make_unique<Recorder>(request_.record);  // refuses a bad path before the port
}

RunJob::~RunJob() = default;

bool RunJob::request(FeedRequest request) {
  if (request == FeedRequest::kEstop) estop_.store(true);
  StreamingLoop* loop = loop_.load();
  if (!loop) return request == FeedRequest::kEstop;
  loop->request(request);
  return true;
}

RunProgress RunJob::progress() const {
  RunProgress p;
  if (StreamingLoop* loop = loop_.load()) {
    p.played = loop->played();
    p.planned = loop->planned();
    p.feed = loop->feed();
  }
  return p;
}

RunOutcome RunJob::execute(link::LinkSession& session, const std::string& port_name, const link::TelemetryPayload& t0,
                           const volatile std::sig_atomic_t& stop_signal,
                           const std::function<void(const std::string&)>& log,
                           const std::function<void(const RunProgress&)>& progress) {
  log(std::string(state_name(HostState::kDisconnected)) + " -> " + state_name(state_of(t0)) + " (" +
      link::describe_state(t0) + ")");
  if (t0.has(link::TelemetryFlag::kFault)) {
    throw HostFailure(kExitFault, port_name +
                                      ": the board has a latched fault: " + link::describe_fault(t0.fault_cause) +
                                      " (clear it deliberately; this host re-enables nothing by itself)");
  }
  if (t0.has(link::TelemetryFlag::kDriveEnable)) {
    throw HostFailure(kExitFault, port_name + ": the drives are already on (another controller?); refusing to run");
  }
  if (!t0.has(link::TelemetryFlag::kHomed)) {
    throw HostFailure(kExitFault,
                      port_name + ": the board is not homed (put the arms on their fixture: deltactl host home)");
  }

  // ---- the approach from the pose the encoders report, checked with the rest ----
  Vec3 counts_deg;
  for (int j = 0; j < 3; ++j) counts_deg[j] = t0.counts[j] * kCountDeg;
  Vec3 start;
  try {
    start = locate_plate(weights_.network, Geometry::nominal(), counts_deg);
  } catch (const std::runtime_error& error) {
    throw HostFailure(kExitFault, port_name + ": the encoders' pose: " + error.what());
  }
  StreamPlan plan(path_, start, request_.limits);
  if (auto violation =
          check_plan(plan, request_.trajectory, weights_.trained_min_m, weights_.trained_max_m, request_.limits)) {
    throw HostFailure(kExitBadInput, *violation + " (from the encoders' pose; no motion)");
  }

  // ---- homed -> running ----
  const std::string lock_note = lock_memory();
  if (estop_.load()) throw HostFailure(kExitFault, port_name + ": e-stop before the run started; nothing enabled");
  try {
    session.enable();
  } catch (const link::LinkError& error) {
    throw HostFailure(link_error_code(error), error.what());
  }
  log(std::string("homed -> running: ") + std::to_string(plan.size()) + " samples (" +
      std::to_string(plan.approach_samples()) + " to the start, then " + request_.trajectory + " for " +
      fixed(path_.duration_s(), 3) + " s)");

  RecordQueue queue(1 << 14);
  StreamingOptions streaming;
  streaming.link_timeout_ms = request_.link_timeout_ms;
  streaming.following_error_deg = request_.following_error_deg;
  streaming.session = session.options();
  StreamingLoop loop(session, plan, weights_.network, start, queue, streaming, stop_signal);
  const auto wall_start = std::chrono::steady_clock::now();
  std::atomic<bool> streaming_done{false};
  std::thread streamer([&loop, &streaming_done] {
    loop.run();
    streaming_done.store(true);
  });
  loop_.store(&loop);
  if (estop_.load()) loop.request(FeedRequest::kEstop);  // asked between the enable and now
  // This thread: the recording and the progress.
  TelemetryRecord r;
  auto next_progress = wall_start + std::chrono::milliseconds(200);
  bool warned = false;
  while (!streaming_done.load()) {
    while (queue.pop(r)) {
      recorder_->write(r);
      if (tap_) tap_(r);
    }
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
  loop_.store(nullptr);
  while (queue.pop(r)) {
    recorder_->write(r);
    if (tap_) tap_(r);
  }
  const StreamingResult& result = loop.result();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // ---- stop: hold and disable (nothing is ever re-enabled here) ----
  RunOutcome out;
  switch (result.outcome) {
    case StreamingResult::Outcome::kCompleted:
    case StreamingResult::Outcome::kStopped:
      out.outcome = result.outcome == StreamingResult::Outcome::kCompleted ? "completed" : "stopped";
      try {
        if (!estop_.load()) session.hold();  // an e-stop asked as the run ended: no hold first
        session.disable();
        log("running -> homed (drives off)");
      } catch (const link::LinkError& error) {
        out.code = link_error_code(error);
        out.error = std::string("stopping: ") + error.what();
      }
      if (out.code == kExitOk && result.outcome == StreamingResult::Outcome::kStopped && stop_signal != 0) {
        log("stopped by signal " + std::to_string(stop_signal) + " (controlled stop, drives off)");
        out.code = 128 + static_cast<int>(stop_signal);
      }
      break;
    case StreamingResult::Outcome::kFault:
      out.outcome = estop_.load() ? "e-stop" : "fault";
      out.code = kExitFault;
      out.error = estop_.load() ? port_name + ": e-stop on request: drives off, nothing re-enabled"
                                : port_name + ": the board faulted: " + result.cause + " (" +
                                      link::describe_state(result.last) + "); drives off, nothing re-enabled";
      try {
        session.send_command(link::Command::kDisable);
      } catch (const link::LinkError&) {
      }
      break;
    case StreamingResult::Outcome::kLinkLost:
      out.outcome = "link lost";
      out.code = kExitLinkLost;
      out.error =
          port_name + ": link lost: " + result.cause + "; the board's watchdog stops the torque; nothing re-enabled";
      try {
        session.send_command(link::Command::kDisable);  // in case the line is still there
      } catch (const link::LinkError&) {
      }
      break;
  }
  recorder_->file.commit();
  const std::uint64_t underruns =
      recorder_->underruns_at_first_play ? recorder_->underruns_at_end - *recorder_->underruns_at_first_play : 0;
  out.summary = summary_text(result, session, recorder_->tracking, underruns, recorder_->rows, request_.record, wall);
  if (queue.dropped() > 0)
    out.summary += "warning: " + std::to_string(queue.dropped()) + " telemetry records not recorded\n";
  out.played = result.played;
  out.planned = result.planned;
  return out;
}

}  // namespace delta::controller
