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
                  board::kFlagFault < 8 && board::kFlagEncoderError < 8 && board::kFaultCauseBits <= 8,
              "telemetry flag and fault-cause bits are one byte each");

template <typename T>
void check_width(const layout::Field& field) {
  static_assert(std::is_integral_v<T>);
  if (sizeof(T) != field.element_bytes) throw std::logic_error("link payload: a field read with the wrong width");
}

// Element `index` of `field`, little-endian.
template <typename T>
void put(std::vector<std::uint8_t>& bytes, const layout::Field& field, T value, std::size_t index = 0) {
  check_width<T>(field);
  const auto word = static_cast<std::make_unsigned_t<T>>(value);
  const std::size_t at = field.offset + index * sizeof(T);
  for (std::size_t i = 0; i < sizeof(T); ++i) bytes[at + i] = static_cast<std::uint8_t>(word >> (8 * i));
}

template <typename T>
T get(const std::vector<std::uint8_t>& bytes, const layout::Field& field, std::size_t index = 0) {
  check_width<T>(field);
  std::make_unsigned_t<T> word = 0;
  const std::size_t at = field.offset + index * sizeof(T);
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    word = static_cast<std::make_unsigned_t<T>>(word | static_cast<std::make_unsigned_t<T>>(bytes[at + i]) << (8 * i));
  }
  return static_cast<T>(word);  // two's complement for the signed fields
}

template <typename T, std::size_t N>
void put_all(std::vector<std::uint8_t>& bytes, const layout::Field& field, const std::array<T, N>& values) {
  for (std::size_t i = 0; i < N; ++i) put(bytes, field, values[i], i);
}

template <typename T, std::size_t N>
void get_all(const std::vector<std::uint8_t>& bytes, const layout::Field& field, std::array<T, N>& values) {
  for (std::size_t i = 0; i < N; ++i) values[i] = get<T>(bytes, field, i);
}

