// One run of the host controller, as `deltactl host run` and `deltactl host serve` both do it: the
// trajectory and the recording checked before any byte is sent, then, on an identified board, the
// state checks, the plan from the pose the encoders report (checked again), enable, the streaming
// loop (host_run.hpp) with the recording written off its thread, and the stop: hold and disable
// after a completed or stopped run, disable after a fault, a link loss or the drives going off by
// another cause (a disable from another program, a board reset); disable is sent even when the hold
// fails. Nothing is ever enabled again after a fault or a link loss. Also the port: found by path or
// /dev/serial/by-id name.
//
// The recording is written under its own name from just before the enable on, flushed every few
// milliseconds and again after each frame of the final hold and disable: every way out of a run,
// even SIGKILL, leaves it there complete up to the last telemetry it got. A run refused before the
// enable leaves no file (a name reserved for it is removed).
#pragma once

#include <atomic>
#include <csignal>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/controller/host_run.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/link/session.hpp"

namespace delta::controller {

// Amperes per telemetry current code.
constexpr double kCurrentCodeA = board::kCurrentFullScaleMilliamp / 1000.0 / board::kCurrentLimitCode;

// The exit codes of `deltactl host` besides 0 and 2 (bad input, an InputError).
constexpr int kExitFault = 3;     // the board faulted or is not ready (the cause is printed)
constexpr int kExitLinkLost = 4;  // the link was lost (or the port could not be opened)
constexpr int kExitMismatch = 5;  // the board's gateware or weights differ from W.json

// A failure with its exit code and one line saying what to do.
class HostFailure : public std::runtime_error {
 public:
  HostFailure(int code, const std::string& message) : std::runtime_error(message), code_(code) {}
  int code() const { return code_; }

 private:
  int code_;
};

// PATH as given, or NAME under /dev/serial/by-id, or "icebreaker": the iCEBreaker's UART (the
// FT2232H's second interface, ...-if01-port0). HostFailure (exit 4) when not there.
std::string resolve_port(const std::string& port);
// Opened raw 8N1 at the board's rate, exclusively; HostFailure (exit 4) when it cannot be.
std::unique_ptr<io::SerialPort> open_board_port(const std::string& port);
// The session options of the host (frame timeout = the link bound; telemetry not kept).
link::SessionOptions host_session_options(int link_timeout_ms);

// Identify, then the newest telemetry. HostFailure: exit 4 (no answer), exit 5 (another protocol).
struct Connected {
  link::IdentifyPayload identify;
  link::TelemetryPayload telemetry;
};
Connected connect_board(link::LinkSession& session);
// HostFailure (exit 5) unless the board runs this checkout's gateware and holds W.json's model (the
// telemetry's model flag and identify's weights CRC): the message names which differs (the
// gateware, no model, another model) and, for the model, `deltactl host load`.
void check_board_identity(const Connected& board, const golden::BoardWeights& weights, const std::string& weights_path,
                          const std::string& port_name);

// Where a run's plan starts: the network's inverse at the counts of `rest` (the arms at rest, the
// drives off), moved to the deployed model's resting shift (the answer keeps each joint at the end of
// its play last taken up, so the enable moves no joint). std::runtime_error when the nominal model
// has no pose there. RunJob and the co-simulation start here. With a joint ripple table: the plate
// position whose shaped setpoint that is (nn::unshape_setpoint).
Vec3 start_at_rest(const golden::BoardWeights& weights, const link::TelemetryPayload& rest);

// How the recording's name is taken: kReplace (host run: the file is replaced when the drives are
// about to go on), kNew (created now, never replacing a file), kNewNumbered (created now; a name
// taken gets -2, -3, ... before its extension: default names never collide).
enum class RecordMode { kReplace, kNew, kNewNumbered };

struct RunRequest {
  std::string trajectory;  // NAME of `deltactl simulate` or FILE.csv
  double duration_s = 0.0;
  std::string record;  // OUT.csv
  RecordMode record_mode = RecordMode::kReplace;
  bool allow_unreferenced = false;  // run on a board homed by hand (not at its references)
  int link_timeout_ms = link::kLinkTimeoutMs;
  double following_error_deg = 2.0;  // the host's bound (StreamingOptions)
  StreamLimits limits;
};

struct RunOutcome {
  int code = 0;         // 0, 3, 4, or 128 + N after a controlled stop on signal N
  std::string error;    // one line when code is 3 or 4
  std::string outcome;  // completed, stopped, fault, link lost, drives off
  std::string summary;  // the run summary (several lines)
  std::string record;   // the recording's path ("" when the run was refused before the enable)
  std::size_t played = 0, planned = 0;
};

// Progress for the caller, every 200 ms (from the thread that called execute()).
struct RunProgress {
  std::size_t played = 0, planned = 0;
  FeedState feed = FeedState::kStreaming;
  std::optional<link::TelemetryPayload> telemetry;  // the newest frame recorded (a few ms old)
};

// Board time from one telemetry frame to a later one, seconds: the 10 kHz tick is a u32 (it wraps
// after 4.97 days); a later frame that shows an earlier tick (a restarted board) gives 0.
double board_seconds_between(const link::TelemetryPayload& from, const link::TelemetryPayload& to);

// `host run --check`: the path checked as a run checks it before the port is opened (from its own
// start, every sample and, with a joint ripple table, every setpoint as sent), every problem (none:
// empty); nothing opened, nothing sent. The move from where the encoders put the plate to the
// path's start is checked when a run starts. InputError for a FILE.csv that is not one.
std::vector<std::string> check_run(const golden::BoardWeights& weights, const RunRequest& request);
std::vector<std::string> check_path(const golden::BoardWeights& weights, const Path& path, const RunRequest& request);

struct TelemetryRecorder;  // the recording's rows (run_job.cpp)

class RunJob {
 public:
  // Checks the trajectory whole (from its own start) and the recording's path before any byte is
  // sent: InputError (a file's line) or HostFailure (the plan's first offending sample), exit 2.
  RunJob(const golden::BoardWeights& weights, const RunRequest& request);
  ~RunJob();

