// A host's session with a board over the link v3 (see session.hpp).
#include "delta/link/session.hpp"

#include <algorithm>
#include <chrono>
#include <system_error>

namespace delta::link {
namespace {

bool drives_on(const TelemetryPayload& t) { return t.has(TelemetryFlag::kDriveEnable); }

}  // namespace

LinkSession::LinkSession(io::ByteStream& stream, SessionOptions options) : stream_(stream), options_(options) {}

void LinkSession::send_frame(const Frame& frame) {
  const std::vector<std::uint8_t> bytes = encode_frame(frame);
  try {
    stream_.write_all(bytes.data(), bytes.size(), options_.frame_timeout_ms);
  } catch (const std::system_error& error) {
    throw LinkError(LinkError::Kind::kLinkLost, std::string("link: ") + error.what());
  }
  ++statistics_.frames_sent;
  statistics_.bytes_sent += bytes.size();
}

void LinkSession::take(const Frame& frame) {
  if (frame.type == FrameType::kIdentify) {
    ++statistics_.identify_frames;
    if (unread_identify_.size() >= 16) unread_identify_.erase(unread_identify_.begin());  // keep-alive replies
    unread_identify_.push_back(decode_identify(frame.payload));
    return;
  }
  if (frame.type != FrameType::kTelemetry) return;  // the decoder takes nothing else
  const TelemetryPayload telemetry = decode_telemetry(frame.payload);
  ++statistics_.telemetry_frames;
  if (last_telemetry_sequence_) {
    const int lost = static_cast<std::uint8_t>(frame.sequence - *last_telemetry_sequence_ - 1);
    statistics_.lost_telemetry += static_cast<std::uint64_t>(lost);
    const std::int64_t periods =
        (static_cast<std::int64_t>(telemetry.tick) - static_cast<std::int64_t>(last_telemetry_->tick)) /
        kTicksPerSetpoint;
    if (periods > 1 + lost) statistics_.skipped_telemetry += static_cast<std::uint64_t>(periods - 1 - lost);
  }
  last_telemetry_sequence_ = frame.sequence;
  last_telemetry_ = telemetry;
  if (waiting_ != nullptr) waiting_->count(telemetry.sequence);
  if (options_.keep_telemetry) telemetry_.push_back(telemetry);
  unread_telemetry_.push_back(telemetry);
}

std::size_t LinkSession::poll_frames() {
  std::uint8_t buffer[512];
  std::size_t frames_taken = 0;
  for (;;) {
    std::size_t got = 0;
    try {
      got = stream_.read_some(buffer, sizeof buffer);
    } catch (const std::system_error& error) {
      throw LinkError(LinkError::Kind::kLinkLost, std::string("link: ") + error.what());
    }
    if (got == 0) return frames_taken;
    statistics_.bytes_received += got;
    const std::vector<Frame> frames = decoder_.feed(buffer, got);
    statistics_.decoder = decoder_.counters();
    for (const Frame& frame : frames) take(frame);
    frames_taken += frames.size();
  }
}

void LinkSession::receive_frames() {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.frame_timeout_ms);
  long long left = options_.frame_timeout_ms;
  bool readable = false;
  // The clock is read after a wait that ended without a byte, and every 64 bytes that did not end
  // a frame (a stream of garbage still times out; a frame's bytes cost no clock reads).
  for (unsigned bytes = 0;; ++bytes) {
    if (poll_frames() > 0) return;
    if (!readable || bytes % 64 == 0) {
      left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    }
    if (left <= 0) {
      throw LinkError(LinkError::Kind::kLinkLost, stream_.name() + ": no frame from the board for " +
                                                      std::to_string(options_.frame_timeout_ms) + " ms");
    }
    try {
      readable = stream_.wait_readable(static_cast<int>(std::min<long long>(left, 100)), decoder_.bytes_to_decide());
    } catch (const std::system_error& error) {
      throw LinkError(LinkError::Kind::kLinkLost, std::string("link: ") + error.what());
    }
  }
}

std::optional<TelemetryPayload> LinkSession::take_telemetry() {
  if (unread_telemetry_.empty()) return std::nullopt;
  const TelemetryPayload telemetry = unread_telemetry_.front();
  unread_telemetry_.pop_front();
  return telemetry;
}

void LinkSession::send_setpoint(std::uint32_t sample_index, const std::array<std::int16_t, 3>& input_code) {
  SetpointPayload setpoint;
  setpoint.sample_index = sample_index;
  setpoint.input_code = input_code;
  send_frame(make_frame(sequence_++, setpoint));
  ++statistics_.setpoints_sent;
}

