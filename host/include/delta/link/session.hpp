// A host's session with a board over the link v2 (docs/board_link.md): identify, set home, enable,
// hold and disable, the non-blocking primitives a streaming loop sends 1 kHz setpoints with (paced
// by SetpointPacer), while collecting every telemetry frame and the link's statistics. It speaks through any
// io::ByteStream (the serial port, the virtual board's pseudo-terminal, or the virtual board in process) and knows only
// what the frames tell: no device, no simulator, no wall-clock pacing.
//
// Pacing (docs/board_link.md, "Setpoints"): each telemetry frame gives the next sample index the
// board plays (s) and its buffer fill; the session keeps `target_fill` samples sent ahead of s
// (sent - s, which counts those still on the line) and never more than `max_setpoints_per_frame`
// per telemetry frame (the line's budget: 100 bytes per ms, 22 per setpoint). A setpoint the board
// did not take (corrupted on the line, refused) shows as the board's next free index (s + fill)
// staying below one sent `resend_after_frames` telemetry frames ago: the session sends again from
// the board's next free index. Only the newest frame paces: frames that piled up while the host
// could not run are stale (the setpoints sent since would look lost on them and go out twice).
//
// Timing: the board plays sample s at the first control period of the next 1 ms segment after the
// telemetry snapshot that names it (tick T + 10) and its network answer is the joint reference one
// segment later (tick T + 20). A sample n places after s reaches its reference at T + 20 + 10 n if
// the board plays on without underrun; the session hands that tick to the setpoint source, so the
// host sends each sample the position for the time the board will reach it (latency compensated:
// 1 ms of network and interpolation plus the wait in the buffer).
#pragma once

#include <algorithm>
#include <array>
#include <bitset>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "delta/io/byte_stream.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"