  // On an identified board whose telemetry is t0: not faulted, drives off, homed (HostFailure,
  // exit 3), the plan from the encoders' pose checked (HostFailure, exit 2), enable, stream, stop. `log`
  // gets one-line state changes; `progress` every 200 ms. The recording is committed.
  RunOutcome execute(link::LinkSession& session, const std::string& port_name, const link::TelemetryPayload& t0,
                     const volatile std::sig_atomic_t& stop_signal, const std::function<void(const std::string&)>& log,
                     const std::function<void(const RunProgress&)>& progress);

  // From another thread: hold, resume, stop, e-stop. A stop before the stream starts ends the run
  // before the enable (nothing moves); hold and resume return false when not streaming, stop when
  // finished. kEstop is taken at any time (true): before the enable, execute() refuses to run; while
  // streaming, the loop disables at once; after it, the stop disables without the hold.
  bool request(FeedRequest request);
  // The recording's path (with the number a taken default name got).
  const std::string& record_path() const;
  // Every telemetry record, from the thread that called execute() (never the streaming thread).
  void observe(std::function<void(const TelemetryRecord&)> tap) { tap_ = std::move(tap); }
  // The plan's samples (0 before the plan is made) and those played so far.
  RunProgress progress() const;

 private:
  // execute()'s phases, in order.
  void check_ready(const std::string& port_name, const link::TelemetryPayload& t0,
                   const std::function<void(const std::string&)>& log) const;
  link::TelemetryPayload wait_at_rest(link::LinkSession& session, const std::string& port_name) const;
  StreamPlan plan_from_rest(const std::string& port_name, const link::TelemetryPayload& rest, Vec3* start) const;
  std::string enable_primed(link::LinkSession& session, const std::string& port_name, const link::TelemetryPayload& t0,
                            RunOutcome* out);
  StreamingResult stream_and_record(link::LinkSession& session, StreamPlan& plan, const Vec3& start, RecordQueue& queue,
                                    const volatile std::sig_atomic_t& stop_signal, const std::string& lock_note,
                                    const std::function<void(const std::string&)>& log,
                                    const std::function<void(const RunProgress&)>& progress);
  void stop(link::LinkSession& session, const std::string& port_name, const StreamingResult& result, const Vec3& start,
            const volatile std::sig_atomic_t& stop_signal, const std::function<void(const std::string&)>& log,
            RunOutcome* out);

  const golden::BoardWeights& weights_;
  RunRequest request_;
  Path path_;
  std::unique_ptr<TelemetryRecorder> recorder_;
  mutable std::mutex mutex_;  // guards what follows
  StreamingLoop* loop_ = nullptr;
  bool stop_pending_ = false;  // a stop asked before the stream started
  bool finished_ = false;
  std::optional<link::TelemetryPayload> newest_;
  std::atomic<bool> estop_{false};
  std::function<void(const TelemetryRecord&)> tap_;
};

// `deltactl host record`: the drives stay off (nothing but identify is sent); every telemetry frame
// is recorded for duration_s of board time (0: until a signal). The lab's calibration run, the
// measuring stage dragging the plate (docs/contracts.md, "The lab's measurements").
struct RecordRequest {
  std::string record;         // RUN.csv
  double duration_s = 0.0;    // board time from the first telemetry frame
  bool unreferenced = false;  // record a board not homed at its references (else HostFailure, exit 3)
};

class RecordJob {
 public:
  // Opens the recording before any byte is sent (InputError, exit 2).
  explicit RecordJob(const RecordRequest& request);
  ~RecordJob();
  // On an identified board whose telemetry is t0 (drives off, and homed at its references unless
  // request.unreferenced, else HostFailure exit 3 before anything is recorded): records
  // until the duration or a signal (code 128 + N), a drive enable by anyone else (exit 3) or link
  // loss (exit 4). The recording is committed.
  RunOutcome execute(link::LinkSession& session, const std::string& port_name, const link::TelemetryPayload& t0,
                     const volatile std::sig_atomic_t& stop_signal, const std::function<void(const std::string&)>& log);

 private:
  RecordRequest request_;
  std::unique_ptr<TelemetryRecorder> recorder_;
};

}  // namespace delta::controller
