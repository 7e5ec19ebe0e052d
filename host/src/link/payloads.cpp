// The payloads of the board link v2 (see payloads.hpp): little-endian fields at the package's offsets.
#include "delta/link/payloads.hpp"

#include <limits>
#include <stdexcept>
#include <type_traits>

namespace delta::link {
namespace {

template <typename Field, typename Fact>
constexpr bool fits(Fact value) {
  return value >= static_cast<Fact>(std::numeric_limits<Field>::min()) &&
         value <= static_cast<Fact>(std::numeric_limits<Field>::max());
}
static_assert(fits<std::uint16_t>(board::kProtocolVersion) && fits<std::uint16_t>(board::kSetpointDepth) &&
                  fits<std::uint32_t>(board::kNetworkClockHz) && fits<std::uint32_t>(board::kBoardClockHz) &&
                  fits<std::uint16_t>(board::kControlRateHz) && fits<std::uint16_t>(board::kSetpointRateHz),
              "a board fact does not fit its identify field");
static_assert(board::kFlagDriveEnable < 8 && board::kFlagHomed < 8 && board::kFlagHolding < 8 &&
                  board::kFlagFault < 8 && board::kFlagEncoderError < 8 && board::kFlagReferenced < 8 &&
                  board::kFlagHoming < 8 && board::kFlagModel < 8 && board::kFaultCauseBits <= 8,
              "telemetry flag and fault-cause bits are one byte each");

template <typename T>
void check_width(const layout::Field& field) {
  static_assert(std::is_integral_v<T>);
  if (field.element_bytes == 0 || field.element_bytes > sizeof(T)) {
    throw std::logic_error("link payload: a field wider than its C++ type");
  }
}

// Element `index` of `field`, little-endian, in field.element_bytes bytes (two's complement).
template <typename T>
void write(std::vector<std::uint8_t>& bytes, const layout::Field& field, T value, std::size_t index = 0) {
  check_width<T>(field);
  const int bits = static_cast<int>(8 * field.element_bytes);
  if (field.element_bytes < sizeof(T)) {  // a narrower wire field: the value must fit it
    const auto wide = static_cast<long long>(value);
    const long long low = std::is_signed_v<T> ? -(1LL << (bits - 1)) : 0;
    const long long high = std::is_signed_v<T> ? (1LL << (bits - 1)) - 1 : (1LL << bits) - 1;
    if (wide < low || wide > high) {
      throw std::invalid_argument("link payload: " + std::to_string(wide) + " does not fit a " + std::to_string(bits) +
                                  "-bit field at byte " + std::to_string(field.offset));
    }
  }
  const auto word = static_cast<std::make_unsigned_t<T>>(value);
  const std::size_t at = field.offset + index * field.element_bytes;
  for (std::size_t i = 0; i < field.element_bytes; ++i) bytes[at + i] = static_cast<std::uint8_t>(word >> (8 * i));
}

template <typename T>
void read(const std::vector<std::uint8_t>& bytes, const layout::Field& field, T& value, std::size_t index = 0) {
  check_width<T>(field);
  using Word = std::make_unsigned_t<T>;
  Word word = 0;
  const std::size_t at = field.offset + index * field.element_bytes;
  for (std::size_t i = 0; i < field.element_bytes; ++i) {
    word = static_cast<Word>(word | static_cast<Word>(bytes[at + i]) << (8 * i));
  }
  const std::size_t bits = 8 * field.element_bytes;
  if (std::is_signed_v<T> && bits < 8 * sizeof(T) && ((word >> (bits - 1)) & 1u)) {
    word = static_cast<Word>(word | static_cast<Word>(~std::uint64_t{0} << bits));  // sign extension
  }
  value = static_cast<T>(word);  // two's complement for the signed fields
}

template <typename T, std::size_t N>
void write(std::vector<std::uint8_t>& bytes, const layout::Field& field, const std::array<T, N>& values) {
  if (field.count != N) throw std::logic_error("link payload: an array field of the wrong length");
  for (std::size_t i = 0; i < N; ++i) write(bytes, field, values[i], i);
}

template <typename T, std::size_t N>
void read(const std::vector<std::uint8_t>& bytes, const layout::Field& field, std::array<T, N>& values) {
  if (field.count != N) throw std::logic_error("link payload: an array field of the wrong length");
  for (std::size_t i = 0; i < N; ++i) read(bytes, field, values[i], i);
}

// Each payload's members paired with their layout fields, once for encode and decode alike:
// visit(field, member) for every member (Payload may be const).
template <typename Payload, typename Visit>
void visit_setpoint(Payload& p, Visit&& visit) {
  visit(layout::kSetpointIndex, p.sample_index);
  visit(layout::kSetpointInput, p.input_code);
}

template <typename Payload, typename Visit>
void visit_model(Payload& p, Visit&& visit) {
  visit(layout::kModelFrame, p.frame);
  visit(layout::kModelWord, p.word);
}

template <typename Payload, typename Visit>
void visit_identify(Payload& p, Visit&& visit) {
  visit(layout::kIdentifyProtocol, p.protocol_version);
  visit(layout::kIdentifyDepth, p.setpoint_depth);
  visit(layout::kIdentifyBuildId, p.build_id);
  visit(layout::kIdentifyWeightsCrc, p.weights_crc);
  visit(layout::kIdentifyNetworkClock, p.network_clock_hz);
  visit(layout::kIdentifyBoardClock, p.board_clock_hz);
  visit(layout::kIdentifyControlRate, p.control_rate_hz);
  visit(layout::kIdentifySetpointRate, p.setpoint_rate_hz);
}

template <typename Payload, typename Visit>
void visit_telemetry(Payload& p, Visit&& visit) {
  visit(layout::kTelemetrySampleIndex, p.sample_index);
  visit(layout::kTelemetryTick, p.tick);
  visit(layout::kTelemetryCounts, p.counts);
  visit(layout::kTelemetryReferences, p.references);
  visit(layout::kTelemetryCurrents, p.currents);
  visit(layout::kTelemetryFault, p.fault_cause);
  visit(layout::kTelemetryFlags, p.flags);
  visit(layout::kTelemetryFill, p.fill);
  visit(layout::kTelemetryBadFrames, p.bad_frames);
  visit(layout::kTelemetryUnderruns, p.underruns);
  visit(layout::kTelemetrySaturations, p.saturations);
  visit(layout::kTelemetrySlewLimits, p.slew_limits);
  visit(layout::kTelemetrySequence, p.sequence);
  visit(layout::kTelemetryRejected, p.rejected);
  visit(layout::kTelemetryHome, p.home);
}

void check_size(const char* what, const std::vector<std::uint8_t>& payload, long long expected) {
  if (payload.size() != static_cast<std::size_t>(expected)) {
    throw std::invalid_argument(std::string(what) + " payload of " + std::to_string(payload.size()) +
                                " bytes: the link v3 " + what + " payload has " + std::to_string(expected));
  }
}

Frame frame_of(std::uint8_t sequence, FrameType type, std::vector<std::uint8_t> payload) {
  Frame frame;
  frame.sequence = sequence;
  frame.type = type;
  frame.payload = std::move(payload);
  return frame;
}

}  // namespace

IdentifyPayload board_identify(std::uint32_t build_id, std::uint32_t weights_crc) {
  IdentifyPayload identify;
  identify.protocol_version = board::kProtocolVersion;
  identify.setpoint_depth = board::kSetpointDepth;
  identify.build_id = build_id;
  identify.weights_crc = weights_crc;
  identify.network_clock_hz = board::kNetworkClockHz;
  identify.board_clock_hz = board::kBoardClockHz;
  identify.control_rate_hz = board::kControlRateHz;
  identify.setpoint_rate_hz = board::kSetpointRateHz;
  return identify;
}

std::vector<std::uint8_t> encode(const SetpointPayload& payload) {
  std::vector<std::uint8_t> bytes(board::kSetpointPayloadBytes);
  visit_setpoint(payload, [&bytes](const layout::Field& field, const auto& value) { write(bytes, field, value); });
  return bytes;
}

std::vector<std::uint8_t> encode(const ModelPayload& payload) {
  std::vector<std::uint8_t> bytes(board::kModelPayloadBytes);
  visit_model(payload, [&bytes](const layout::Field& field, const auto& value) { write(bytes, field, value); });
  return bytes;
}

std::vector<std::uint8_t> encode(Command command) {
  std::vector<std::uint8_t> bytes(board::kCommandPayloadBytes);
  write(bytes, layout::kCommandByte, static_cast<std::uint8_t>(command));
  return bytes;
}

std::vector<std::uint8_t> encode(const IdentifyPayload& payload) {
  std::vector<std::uint8_t> bytes(board::kIdentifyPayloadBytes);
  visit_identify(payload, [&bytes](const layout::Field& field, const auto& value) { write(bytes, field, value); });
  return bytes;
}

// The fault byte carries the fault causes (low bits), the play sides (TelemetryPlaySideShift..) and
// the e-stop latch (TelemetryEstopBit); the rejected counter's word the count (StatusCounterBits) and
// the board causes above it (BoardFaultShift..).
constexpr int kFaultCauseMask = (1 << board::kFaultCauseBits) - 1;
constexpr int kRejectedMask = (1 << board::kStatusCounterBits) - 1;
constexpr int kBoardFaultMask = (1 << board::kBoardFaultBits) - 1;
static_assert(board::kBoardFaultShift == board::kStatusCounterBits &&
                  board::kBoardFaultShift + board::kBoardFaultBits == 16 &&
                  board::kTelemetryBoardFaultOffset == board::kTelemetryRejectedOffset,
              "the board causes are the rejected counter's word's bits above its count");

std::vector<std::uint8_t> encode(const TelemetryPayload& payload) {
  std::vector<std::uint8_t> bytes(board::kTelemetryPayloadBytes);
  TelemetryPayload packed = payload;
  packed.fault_cause = static_cast<std::uint8_t>((payload.fault_cause & kFaultCauseMask) |
                                                 ((payload.rising & 7) << board::kTelemetryPlaySideShift) |
                                                 ((payload.estop ? 1 : 0) << board::kTelemetryEstopBit));
  packed.rejected = static_cast<std::uint16_t>((payload.rejected & kRejectedMask) |
                                               ((payload.board_fault & kBoardFaultMask) << board::kBoardFaultShift));
  visit_telemetry(packed, [&bytes](const layout::Field& field, const auto& value) { write(bytes, field, value); });
  return bytes;
}

SetpointPayload decode_setpoint(const std::vector<std::uint8_t>& payload) {
  check_size("setpoint", payload, board::kSetpointPayloadBytes);
  SetpointPayload setpoint;
  visit_setpoint(setpoint, [&payload](const layout::Field& field, auto& value) { read(payload, field, value); });
  return setpoint;
}

ModelPayload decode_model(const std::vector<std::uint8_t>& payload) {
  check_size("model", payload, board::kModelPayloadBytes);
  ModelPayload model;
  visit_model(model, [&payload](const layout::Field& field, auto& value) { read(payload, field, value); });
  return model;
}

std::optional<Command> decode_command(const std::vector<std::uint8_t>& payload) {
  check_size("command", payload, board::kCommandPayloadBytes);
  std::uint8_t byte = 0;
  read(payload, layout::kCommandByte, byte);
  switch (byte) {
    case board::kCommandEnable:
    case board::kCommandDisable:
    case board::kCommandHold:
    case board::kCommandClearFault:
    case board::kCommandSetHome:
    case board::kCommandHomeStart:
    case board::kCommandEstop:
      return static_cast<Command>(byte);
    default:
      if (byte >= board::kCommandJogBase && byte < board::kCommandJogBase + 6) return static_cast<Command>(byte);
      return std::nullopt;
  }
}

IdentifyPayload decode_identify(const std::vector<std::uint8_t>& payload) {
  check_size("identify", payload, board::kIdentifyPayloadBytes);
  IdentifyPayload identify;
  visit_identify(identify, [&payload](const layout::Field& field, auto& value) { read(payload, field, value); });
  return identify;
}

TelemetryPayload decode_telemetry(const std::vector<std::uint8_t>& payload) {
  check_size("telemetry", payload, board::kTelemetryPayloadBytes);
  TelemetryPayload telemetry;
  visit_telemetry(telemetry, [&payload](const layout::Field& field, auto& value) { read(payload, field, value); });
  telemetry.rising = static_cast<std::uint8_t>((telemetry.fault_cause >> board::kTelemetryPlaySideShift) & 7);
  telemetry.estop = ((telemetry.fault_cause >> board::kTelemetryEstopBit) & 1) != 0;
  telemetry.fault_cause = static_cast<std::uint8_t>(telemetry.fault_cause & kFaultCauseMask);
  telemetry.board_fault = static_cast<std::uint8_t>((telemetry.rejected >> board::kBoardFaultShift) & kBoardFaultMask);
  telemetry.rejected = static_cast<std::uint16_t>(telemetry.rejected & kRejectedMask);
  return telemetry;
}

Frame make_frame(std::uint8_t sequence, const SetpointPayload& payload) {
  return frame_of(sequence, FrameType::kSetpoint, encode(payload));
}
Frame make_frame(std::uint8_t sequence, const ModelPayload& payload) {
  return frame_of(sequence, FrameType::kModel, encode(payload));
}
Frame make_frame(std::uint8_t sequence, Command command) {
  return frame_of(sequence, FrameType::kCommand, encode(command));
}
Frame make_frame(std::uint8_t sequence, const IdentifyPayload& payload) {
  return frame_of(sequence, FrameType::kIdentify, encode(payload));
}
Frame make_frame(std::uint8_t sequence, const TelemetryPayload& payload) {
  return frame_of(sequence, FrameType::kTelemetry, encode(payload));
}
Frame make_identify_request(std::uint8_t sequence) { return frame_of(sequence, FrameType::kIdentifyRequest, {}); }

}  // namespace delta::link
