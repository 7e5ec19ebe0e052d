// The host controller's run (deltactl host run): the session's explicit states, the streaming
// thread with absolute 1 ms deadlines that reads telemetry, supervises the board and the link and
// sends setpoints paced by the telemetry (link::SetpointPacer), and the recording, written by
// another thread from a lock-free queue (no file output, lock or allocation in the loop's steady
// state: the decoder's frame vectors aside). The co-simulation (deltactl cosim) runs this same loop
// with board time as its clock (StreamingOptions::clock).
//
//   disconnected -> idle (identified) -> homed -> running -> (holding) -> homed (drives off)
//                                          any -> fault (latched by the board; never re-enabled here)
//
// Supervision in every cycle: no telemetry for link_timeout_ms of wall time (or the device hung
// up) is link loss: the loop ends and nothing is enabled again (the board's watchdog stops
// the torque). A telemetry frame with the fault flag ends the loop with the board's cause; one with
// the drives off and no fault (a disable from another program, a board reset) ends it at once
// (kDrivesOff: the board plays nothing more, waiting would never end). A stop request (SIGINT,
// SIGTERM, SIGHUP, SIGQUIT, or request(kStop)) ends the plan by a ramp of the path's rate to 0
// (StreamPlan::stop_from); a stop not done after 1 s of board time ends the loop anyway (the caller
// holds and disables).
//
// Feed hold (request(kHold)): the same ramp to rest on the path, then the board's hold command
// (sent again every 4 frames while held: it is idempotent and keeps the board's watchdog fed);
// resume (request(kResume)): the plan grows by a ramp back to speed and the rest of the path, its
// first setpoints are sent, then enable (the board resumes from its buffer: no underrun).
//
//   streaming -(hold)-> holding (ramping to rest) -> held (board holding) -(resume)-> resuming
//   -> streaming; any -(stop)-> stopping -> done
#pragma once

#include <atomic>
#include <csignal>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "delta/controller/realtime.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/link/session.hpp"

namespace delta::controller {

enum class HostState { kDisconnected, kIdle, kHomed, kRunning, kHolding, kFault };
const char* state_name(HostState state);
// The state the telemetry shows (idle: not homed).
HostState state_of(const link::TelemetryPayload& telemetry);

// One telemetry frame as the recording keeps it, with the reference the host sent for the sample
// whose answer is the joint reference at that tick (stream sample s - 2: docs/board_link.md).
struct TelemetryRecord {
  link::TelemetryPayload telemetry;
  Vec3 reference_m = Vec3::Zero();  // as sent: the position codes decoded (-1: none yet, the start pose)
  double tau_s = -1.0;              // path time of that sample (-1: the approach or before)
  std::int64_t stream_sample = -1;  // its stream index (-1: before the stream)
};

// Single producer (the streaming thread), single consumer (the writer): a fixed ring.
class RecordQueue {
 public:
  explicit RecordQueue(std::size_t capacity) : ring_(capacity) {}
  bool push(const TelemetryRecord& record);  // false when full (counted in dropped())
  bool pop(TelemetryRecord& record);
  std::uint64_t dropped() const { return dropped_.load(); }

