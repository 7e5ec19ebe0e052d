// The host controller's streaming loop (see host_run.hpp).
#include "delta/controller/host_run.hpp"

#include <algorithm>
#include <cmath>

#include "delta/board_facts.hpp"
#include "delta/nn/trained_model.hpp"

namespace delta::controller {
namespace {

// A controlled stop ends within about 0.4 s (the lead, the ramp to rest); past 1 s something else
// keeps the board from playing: the loop ends and the caller holds and disables.
constexpr std::uint32_t kStopBoundTicks = static_cast<std::uint32_t>(board::kControlRateHz);

}  // namespace

const char* state_name(HostState state) {
  switch (state) {
    case HostState::kDisconnected:
      return "disconnected";
    case HostState::kIdle:
      return "idle";
    case HostState::kHomed:
      return "homed";
    case HostState::kRunning:
      return "running";
    case HostState::kHolding:
      return "holding";
    case HostState::kFault:
      return "fault";
  }
  return "?";
}

const char* feed_name(FeedState state) {
  switch (state) {
    case FeedState::kStreaming:
      return "streaming";
    case FeedState::kHolding:
      return "holding (slowing to rest)";
    case FeedState::kHeld:
      return "held";
    case FeedState::kResuming:
      return "resuming";
    case FeedState::kStopping:
      return "stopping";
  }
  return "?";
}

HostState state_of(const link::TelemetryPayload& t) {
  if (t.has(link::TelemetryFlag::kFault)) return HostState::kFault;
  if (t.has(link::TelemetryFlag::kDriveEnable)) {
    return t.has(link::TelemetryFlag::kHolding) ? HostState::kHolding : HostState::kRunning;
  }
  return t.has(link::TelemetryFlag::kHomed) ? HostState::kHomed : HostState::kIdle;
}

const char* outcome_name(StreamingResult::Outcome outcome) {
  switch (outcome) {
    case StreamingResult::Outcome::kCompleted:
      return "completed";
    case StreamingResult::Outcome::kStopped:
      return "stopped";
    case StreamingResult::Outcome::kFault:
      return "fault";
    case StreamingResult::Outcome::kLinkLost:
      return "link lost";
    case StreamingResult::Outcome::kDrivesOff:
      return "drives off";
  }
  return "?";
}

bool RecordQueue::push(const TelemetryRecord& record) {
  const std::size_t head = head_.load(std::memory_order_relaxed);
  const std::size_t next = (head + 1) % ring_.size();
  if (next == tail_.load(std::memory_order_acquire)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  ring_[head] = record;
  head_.store(next, std::memory_order_release);
  return true;
}

bool RecordQueue::pop(TelemetryRecord& record) {
  const std::size_t tail = tail_.load(std::memory_order_relaxed);
  if (tail == head_.load(std::memory_order_acquire)) return false;
  record = ring_[tail];
  tail_.store((tail + 1) % ring_.size(), std::memory_order_release);
  return true;
}

StreamingLoop::StreamingLoop(link::LinkSession& session, StreamPlan& plan, const golden::BoardWeights& weights,
                             const Vec3& start_m, RecordQueue& queue, const StreamingOptions& options,
                             const volatile std::sig_atomic_t& stop_request)
    : session_(session),
      plan_(plan),
      weights_(weights),
      network_(weights.network),
      start_m_(start_m),
      queue_(queue),
      options_(options),
      stop_request_(stop_request) {}

void StreamingLoop::run() {
  MonotonicClock monotonic;
  LoopClock& clock = options_.clock != nullptr ? *options_.clock : monotonic;
  if (options_.clock == nullptr) result_.realtime_note = make_thread_realtime(options_.priority);
  const double code_m = std::ldexp(1.0, -network_.formats.input_fraction_bits);
  link::TelemetryPayload t = *session_.last_telemetry();
  // From the board's next sample: the enable started on an empty buffer (the board takes setpoints
  // only with the drives on), so nothing stale is counted as sent or played.
  link::SetpointPacer pacer(options_.session, t.sample_index, plan_.size(), plan_.capacity());
  result_.first_index = pacer.first_index();
  result_.first = t;
  result_.planned = plan_.size();
  planned_.store(plan_.size());
  std::vector<std::array<std::int32_t, 3>> codes(plan_.capacity());  // as sent (resends send the same)
  std::vector<Vec3> shaping_m(plan_.capacity(), Vec3::Zero());       // sent - planned (joint ripple table)
  std::size_t sent = 0;                                              // samples [0, sent) have codes
  auto send = [&](std::size_t k, std::uint32_t index, std::int64_t /*reach_tick*/) {
    sent = std::max(sent, k + 1);
    const Vec3 planned = plan_.position(k);
    const Vec3 shaped = nn::shape_setpoint(weights_.model, planned);
    shaping_m[k] = shaped - planned;
    const auto code = golden::encode_position(network_.formats, shaped);
    codes[k] = {static_cast<std::int32_t>(code[0]), static_cast<std::int32_t>(code[1]),
                static_cast<std::int32_t>(code[2])};
    session_.send_setpoint(index, golden::setpoint_input(network_, code));
  };
  auto record = [&](const link::TelemetryPayload& frame) {
    TelemetryRecord r;
    r.telemetry = frame;
    r.reference_m = start_m_;
    const std::int64_t k = static_cast<std::int64_t>(frame.sample_index) - 2 - pacer.first_index();
    const std::int64_t last = std::min<std::int64_t>(k, static_cast<std::int64_t>(plan_.size()) - 1);
    if (last >= 0 && static_cast<std::size_t>(last) < sent) {
      const auto& c = codes[static_cast<std::size_t>(last)];
      // The pose asked for: the code sent, less its shaping.
      r.reference_m = Vec3(c[0] * code_m, c[1] * code_m, c[2] * code_m) - shaping_m[static_cast<std::size_t>(last)];
      r.tau_s = plan_.tau(static_cast<std::size_t>(last));
      r.stream_sample = last;
    }
    queue_.push(r);
  };
  auto set_plan = [&](std::size_t samples) {
    pacer.set_samples(samples);
    result_.planned = pacer.samples();
    planned_.store(result_.planned);
  };
  auto set_feed = [&](FeedState state) { feed_.store(static_cast<int>(state)); };

  const std::int64_t period = static_cast<std::int64_t>(options_.period_us) * 1000;
  const std::int64_t timeout = static_cast<std::int64_t>(options_.link_timeout_ms) * 1'000'000;
  std::int64_t deadline = clock.now_ns();
  std::int64_t last_frame = deadline;
  FeedState feed = FeedState::kStreaming;
  bool resume_wanted = false;       // asked while still slowing down: resumed once held
  std::uint64_t command_frame = 0;  // telemetry frames since the last hold or enable sent
  std::uint32_t held_since_tick = 0;
  // A primed start (RunJob enables, then holds): the lead is sent while the board holds, then
  // enable (again every 4 frames until it plays), so the first plays never find the buffer short.
  bool priming = t.has(link::TelemetryFlag::kHolding), priming_enable_sent = false;
  std::uint32_t stop_tick = 0;  // when the stop was taken
  try {
    const std::uint64_t resent_before = pacer.resent();
    pacer.update(t, send);
    session_.count_resent(pacer.resent() - resent_before);
    for (;;) {
      deadline += period;
      clock.sleep_until_ns(deadline);
      const std::int64_t now = clock.now_ns();
      result_.latency.record(now - deadline);
      ++result_.cycles;
      if (now - deadline >= period) {  // keep the grid: skip the periods already gone
        const std::int64_t missed = (now - deadline) / period;
        result_.overruns += static_cast<std::uint64_t>(missed);
        deadline += missed * period;
      }
      // Before reading: a host that could not run (stopped, starved) for the bound has not
      // supervised the board meanwhile, whatever arrived since.
      if (now - last_frame > timeout) {
        result_.outcome = StreamingResult::Outcome::kLinkLost;
        result_.cause = "no telemetry from the board for " + std::to_string((now - last_frame) / 1'000'000) +
                        " ms (bound " + std::to_string(options_.link_timeout_ms) + " ms)";
        break;
      }
      if (estop_.load()) {  // ahead of anything else: the drives off now, the board's own e-stop latched
        session_.send_command(link::Command::kEstop);
        session_.send_command(link::Command::kDisable);
        result_.outcome = StreamingResult::Outcome::kFault;
        result_.cause = "e-stop on request: drives off";
        break;
      }
      session_.poll_frames();
      bool finished = false, fresh = false;
      while (auto frame = session_.take_telemetry()) {
        t = *frame;
        result_.longest_telemetry_gap_ms =
            std::max(result_.longest_telemetry_gap_ms, static_cast<double>(now - last_frame) / 1e6);
        last_frame = now;
        ++result_.telemetry_frames;
        ++command_frame;
        record(t);
        played_.store(pacer.played(t));
        if (t.has(link::TelemetryFlag::kFault)) {
          result_.outcome = StreamingResult::Outcome::kFault;
          result_.cause = link::describe_fault(t);
          finished = true;
          break;
        }
        if (!t.has(link::TelemetryFlag::kDriveEnable)) {
          result_.outcome = StreamingResult::Outcome::kDrivesOff;
          result_.cause = "the drives went off without a fault (" + link::describe_state(t) +
                          "): a disable from another program on the port, or a board reset";
          finished = true;
          break;
        }
        if (feed == FeedState::kStopping && t.tick - stop_tick > kStopBoundTicks) {
          result_.outcome = StreamingResult::Outcome::kStopped;
          result_.cause = "the controlled stop did not end within 1 s of board time";
          finished = true;
          break;
        }
        if (options_.following_error_deg > 0.0) {
          for (int j = 0; j < 3 && !finished; ++j) {
            const double error = t.following_error_deg(j);
            if (std::abs(error) > options_.following_error_deg) {
              result_.outcome = StreamingResult::Outcome::kFault;
              result_.cause = "following error on joint " + std::to_string(j + 1) + ": " + std::to_string(error) +
                              " deg beyond the host's bound " + std::to_string(options_.following_error_deg) + " deg";
              finished = true;
            }
          }
          if (finished) break;
        }
        // Requests: a signal or kStop ends the run at rest; hold and resume change the plan.
        const auto request = static_cast<FeedRequest>(request_.exchange(static_cast<int>(FeedRequest::kNone)));
        if ((stop_request_ != 0 || request == FeedRequest::kStop) && feed != FeedState::kStopping) {
          if (feed == FeedState::kHeld) {
            set_plan(pacer.next());  // at rest already (the board holds the rest of its buffer)
            result_.held_s += link::ticks_s(t.tick - held_since_tick);
          } else {
            set_plan(plan_.stop_from(pacer.next()));
          }
          feed = FeedState::kStopping;
          stop_tick = t.tick;
        } else if (request == FeedRequest::kHold && (feed == FeedState::kStreaming || feed == FeedState::kResuming)) {
          set_plan(plan_.hold_from(pacer.next()));
          feed = FeedState::kHolding;
          resume_wanted = false;
        } else if (request == FeedRequest::kResume && feed == FeedState::kHolding) {
          resume_wanted = true;
        } else if ((request == FeedRequest::kResume || resume_wanted) && feed == FeedState::kHeld) {
          resume_wanted = false;
          if (const std::size_t samples = plan_.resume()) {
            set_plan(samples);
            pacer.update(t, send);  // the buffer first, then the resume: no underrun
            session_.send_command(link::Command::kEnable);
            command_frame = 0;
            result_.held_s += link::ticks_s(t.tick - held_since_tick);
            feed = FeedState::kResuming;
          }
        }
        if (priming && !t.has(link::TelemetryFlag::kHolding)) {
          priming = false;
        } else if (priming && pacer.next() >= std::min<std::size_t>(options_.session.target_fill, pacer.samples()) &&
                   (!priming_enable_sent || command_frame >= 4)) {
          session_.send_command(link::Command::kEnable);
          command_frame = 0;
          priming_enable_sent = true;
        }
        if (feed == FeedState::kStopping && t.has(link::TelemetryFlag::kHolding)) {
          result_.outcome = StreamingResult::Outcome::kStopped;
          finished = true;  // stopped while held: at rest, the caller disables
          break;
        }
        if (feed == FeedState::kHolding && pacer.next() >= pacer.samples() && t.fill <= 2) {
          // The rest point is sent and playing: pause the board (the buffer's last samples, all
          // at rest, stay for the resume).
          session_.send_command(link::Command::kHold);
          command_frame = 0;
          feed = FeedState::kHeld;
          held_since_tick = t.tick;
          ++result_.holds;
        } else if (feed == FeedState::kHeld && command_frame >= 4) {
          session_.send_command(link::Command::kHold);  // idempotent; feeds the watchdog
          command_frame = 0;
        } else if (feed == FeedState::kResuming) {
          if (!t.has(link::TelemetryFlag::kHolding)) {
            feed = FeedState::kStreaming;
          } else if (command_frame >= 4) {
            session_.send_command(link::Command::kEnable);  // lost on the line: again
            command_frame = 0;
          }
        }
        set_feed(feed);
        if (feed != FeedState::kHeld && feed != FeedState::kHolding && pacer.done(t)) {
          result_.outcome =
              feed == FeedState::kStopping ? StreamingResult::Outcome::kStopped : StreamingResult::Outcome::kCompleted;
          finished = true;
          break;
        }
        fresh = true;
      }
      if (finished) break;
      // Paced by the newest frame only: after a late wake, the frames that piled up are stale (the
      // setpoints sent on them would look lost to the resend rule and go out twice).
      if (fresh) {
        const std::uint64_t resent = pacer.resent();
        pacer.update(t, send);
        session_.count_resent(pacer.resent() - resent);
      }
    }
  } catch (const link::LinkError& error) {
    result_.outcome = StreamingResult::Outcome::kLinkLost;
    result_.cause = error.what();
  }
  result_.played = pacer.played(t);
  result_.last = t;
  result_.setpoints_resent = pacer.resent();
}

void TrackingStatistics::add(const link::TelemetryPayload& t) {
  for (int j = 0; j < 3; ++j) {
    const double error = t.following_error_deg(j);
    sum_sq_deg2[j] += error * error;
    max_abs_deg[j] = std::max(max_abs_deg[j], std::abs(error));
  }
  ++frames;
}

Vec3 TrackingStatistics::rms_deg() const {
  return frames ? Vec3((sum_sq_deg2 / static_cast<double>(frames)).cwiseSqrt()) : Vec3(Vec3::Zero());
}

}  // namespace delta::controller
