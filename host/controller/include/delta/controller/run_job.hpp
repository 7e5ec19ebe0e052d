// One run of the host controller, as `deltactl host run` and `deltactl host serve` both do it: the
// trajectory and the recording checked before any byte is sent, then, on an identified board, the
// state checks, the plan from the pose the encoders report (checked again), enable, the streaming
// loop (host_run.hpp) with the recording written off its thread, and the stop: hold and disable
// after a completed or stopped run, disable after a fault or a link loss. Nothing is ever enabled
// again after a fault or a link loss. Also the port: found by path or /dev/serial/by-id name.
#pragma once

#include <atomic>
#include <csignal>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>

#include "delta/controller/board_network.hpp"
#include "delta/controller/host_run.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/link/session.hpp"

namespace delta::controller {

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
// HostFailure (exit 5) unless the board runs this checkout's gateware and the weights' CRC.
void check_board_identity(const link::IdentifyPayload& identify, const BoardWeights& weights,
                          const std::string& weights_path, const std::string& port_name);

struct RunRequest {
  std::string trajectory;  // NAME of `deltactl simulate` or FILE.csv
  double duration_s = 0.0;
  std::string record;  // OUT.csv
  int link_timeout_ms = 100;
  double following_error_deg = 2.0;  // the host's bound (StreamingOptions)
  StreamLimits limits;
};

struct RunOutcome {
  int code = 0;         // 0, 3, 4, or 128 + N after a controlled stop on signal N
  std::string error;    // one line when code is 3 or 4
  std::string outcome;  // completed, stopped, fault, link lost
  std::string summary;  // the run summary (several lines)
  std::size_t played = 0, planned = 0;
};

// Progress for the caller, every 200 ms (from the thread that called execute()).
struct RunProgress {
  std::size_t played = 0, planned = 0;
  FeedState feed = FeedState::kStreaming;
};

struct TelemetryRecorder;  // the recording's rows (run_job.cpp)

class RunJob {
 public:
  // Checks the trajectory whole (from its own start) and opens the recording before any byte is
  // sent: InputError (a file's line) or HostFailure (the plan's first offending sample), exit 2.
  RunJob(const BoardWeights& weights, const RunRequest& request);
  ~RunJob();

  // On an identified board whose telemetry is t0: not faulted, drives off, homed (HostFailure,
  // exit 3), the plan from the encoders' pose checked (HostFailure, exit 2), enable, stream, stop. `log`
  // gets one-line state changes; `progress` every 200 ms. The recording is committed.
  RunOutcome execute(link::LinkSession& session, const std::string& port_name, const link::TelemetryPayload& t0,
                     const volatile std::sig_atomic_t& stop_signal, const std::function<void(const std::string&)>& log,
                     const std::function<void(const RunProgress&)>& progress);

  // From another thread while execute() streams: hold, resume, stop. False when not streaming.
  bool request(FeedRequest request);
  // The plan's samples (0 before the plan is made) and those played so far.
  RunProgress progress() const;

 private:
  const BoardWeights& weights_;
  RunRequest request_;
  Path path_;
  std::unique_ptr<TelemetryRecorder> recorder_;
  std::atomic<StreamingLoop*> loop_{nullptr};
};

// `deltactl host record`: the drives stay off (nothing but identify is sent); every telemetry frame
// is recorded for duration_s of board time (0: until a signal). The lab's calibration run, the
// measuring stage dragging the plate (SPEC.md, "The lab's measurements").
struct RecordRequest {
  std::string record;       // RUN.csv
  double duration_s = 0.0;  // board time from the first telemetry frame
};

class RecordJob {
 public:
  // Opens the recording before any byte is sent (InputError, exit 2).
  explicit RecordJob(const RecordRequest& request);
  ~RecordJob();
  // On an identified board whose telemetry is t0 (drives off, else HostFailure exit 3): records
  // until the duration or a signal (code 128 + N), a drive enable by anyone else (exit 3) or link
  // loss (exit 4). The recording is committed.
  RunOutcome execute(link::LinkSession& session, const std::string& port_name, const link::TelemetryPayload& t0,
                     const volatile std::sig_atomic_t& stop_signal, const std::function<void(const std::string&)>& log);

 private:
  RecordRequest request_;
  std::unique_ptr<TelemetryRecorder> recorder_;
};

}  // namespace delta::controller