 private:
  std::vector<TelemetryRecord> ring_;
  std::atomic<std::size_t> head_{0}, tail_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

struct StreamingOptions {
  int link_timeout_ms = link::kLinkTimeoutMs;  // wall time without telemetry: link lost
  int period_us = 1000;                        // the loop's period (absolute deadlines)
  int priority = 80;                           // SCHED_FIFO priority when permitted
  // The host's own following-error bound (|encoder - joint reference|, any joint, drives on),
  // tighter than the board's 5.12 deg: exceeded, the run ends as a fault and the drives go off.
  double following_error_deg = 2.0;
  link::SessionOptions session;
  // The loop's time. nullptr: CLOCK_MONOTONIC, the thread made SCHED_FIFO when permitted (the lab).
  // Another clock (the co-simulation's board time) is used as it is: no real-time request.
  LoopClock* clock = nullptr;
};

struct StreamingResult {
  enum class Outcome { kCompleted, kStopped, kFault, kLinkLost, kDrivesOff };
  Outcome outcome = Outcome::kCompleted;
  std::string cause;          // fault or link loss, one line
  std::string realtime_note;  // "" or why SCHED_FIFO was not granted
  WakeLatency latency;        // wake time - deadline, every cycle
  std::uint64_t cycles = 0;
  std::uint64_t overruns = 0;  // periods missed entirely (woke more than one period late)
  std::uint64_t telemetry_frames = 0;
  double longest_telemetry_gap_ms = 0.0;  // wall time between telemetry frames
  std::size_t played = 0;                 // stream samples the board played
  std::size_t planned = 0;                // of a plan of (after a stop: the shortened plan)
  std::uint32_t first_index = 0;          // board sample index of stream sample 0
  link::TelemetryPayload first, last;     // telemetry at the start and the end of the stream
  std::uint64_t setpoints_resent = 0;
  std::uint64_t holds = 0;  // feed holds that came to rest
  double held_s = 0.0;      // board time spent held
};

// completed, stopped, fault, link lost, drives off.
const char* outcome_name(StreamingResult::Outcome outcome);

// kEstop: the drives off at the next cycle (the disable command goes out before any further
// setpoint); the run ends as a fault with the cause "e-stop". Sticky: no later request undoes it.
enum class FeedRequest : int { kNone, kHold, kResume, kStop, kEstop };
enum class FeedState : int { kStreaming, kHolding, kHeld, kResuming, kStopping };
const char* feed_name(FeedState state);

// The loop; run() in the streaming thread. `stop_request` (a signal number, 0: none) is polled.
class StreamingLoop {
 public:
  // The plan's positions are shaped (nn::shape_setpoint with weights.model) as they are sent.
  StreamingLoop(link::LinkSession& session, StreamPlan& plan, const golden::BoardWeights& weights, const Vec3& start_m,
                RecordQueue& queue, const StreamingOptions& options, const volatile std::sig_atomic_t& stop_request);
  void run();
  const StreamingResult& result() const { return result_; }
  // Progress for another thread.
  std::size_t played() const { return played_.load(); }
  std::size_t planned() const { return planned_.load(); }
  bool stopping() const { return feed() == FeedState::kStopping; }
  FeedState feed() const { return static_cast<FeedState>(feed_.load()); }
  // From another thread; taken at the next telemetry frame. Hold is ignored unless streaming (or
  // resuming); resume unless holding or held; a stop always ends the run at rest.
  void request(FeedRequest request) {
    if (request == FeedRequest::kEstop)
      estop_.store(true);
    else
      request_.store(static_cast<int>(request));
  }

 private:
  link::LinkSession& session_;
  StreamPlan& plan_;
  const golden::BoardWeights& weights_;
  const golden::QuantisedNetwork& network_;
  Vec3 start_m_;
  RecordQueue& queue_;
  StreamingOptions options_;
  const volatile std::sig_atomic_t& stop_request_;
  StreamingResult result_;
  std::atomic<std::size_t> played_{0}, planned_{0};
  std::atomic<int> feed_{static_cast<int>(FeedState::kStreaming)};
  std::atomic<int> request_{static_cast<int>(FeedRequest::kNone)};
  std::atomic<bool> estop_{false};
};

// Tracking of a run from its telemetry (encoder count - joint reference, degrees), off the loop.
struct TrackingStatistics {
  std::uint64_t frames = 0;
  Vec3 sum_sq_deg2 = Vec3::Zero();
  Vec3 max_abs_deg = Vec3::Zero();
  void add(const link::TelemetryPayload& telemetry);
  Vec3 rms_deg() const;
};

}  // namespace delta::controller