void LinkSession::send_identify_request() { send_frame(make_identify_request(sequence_++)); }

void LinkSession::send_command(Command command) {
  send_frame(make_frame(sequence_++, command));
  ++statistics_.commands_sent;
}

TelemetryPayload LinkSession::next_telemetry() {
  while (unread_telemetry_.empty()) receive_frames();
  return *take_telemetry();
}

IdentifyPayload LinkSession::identify() {
  // What waited in the device's buffer is older than the request: read first, then not counted.
  poll_frames();
  unread_identify_.clear();
  SentFrames sent;
  sent.add(sequence_);
  send_frame(make_identify_request(sequence_++));
  // The reply comes within a frame time after the telemetry frame on the line; allow a few, and
  // ask again every 4 frames (the request or the reply may be corrupted on the line). Frames the
  // board sent before it had the request (on their way, or held by a USB adapter's batching) are
  // not counted: telemetry names the last frame the board accepted.
  waiting_ = &sent;
  struct Unwait {
    SentFrames*& waiting;
    ~Unwait() { waiting = nullptr; }
  } unwait{waiting_};
  std::uint64_t resend_at = 4;
  for (int calls = 0; unread_identify_.empty(); ++calls) {
    if (sent.counted() > static_cast<std::uint64_t>(options_.command_timeout_frames) ||
        calls > 8 * options_.command_timeout_frames) {
      throw LinkError(LinkError::Kind::kLinkLost, stream_.name() + ": no identify reply from the board");
    }
    if (sent.frames() >= resend_at) {
      sent.add(sequence_);
      send_frame(make_identify_request(sequence_++));
      resend_at += 4;
    }
    receive_frames();
  }
  const IdentifyPayload identify = unread_identify_.front();
  unread_identify_.clear();
  if (identify.protocol_version != board::kProtocolVersion) {
    throw LinkError(LinkError::Kind::kProtocol, stream_.name() + ": the board speaks link protocol " +
                                                    std::to_string(identify.protocol_version) + ", this host " +
                                                    std::to_string(board::kProtocolVersion));
  }
  return identify;
}

TelemetryPayload LinkSession::command(Command command, const std::function<bool(const TelemetryPayload&)>& done) {
  // The baseline: the newest frame the board sent before this command (whatever waits in the
  // device's buffer read first: counting stale frames as answers would time the command out).
  poll_frames();
  while (!unread_telemetry_.empty()) next_telemetry();
  if (!last_telemetry_) next_telemetry();
  const TelemetryPayload before = *last_telemetry_;
  // A command frame corrupted on the line is dropped, not refused: without its effect after
  // kCommandResendFrames frames it is sent again (every command is idempotent once done() holds).
  // The refused counter also counts setpoints still in flight after a stream, so a refusal is
  // only concluded when the command never took effect.
  constexpr int kCommandResendFrames = 4;
  send_command(command);
  for (int frames = 1; frames <= options_.command_timeout_frames; ++frames) {
    const TelemetryPayload t = next_telemetry();
    if (done(t)) return t;
    if (frames % kCommandResendFrames == 0 && frames < options_.command_timeout_frames) send_command(command);
  }
  const TelemetryPayload& last = *last_telemetry_;
  if (last.rejected != before.rejected && command == Command::kEnable && !last.has(TelemetryFlag::kModel)) {
    throw LinkError(LinkError::Kind::kRefused,
                    stream_.name() + ": the board refused the enable: it has no model (load one: deltactl host load " +
                        "--port " + stream_.name() + " --weights W.json)");
  }
  if (last.rejected != before.rejected) {
    throw LinkError(LinkError::Kind::kRefused, stream_.name() + ": the board refused command " +
                                                   std::to_string(static_cast<int>(command)) + " (" +
                                                   describe_state(last) + ")");
  }
  throw LinkError(LinkError::Kind::kLinkLost,
                  stream_.name() + ": command " + std::to_string(static_cast<int>(command)) + " had no effect in " +
                      std::to_string(options_.command_timeout_frames) + " telemetry frames");
}

TelemetryPayload LinkSession::set_home() {
  return command(Command::kSetHome, [](const TelemetryPayload& t) { return t.has(TelemetryFlag::kHomed); });
}