namespace delta::link {

// Board control periods (telemetry tick) per setpoint and per second.
constexpr std::int64_t kTicksPerSetpoint = board::kPeriodsPerSetpoint;
constexpr double kTickSeconds = 1.0 / static_cast<double>(board::kControlRateHz);

// The host controller's streaming budget (docs/board_link.md, "Streaming budget"): it keeps
// board::kStreamLeadSetpoints samples (200 ms) sent ahead, within the board's buffer, and calls
// the link lost after as long without telemetry; the board's watchdog waits longer still, so a
// host that stalls for less than the lead loses nothing and one that dies stops the drives within
// the watchdog's bound of its last frame.
constexpr int kLinkTimeoutMs = static_cast<int>(board::kStreamLeadSetpoints * 1000 / board::kSetpointRateHz);
static_assert(board::kStreamLeadSetpoints < board::kSetpointDepth, "the lead must fit the board's buffer");
static_assert(kLinkTimeoutMs * board::kControlRateHz / 1000 < board::kWatchdogPeriods,
              "the board's watchdog must outwait the host's link bound");

class LinkError : public std::runtime_error {
 public:
  enum class Kind {
    kLinkLost,  // no frame within the timeout (or the stream failed)
    kProtocol,  // an identify reply of another protocol version
    kRefused,   // the board refused a command (its `rejected` counter rose)
    kFault,     // the board latched a fault
  };
  LinkError(Kind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

struct SessionOptions {
  int frame_timeout_ms = 1000;      // no frame for this long (the stream's clock): link lost
  int command_timeout_frames = 20;  // telemetry frames to wait for a command's effect
  std::uint32_t target_fill = 20;   // samples kept sent ahead of the board's next sample (host: the lead)
  std::uint32_t max_setpoints_per_frame = 4;
  std::uint32_t resend_after_frames = 3;
  bool keep_telemetry = true;  // collect every telemetry frame (telemetry())
};

// What the link did, host side; the board's own counters are in the last telemetry frame.
struct LinkStatistics {
  std::uint64_t telemetry_frames = 0;
  std::uint64_t identify_frames = 0;
  std::uint64_t lost_telemetry = 0;     // gaps in the telemetry sequence numbers: frames lost on the line
  std::uint64_t skipped_telemetry = 0;  // 1 ms periods without a telemetry frame beyond the lost ones
  DecoderCounters decoder;              // host-side decoder: accepted, dropped, skipped bytes
  std::uint64_t frames_sent = 0;
  std::uint64_t setpoints_sent = 0;    // setpoint frames, resent ones included
  std::uint64_t setpoints_resent = 0;  // sent again after the board did not take them
  std::uint64_t commands_sent = 0;
  std::uint64_t bytes_sent = 0;
  std::uint64_t bytes_received = 0;
};

// The pacing rule as a value type, for the loop that owns the timing (the host controller's
// streaming loop, controller::StreamingLoop, which the lab's host and the co-simulation both run):
// given each telemetry frame, it says which stream samples to send now. The end may be moved earlier while streaming (a
// controlled stop). No allocation after construction.
class SetpointPacer {
 public:
  // `capacity`: the most samples set_samples may ask for later (a plan that grows by feed holds).
  SetpointPacer(const SessionOptions& options, std::uint32_t first_index, std::size_t samples, std::size_t capacity = 0)
      : options_(options),
        first_(first_index),
        end_(static_cast<std::int64_t>(first_index) + static_cast<std::int64_t>(samples)),
        next_(first_index),
        sent_at_frame_(std::max(samples, capacity), 0) {}

  // Calls send(k, sample_index, reach_tick) for each stream sample k to send now (resends
  // included, with the same k); `now` is the newest telemetry frame. Returns the samples sent.
  template <typename Send>
  std::size_t update(const TelemetryPayload& now, Send&& send) {
    const std::int64_t playing = now.sample_index;
    const std::int64_t board_next = playing + now.fill;
    // A sample sent long enough ago that the board still has not taken: lost; send again from there.
    if (board_next < next_ && board_next >= first_ && board_next < end_ &&
        frame_ - sent_at_frame_[static_cast<std::size_t>(board_next - first_)] >= options_.resend_after_frames) {
      resent_ += static_cast<std::uint64_t>(next_ - board_next);
      next_ = board_next;
    }
    std::size_t sent = 0;
    for (std::uint32_t budget = options_.max_setpoints_per_frame;
         budget > 0 && next_ < end_ && next_ - playing < static_cast<std::int64_t>(options_.target_fill); --budget) {
      const std::size_t k = static_cast<std::size_t>(next_ - first_);
      const std::int64_t reach_tick = static_cast<std::int64_t>(now.tick) + kTicksPerSetpoint * (next_ - playing + 2);
      send(k, static_cast<std::uint32_t>(next_), reach_tick);
      sent_at_frame_[k] = frame_;
      ++next_;
      ++sent;
    }
    ++frame_;
    return sent;
  }

  // Stream samples the board has played, per `now`: 0 .. samples().
  std::size_t played(const TelemetryPayload& now) const {
    return static_cast<std::size_t>(
        std::clamp<std::int64_t>(static_cast<std::int64_t>(now.sample_index) - first_, 0, end_ - first_));
  }
  bool done(const TelemetryPayload& now) const { return static_cast<std::int64_t>(now.sample_index) >= end_; }
  std::size_t samples() const { return static_cast<std::size_t>(end_ - first_); }
  // Ends the stream after `samples` samples (at least those already sent; at most the capacity).
  void set_samples(std::size_t samples) {
    const std::int64_t end = first_ + static_cast<std::int64_t>(std::min(samples, sent_at_frame_.size()));
    end_ = std::max(end, next_);
  }
  std::uint32_t first_index() const { return first_; }
  std::size_t next() const { return static_cast<std::size_t>(next_ - first_); }  // the next stream sample to send
  std::uint64_t resent() const { return resent_; }

 private:
  SessionOptions options_;
  std::int64_t first_;
  std::int64_t end_;
  std::int64_t next_;  // the next sample index to send
  std::vector<std::uint64_t> sent_at_frame_;
  std::uint64_t frame_ = 0;
  std::uint64_t resent_ = 0;
};

// What a model load did (LinkSession::load_model).
struct ModelLoadReport {
  bool loaded = false;                         // every frame taken and the board shows a model (flag 7)
  std::size_t taken = 0;                       // frames the board took in order (0 .. frames)
  std::size_t sent = 0;                        // frames sent
  std::optional<std::uint16_t> refused_frame;  // the first frame number the board refused
  std::string problem;                         // "" when loaded, else what failed (one line)
  TelemetryPayload telemetry;                  // the frame that told
};

// Bytes of model frames a load keeps on their way to the board beyond the last one its telemetry
// shows accepted: half the board's receive ring (board::kRxRingBytes), whatever the latency of the
// line, the USB adapter and the host.
constexpr std::size_t kModelLoadWindowBytes = static_cast<std::size_t>(board::kRxRingBytes) / 2;

class LinkSession {
 public:
  explicit LinkSession(io::ByteStream& stream, SessionOptions options = {});

  // Asks the board who it is; throws LinkError (kProtocol) unless it speaks board::kProtocolVersion,
  // (kLinkLost) when no reply comes.
  IdentifyPayload identify();

  // The next telemetry frame (identify replies on the way are taken too); throws kLinkLost.
  TelemetryPayload next_telemetry();

  // Sends one command frame and waits until a telemetry frame satisfies `done`, sending it again
  // every 4 frames (a frame corrupted on the line is dropped silently); after
  // command_timeout_frames frames throws kRefused if the board's refused counter rose meanwhile,
  // else kLinkLost; kFault when `done` needs the drives and a fault is latched.
  TelemetryPayload command(Command command, const std::function<bool(const TelemetryPayload&)>& done);
  TelemetryPayload set_home();  // drives off: encoders := home count, homed
  TelemetryPayload enable();    // homed, no fault: drives on
  TelemetryPayload hold();      // drives on: the reference stops at the end of the segment
  TelemetryPayload disable();   // drives off, buffer flushed
  // Refused (LinkError kRefused, naming the causes) while a cause persists: a safety input still at
  // its stop level (the e-stop chain open, a drive in fault) or a joint's condition.
  TelemetryPayload clear_fault();
  TelemetryPayload estop();  // any state: drives off, the board's e-stop latched until a clear-fault

  // Sends a model load (golden::model_frames: frames 0 .. the commit, in order) paced by the
  // board's acceptance: at most kModelLoadWindowBytes of frames beyond the last one the telemetry's
  // `sequence` shows accepted, so the board's receive ring never overflows. A rise of the board's
  // `rejected` counter (the drives on; a frame out of order after one lost on the line) ends it:
  // the first refused frame is named (the board refuses every frame after the one it missed). So
  // does a load that stalls (no frame accepted for command_timeout_frames telemetry frames) and a
  // commit after which the board shows no model (its CRC of the words it took differs). Nothing
  // is resent: the caller starts again from frame 0. Throws kLinkLost only when the link is.
  ModelLoadReport load_model(const std::vector<ModelPayload>& frames);

  // Non-blocking primitives for a loop with its own timing (the host controller's streaming
  // thread): reads and decodes what the stream has (throws kLinkLost when it failed or hung up),
  // returns the frames taken; the oldest unread telemetry frame; one setpoint or command frame.
  std::size_t poll_frames();
  std::optional<TelemetryPayload> take_telemetry();
  // input_code: the scaled network inputs u (golden::setpoint_input of the position's codes).
  void send_setpoint(std::uint32_t sample_index, const std::array<std::int16_t, 3>& input_code);
  void send_command(Command command);
  // An identify request: a valid frame that changes nothing (it feeds the board's watchdog); the
  // reply is taken and dropped.
  void send_identify_request();
  void count_resent(std::uint64_t setpoints) { statistics_.setpoints_resent += setpoints; }

  const LinkStatistics& statistics() const { return statistics_; }
  const std::optional<TelemetryPayload>& last_telemetry() const { return last_telemetry_; }
  const std::vector<TelemetryPayload>& telemetry() const { return telemetry_; }
  const SessionOptions& options() const { return options_; }

 private:
  void send_frame(const Frame& frame);
  // Reads and decodes until at least one frame arrived; throws kLinkLost after frame_timeout_ms.
  void receive_frames();
  void take(const Frame& frame);

  // The frames an identify request was sent in, and the telemetry frames since: counted once one
  // names a frame of the request as the last the board accepted (earlier ones were on their way
  // before the board had it), or once kStaleFrames were not (the request lost: the wait goes on).
  class SentFrames {
   public:
    static constexpr std::uint64_t kStaleFrames = 64;
    void add(std::uint8_t sequence) { sent_.set(sequence); }
    void count(std::uint8_t accepted_sequence) {
      if (sent_.test(accepted_sequence) || stale_ >= kStaleFrames || counted_ > 0) {
        ++counted_;
      } else {
        ++stale_;
      }
    }
    std::uint64_t counted() const { return counted_; }
    std::uint64_t frames() const { return counted_ + stale_; }

   private:
    std::bitset<256> sent_;
    std::uint64_t stale_ = 0;
    std::uint64_t counted_ = 0;
  };

  io::ByteStream& stream_;
  SessionOptions options_;
  SentFrames* waiting_ = nullptr;  // identify's, while it waits (take() counts frames into it)
  FrameDecoder decoder_{Receiver::kHost};
  std::uint8_t sequence_ = 0;
  LinkStatistics statistics_;
  std::optional<TelemetryPayload> last_telemetry_;
  std::optional<std::uint8_t> last_telemetry_sequence_;
  std::vector<TelemetryPayload> telemetry_;
  std::deque<TelemetryPayload> unread_telemetry_;
  std::vector<IdentifyPayload> unread_identify_;
};

// One line of what the flags and fault cause say, e.g. "drives on, homed; fault: watchdog".
std::string describe_state(const TelemetryPayload& telemetry);
// The latched causes named, the board's own first ("e-stop command", "e-stop input open",
// "drive 2 fault"), then the joints' ("following error", ...); "none" if none.
std::string describe_fault(const TelemetryPayload& telemetry);

}  // namespace delta::link