void check_size(const char* what, const std::vector<std::uint8_t>& payload, long long expected) {
  if (payload.size() != static_cast<std::size_t>(expected)) {
    throw std::invalid_argument(std::string(what) + " payload of " + std::to_string(payload.size()) +
                                " bytes: the link v2 " + what + " payload has " + std::to_string(expected));
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
  put(bytes, layout::kSetpointIndex, payload.sample_index);
  put_all(bytes, layout::kSetpointPosition, payload.position_code);
  return bytes;
}

std::vector<std::uint8_t> encode(Command command) {
  std::vector<std::uint8_t> bytes(board::kCommandPayloadBytes);
  put(bytes, layout::kCommandByte, static_cast<std::uint8_t>(command));
  return bytes;
}

std::vector<std::uint8_t> encode(const IdentifyPayload& payload) {
  std::vector<std::uint8_t> bytes(board::kIdentifyPayloadBytes);
  put(bytes, layout::kIdentifyProtocol, payload.protocol_version);
  put(bytes, layout::kIdentifyDepth, payload.setpoint_depth);
  put(bytes, layout::kIdentifyBuildId, payload.build_id);
  put(bytes, layout::kIdentifyWeightsCrc, payload.weights_crc);
  put(bytes, layout::kIdentifyNetworkClock, payload.network_clock_hz);
  put(bytes, layout::kIdentifyBoardClock, payload.board_clock_hz);
  put(bytes, layout::kIdentifyControlRate, payload.control_rate_hz);
  put(bytes, layout::kIdentifySetpointRate, payload.setpoint_rate_hz);
  return bytes;
}

std::vector<std::uint8_t> encode(const TelemetryPayload& payload) {
  std::vector<std::uint8_t> bytes(board::kTelemetryPayloadBytes);
  put(bytes, layout::kTelemetrySampleIndex, payload.sample_index);
  put(bytes, layout::kTelemetryTick, payload.tick);
  put_all(bytes, layout::kTelemetryCounts, payload.counts);
  put_all(bytes, layout::kTelemetryReferences, payload.references);
  put_all(bytes, layout::kTelemetryCurrents, payload.currents);
  put(bytes, layout::kTelemetryFault, payload.fault_cause);
  put(bytes, layout::kTelemetryFlags, payload.flags);
  put(bytes, layout::kTelemetryFill, payload.fill);
  put(bytes, layout::kTelemetryBadFrames, payload.bad_frames);
  put(bytes, layout::kTelemetryUnderruns, payload.underruns);
  put(bytes, layout::kTelemetrySaturations, payload.saturations);
  put(bytes, layout::kTelemetrySequence, payload.sequence);
  put(bytes, layout::kTelemetryRejected, payload.rejected);
  return bytes;
}

SetpointPayload decode_setpoint(const std::vector<std::uint8_t>& payload) {
  check_size("setpoint", payload, board::kSetpointPayloadBytes);
  SetpointPayload setpoint;
  setpoint.sample_index = get<std::uint32_t>(payload, layout::kSetpointIndex);
  get_all(payload, layout::kSetpointPosition, setpoint.position_code);
  return setpoint;
}

std::optional<Command> decode_command(const std::vector<std::uint8_t>& payload) {
  check_size("command", payload, board::kCommandPayloadBytes);
  const auto byte = get<std::uint8_t>(payload, layout::kCommandByte);
  switch (byte) {
    case board::kCommandEnable:
    case board::kCommandDisable:
    case board::kCommandHold:
    case board::kCommandClearFault:
    case board::kCommandSetHome:
      return static_cast<Command>(byte);
    default:
      return std::nullopt;
  }
}

IdentifyPayload decode_identify(const std::vector<std::uint8_t>& payload) {
  check_size("identify", payload, board::kIdentifyPayloadBytes);
  IdentifyPayload identify;
  identify.protocol_version = get<std::uint16_t>(payload, layout::kIdentifyProtocol);
  identify.setpoint_depth = get<std::uint16_t>(payload, layout::kIdentifyDepth);
  identify.build_id = get<std::uint32_t>(payload, layout::kIdentifyBuildId);
  identify.weights_crc = get<std::uint32_t>(payload, layout::kIdentifyWeightsCrc);
  identify.network_clock_hz = get<std::uint32_t>(payload, layout::kIdentifyNetworkClock);
  identify.board_clock_hz = get<std::uint32_t>(payload, layout::kIdentifyBoardClock);
  identify.control_rate_hz = get<std::uint16_t>(payload, layout::kIdentifyControlRate);
  identify.setpoint_rate_hz = get<std::uint16_t>(payload, layout::kIdentifySetpointRate);
  return identify;
}

TelemetryPayload decode_telemetry(const std::vector<std::uint8_t>& payload) {
  check_size("telemetry", payload, board::kTelemetryPayloadBytes);
  TelemetryPayload telemetry;
  telemetry.sample_index = get<std::uint32_t>(payload, layout::kTelemetrySampleIndex);
  telemetry.tick = get<std::uint32_t>(payload, layout::kTelemetryTick);
  get_all(payload, layout::kTelemetryCounts, telemetry.counts);
  get_all(payload, layout::kTelemetryReferences, telemetry.references);
  get_all(payload, layout::kTelemetryCurrents, telemetry.currents);
  telemetry.fault_cause = get<std::uint8_t>(payload, layout::kTelemetryFault);
  telemetry.flags = get<std::uint8_t>(payload, layout::kTelemetryFlags);
  telemetry.fill = get<std::uint16_t>(payload, layout::kTelemetryFill);
  telemetry.bad_frames = get<std::uint16_t>(payload, layout::kTelemetryBadFrames);
  telemetry.underruns = get<std::uint16_t>(payload, layout::kTelemetryUnderruns);
  telemetry.saturations = get<std::uint16_t>(payload, layout::kTelemetrySaturations);
  telemetry.sequence = get<std::uint8_t>(payload, layout::kTelemetrySequence);
  telemetry.rejected = get<std::uint8_t>(payload, layout::kTelemetryRejected);
  return telemetry;
}

Frame make_frame(std::uint8_t sequence, const SetpointPayload& payload) {
  return frame_of(sequence, FrameType::kSetpoint, encode(payload));
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