TelemetryPayload LinkSession::enable() {
  const TelemetryPayload t = command(Command::kEnable, [this](const TelemetryPayload& frame) {
    if (frame.has(TelemetryFlag::kFault)) {
      throw LinkError(LinkError::Kind::kFault, stream_.name() + ": enable: " + describe_state(frame));
    }
    return drives_on(frame) && !frame.has(TelemetryFlag::kHolding);
  });
  return t;
}

TelemetryPayload LinkSession::hold() {
  return command(Command::kHold, [](const TelemetryPayload& t) { return t.has(TelemetryFlag::kHolding); });
}

TelemetryPayload LinkSession::disable() {
  return command(Command::kDisable, [](const TelemetryPayload& t) { return !drives_on(t); });
}

TelemetryPayload LinkSession::clear_fault() {
  try {
    return command(Command::kClearFault, [](const TelemetryPayload& t) { return !t.has(TelemetryFlag::kFault); });
  } catch (const LinkError& error) {
    if (error.kind() != LinkError::Kind::kRefused || !last_telemetry_) throw;
    const TelemetryPayload& t = *last_telemetry_;
    std::string why = "a cause persists";
    if (t.has(BoardFault::kEstopInput)) why = "the e-stop input is still open (close the e-stop chain first)";
    for (int j = 0; j < 3; ++j) {
      if (t.has(static_cast<BoardFault>(static_cast<int>(BoardFault::kDrive1) + j))) {
        why = "drive " + std::to_string(j + 1) + " may still report its fault (clear the drive first)";
      }
    }
    throw LinkError(LinkError::Kind::kRefused, stream_.name() + ": the board refused the clear-fault while " + why +
                                                   "; latched: " + describe_fault(t));
  }
}

TelemetryPayload LinkSession::estop() {
  return command(Command::kEstop, [](const TelemetryPayload& t) { return t.estop && !drives_on(t); });
}

ModelLoadReport LinkSession::load_model(const std::vector<ModelPayload>& frames) {
  // The baseline: the newest frame the board sent before the load (what waited in the device's
  // buffer read first).
  poll_frames();
  while (!unread_telemetry_.empty()) next_telemetry();
  if (!last_telemetry_) next_telemetry();
  const TelemetryPayload before = *last_telemetry_;
  ModelLoadReport report;
  report.telemetry = before;
  if (frames.empty()) {
    report.problem = "no frames to load";
    return report;
  }
  const std::size_t frame_bytes = encode_frame(make_frame(0, frames.front())).size();
  const std::size_t window = std::max<std::size_t>(1, kModelLoadWindowBytes / frame_bytes);
  // Each frame's sequence number, never the one the board showed last (a telemetry frame showing
  // it would look like an answer), so that the telemetry's `sequence` names the newest frame taken:
  // at most `window` (< 255) frames are on their way, all with distinct numbers.
  std::vector<std::uint8_t> sequences(frames.size());
  // The newest telemetry frame: at least one more, then whatever else is there. Frames that piled
  // up while the host wrote (a board faster than the host: the virtual board running free) are
  // stale: only the newest says how far the board got, and a count of stale ones is no stall.
  auto newest_telemetry = [this] {
    TelemetryPayload t = next_telemetry();
    poll_frames();
    while (std::optional<TelemetryPayload> more = take_telemetry()) t = *more;
    return t;
  };
  std::size_t sent = 0;
  std::size_t accepted = 0;  // frames the board accepted (taken or refused), in order
  int frames_without_progress = 0;
  // The frames the board has accepted per telemetry frame t: up to the newest on its way that t names.
  auto accepted_by = [&](const TelemetryPayload& t) {
    for (std::size_t i = sent; i > accepted; --i) {
      if (sequences[i - 1] == t.sequence) return i;
    }
    return accepted;
  };
  auto rejected_since = [&](const TelemetryPayload& t) {
    return static_cast<std::uint16_t>(t.rejected - before.rejected);
  };
  while (true) {
    while (sent < frames.size() && sent - accepted < window) {
      if (sequence_ == before.sequence) ++sequence_;
      sequences[sent] = sequence_;
      send_frame(make_frame(sequence_++, frames[sent]));
      ++sent;
    }
    const TelemetryPayload t = newest_telemetry();
    report.telemetry = t;
    const std::size_t newest = accepted_by(t);
    frames_without_progress = newest > accepted ? 0 : frames_without_progress + 1;
    accepted = newest;
    if (rejected_since(t) != 0) {
      // Refused: nothing more is sent. The frames still on their way are refused too; once the board
      // has taken them (or a few frames passed) the count says where the load stopped: every frame
      // after the first refused one is refused (out of order), so the first is accepted - refused.
      TelemetryPayload last = t;
      for (int waited = 0; waited < 4 || (accepted < sent && waited < options_.command_timeout_frames); ++waited) {
        last = newest_telemetry();
        accepted = accepted_by(last);
      }
      report.telemetry = last;
      const std::size_t refused = rejected_since(last);
      const std::size_t first = accepted > refused ? accepted - refused : 0;
      report.taken = first;
      report.sent = sent;
      report.refused_frame = frames[std::min(first, frames.size() - 1)].frame;
      const std::uint16_t lost = static_cast<std::uint16_t>(last.bad_frames - before.bad_frames);
      report.problem = "the board refused model frame " + std::to_string(*report.refused_frame) + " (" +
                       describe_state(last) +
                       (last.has(TelemetryFlag::kDriveEnable) ? "; a model is taken only with the drives off" : "") +
                       (lost != 0 ? "; frames lost on the line: " + std::to_string(lost) : "") + ")";
      return report;
    }
    if (accepted == frames.size()) break;
    if (frames_without_progress > options_.command_timeout_frames) {
      report.taken = accepted;
      report.sent = sent;
      report.problem = "the board took no model frame after frame " +
                       (accepted == 0 ? std::string("none") : std::to_string(frames[accepted - 1].frame)) + " in " +
                       std::to_string(options_.command_timeout_frames) + " telemetry frames (lost on the line?)";
      return report;
    }
  }
  // The commit taken: the next frame shows whether the board's own CRC checked.
  report.telemetry = newest_telemetry();
  report.taken = accepted;
  report.sent = sent;
  report.loaded = report.telemetry.has(TelemetryFlag::kModel);
  if (!report.loaded) {
    report.problem = "the board took all " + std::to_string(frames.size()) +
                     " model frames but shows no model (its CRC of the words it took is not the commit's)";
  }
  return report;
}

std::string describe_fault(const TelemetryPayload& t) {
  std::string out;
  auto add = [&out](const std::string& what) { out += (out.empty() ? "" : ", ") + what; };
  // The board's own causes first: they name what stopped it from outside the joints.
  if (t.estop) add("e-stop command");
  if (t.has(BoardFault::kEstopInput)) add("e-stop input open");
  for (int j = 0; j < 3; ++j) {
    if (t.has(static_cast<BoardFault>(static_cast<int>(BoardFault::kDrive1) + j))) {
      add("drive " + std::to_string(j + 1) + " fault");
    }
  }
  const std::uint8_t fault_cause = t.fault_cause;
  if (fault_cause & mask(FaultCause::kEncoderSkip)) add("encoder skipped a state");
  if (fault_cause & mask(FaultCause::kFollowing)) add("following error");
  static const std::string watchdog =
      "watchdog (no valid frame for " + std::to_string(board::kWatchdogPeriods * 1000 / board::kControlRateHz) + " ms)";
  if (fault_cause & mask(FaultCause::kWatchdog)) add(watchdog);
  if (fault_cause & mask(FaultCause::kTravel)) add("reference outside the travel");
  return out.empty() ? "none" : out;
}

std::string describe_state(const TelemetryPayload& t) {
  std::string out = t.has(TelemetryFlag::kDriveEnable) ? "drives on" : "drives off";
  if (t.has(TelemetryFlag::kReferenced)) {
    out += ", homed at the references";
  } else if (t.homing_ended_by_fault()) {
    out += ", not homed (provisional counts: a fault ends a homing)";
  } else if (t.has(TelemetryFlag::kHomed)) {
    out += ", homed by hand";
  } else {
    out += ", not homed";
  }
  if (!t.has(TelemetryFlag::kModel)) out += ", no model";
  if (t.has(TelemetryFlag::kHoming)) {
    // The board keeps its homing flag through a disable (between jogs, or a homing stopped by its
    // host): with the drives off, say how far it got.
    int referenced = 0;
    for (int j = 0; j < 3; ++j) referenced += t.referenced(j) ? 1 : 0;
    out += t.has(TelemetryFlag::kDriveEnable)
               ? ", homing"
               : ", homing unfinished (" + std::to_string(referenced) + " of 3 joints referenced)";
  }
  if (t.has(TelemetryFlag::kHolding)) out += ", holding";
  if (t.has(TelemetryFlag::kEncoderError)) out += ", encoder error seen";
  if (t.has(TelemetryFlag::kFault)) out += "; fault: " + describe_fault(t);
  return out;
}

}  // namespace delta::link
