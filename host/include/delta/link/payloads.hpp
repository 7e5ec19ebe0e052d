// The payloads of the board link v3 (docs/board_link.md, "Payloads"): setpoint, command, model,
// identify, telemetry, as value structs with encode and decode. Little-endian; every offset comes from
// rtl/board/delta_board_pkg.sv through delta/board_facts.hpp, every field width from the struct's
// C++ type, and static_asserts below check that the fields tile each payload exactly (no gap, no
// overlap, the package's payload size), so the package cannot drift from this codec.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/link/frame_codec.hpp"

namespace delta::link {

// Setpoint (host -> board): the sample index and the three scaled network input codes u_j =
// sat_16(round_shift(x_j - centre_j, shift_j)) (Q1.15, hls/README.md step 2): the host scales the
// position with its model (golden::scale_input), the board's network starts from u.
struct SetpointPayload {
  std::uint32_t sample_index = 0;
  std::array<std::int16_t, 3> input_code{};
};

// One word of the model (host -> board, docs/board_link.md "The model"): frame number n
// (0 .. board::kModelFrames - 1) and its 48-bit word, three 16-bit lanes, low first.
struct ModelPayload {
  std::uint16_t frame = 0;
  std::array<std::uint16_t, 3> word{};
  std::uint64_t value() const {
    return std::uint64_t{word[0]} | std::uint64_t{word[1]} << 16 | std::uint64_t{word[2]} << 32;
  }
  static ModelPayload of(std::uint16_t frame, std::uint64_t value) {
    return ModelPayload{frame,
                        {static_cast<std::uint16_t>(value), static_cast<std::uint16_t>(value >> 16),
                         static_cast<std::uint16_t>(value >> 32)}};
  }
};

// Command byte (host -> board).
enum class Command : std::uint8_t {
  kEnable = board::kCommandEnable,
  kDisable = board::kCommandDisable,
  kHold = board::kCommandHold,
  kClearFault = board::kCommandClearFault,
  kSetHome = board::kCommandSetHome,      // the joints not referenced: count := home count
  kHomeStart = board::kCommandHomeStart,  // forget the references, start homing (docs/homing.md)
  kEstop = board::kCommandEstop,          // drives off, the e-stop latched (any state) until a clear-fault
};

// The bench jog's command byte (CommandJogBase + 2 j + n): joint j (0-2) alone at the open-loop
// current +JogCurrentCode (negative: -JogCurrentCode) for JogPeriods control periods.
constexpr std::uint8_t jog_command_byte(int joint, bool negative) {
  return static_cast<std::uint8_t>(board::kCommandJogBase + 2 * joint + (negative ? 1 : 0));
}

// Identify (board -> host), the answer to an identify request.
struct IdentifyPayload {
  std::uint16_t protocol_version = 0;  // board::kProtocolVersion
  std::uint16_t setpoint_depth = 0;    // board::kSetpointDepth, entries
  std::uint32_t build_id = 0;          // gateware build id: first 32 bits of SHA-256 of rtl/**/*.sv
  std::uint32_t weights_crc = 0;       // CRC-32 of the loaded model (delta::weights_crc), 0 with none
  std::uint32_t network_clock_hz = 0;
  std::uint32_t board_clock_hz = 0;
  std::uint16_t control_rate_hz = 0;
  std::uint16_t setpoint_rate_hz = 0;
};

// The identify payload of a board built from this checkout's package: every field a board fact
// except the two given.
IdentifyPayload board_identify(std::uint32_t build_id, std::uint32_t weights_crc);

// Bits of TelemetryPayload::flags.
enum class TelemetryFlag : std::uint8_t {
  kDriveEnable = board::kFlagDriveEnable,
  kHomed = board::kFlagHomed,
  kHolding = board::kFlagHolding,
  kFault = board::kFlagFault,  // a fault cause is latched
  kEncoderError = board::kFlagEncoderError,
  kReferenced = board::kFlagReferenced,  // every joint homed against its reference
  kHoming = board::kFlagHoming,
  kModel = board::kFlagModel,  // a complete model whose CRC-32 checked is loaded
};

// Bits of TelemetryPayload::fault_cause.
enum class FaultCause : std::uint8_t {
  kEncoderSkip = board::kFaultEncoderSkip,
  kFollowing = board::kFaultFollowing,
  kWatchdog = board::kFaultWatchdog,
  kTravel = board::kFaultTravel,
};

// Bits of TelemetryPayload::board_fault: the board's safety inputs' latched causes.
enum class BoardFault : std::uint8_t {
  kEstopInput = board::kBoardFaultEstopInput,  // the e-stop chain opened
  kDrive1 = board::kBoardFaultDrive,           // drive j's fault line: kDrive1 + j
  kDrive2 = board::kBoardFaultDrive + 1,
  kDrive3 = board::kBoardFaultDrive + 2,
};

constexpr std::uint8_t mask(TelemetryFlag flag) { return static_cast<std::uint8_t>(1u << static_cast<int>(flag)); }
constexpr std::uint8_t mask(FaultCause cause) { return static_cast<std::uint8_t>(1u << static_cast<int>(cause)); }

// Control periods of board time in seconds.
constexpr double ticks_s(std::int64_t ticks) {
  return static_cast<double>(ticks) / static_cast<double>(board::kControlRateHz);
}

// Telemetry (board -> host, one frame per setpoint period).
struct TelemetryPayload {
  std::uint32_t sample_index = 0;            // the next setpoint to play
  std::uint32_t tick = 0;                    // control periods since reset
  std::array<std::int16_t, 3> counts{};      // encoder counts, 0.01 deg
  std::array<std::int32_t, 3> references{};  // joint references, Q24.8 encoder counts (converted, interpolated answers)
  std::array<std::int16_t, 3> currents{};    // current commands, Q1.15 A
  std::uint8_t fault_cause = 0;              // FaultCause bits (the fault byte's low bits): the joints' causes
  bool estop = false;                        // an e-stop command latched (the fault byte's TelemetryEstopBit)
  std::uint8_t rising = 0;                   // bit j: joint j's count last stepped up (the fault byte's play sides)
  std::uint8_t flags = 0;                    // TelemetryFlag bits
  std::uint16_t fill = 0;                    // setpoints waiting in the buffer
  std::uint16_t bad_frames = 0;              // saturating
  std::uint16_t underruns = 0;               // saturating
  std::uint16_t saturations = 0;             // controller saturations, saturating
  std::uint16_t slew_limits = 0;             // segments whose reference change was saturated, saturating
  std::uint8_t sequence = 0;                 // of the last accepted frame
  std::uint16_t rejected = 0;                // refused commands and setpoints, saturating (12 bits)
  std::uint8_t board_fault = 0;              // BoardFault bits latched (bits 12-15 of the rejected counter's word)
  std::uint8_t home = 0;  // bit j: joint j's home switch closed; bit 3 + j: joint j referenced; bit 6: a bench jog runs

  bool home_switch(int joint) const { return ((home >> joint) & 1) != 0; }
  bool referenced(int joint) const { return ((home >> (3 + joint)) & 1) != 0; }
  // In units: board time [s], a joint's count [deg], its reference [counts, deg].
  double time_s() const { return ticks_s(tick); }
  double count_deg(int joint) const { return counts[static_cast<std::size_t>(joint)] * board::kEncoderCountDeg; }
  double reference_counts(int joint) const { return references[static_cast<std::size_t>(joint)] / 256.0; }
  double reference_deg(int joint) const { return reference_counts(joint) * board::kEncoderCountDeg; }
  // The count less its reference [deg] (the joint's following error as the board sees it).
  double following_error_deg(int joint) const {
    return (counts[static_cast<std::size_t>(joint)] - reference_counts(joint)) * board::kEncoderCountDeg;
  }
  bool jogging() const { return ((home >> board::kTelemetryJogBit) & 1) != 0; }
  // Where joint j's play was last taken up: +1 above (its count last stepped up), -1 below.
  int play_side(int joint) const { return ((rising >> joint) & 1) != 0 ? 1 : -1; }

  bool has(TelemetryFlag flag) const { return (flags & mask(flag)) != 0; }
  bool has(FaultCause cause) const { return (fault_cause & mask(cause)) != 0; }
  bool has(BoardFault cause) const { return ((board_fault >> static_cast<int>(cause)) & 1) != 0; }
  // A cause latched by the board itself (an e-stop command, a safety input), not by a joint.
  bool board_cause() const { return estop || board_fault != 0; }
  // Counts homed but not at the references, no homing under way: set by hand (a set-home), or a
  // homing that a fault ended (the board forgets it was homing on a fault and keeps the homed flag
  // of the set-home at each jog). With a fault latched the two look alike: neither is a reference.
  bool homed_unreferenced() const {
    return has(TelemetryFlag::kHomed) && !has(TelemetryFlag::kReferenced) && !has(TelemetryFlag::kHoming);
  }
  bool homing_ended_by_fault() const { return has(TelemetryFlag::kFault) && homed_unreferenced(); }
  void set(TelemetryFlag flag, bool on) {
    flags = static_cast<std::uint8_t>(on ? flags | mask(flag) : flags & ~mask(flag));
  }
  void set(FaultCause cause, bool on) {
    fault_cause = static_cast<std::uint8_t>(on ? fault_cause | mask(cause) : fault_cause & ~mask(cause));
  }
};

// Encoding: exactly the type's payload size (board::k*PayloadBytes). A value that does not fit a
// field narrower than its C++ type throws std::invalid_argument (no field is narrower today).
std::vector<std::uint8_t> encode(const SetpointPayload& payload);
std::vector<std::uint8_t> encode(const ModelPayload& payload);
std::vector<std::uint8_t> encode(Command command);
std::vector<std::uint8_t> encode(const IdentifyPayload& payload);
std::vector<std::uint8_t> encode(const TelemetryPayload& payload);

// Decoding: each throws std::invalid_argument naming the payload and both sizes when `payload`
// is not the type's size. decode_command returns nothing for a byte that is no Command (the board
// refuses it and counts it in `rejected`); a bench jog's byte (jog_command_byte) comes back as it is.
SetpointPayload decode_setpoint(const std::vector<std::uint8_t>& payload);
ModelPayload decode_model(const std::vector<std::uint8_t>& payload);
std::optional<Command> decode_command(const std::vector<std::uint8_t>& payload);
IdentifyPayload decode_identify(const std::vector<std::uint8_t>& payload);
TelemetryPayload decode_telemetry(const std::vector<std::uint8_t>& payload);

// Whole frames of a payload, ready for encode_frame.
Frame make_frame(std::uint8_t sequence, const SetpointPayload& payload);
Frame make_frame(std::uint8_t sequence, const ModelPayload& payload);
Frame make_frame(std::uint8_t sequence, Command command);
Frame make_frame(std::uint8_t sequence, const IdentifyPayload& payload);
Frame make_frame(std::uint8_t sequence, const TelemetryPayload& payload);
Frame make_identify_request(std::uint8_t sequence);

// ---- layout: the one table the codec reads and writes by, checked against the package ----
namespace layout {

struct Field {
  std::size_t offset;         // from the package
  std::size_t element_bytes;  // on the wire: sizeof the C++ element type, or fewer (a narrower integer)
  std::size_t count;          // elements (3 for the per-joint arrays)
  constexpr std::size_t end() const { return offset + element_bytes * count; }
};

template <typename Element>
constexpr Field field(long long offset, std::size_t count = 1, long long element_bytes = sizeof(Element)) {
  return Field{static_cast<std::size_t>(offset), static_cast<std::size_t>(element_bytes), count};
}

constexpr Field kSetpointIndex = field<std::uint32_t>(board::kSetpointIndexOffset);
constexpr Field kSetpointInput = field<std::int16_t>(board::kSetpointInputOffset, 3);
constexpr Field kSetpoint[] = {kSetpointIndex, kSetpointInput};

constexpr Field kModelFrame = field<std::uint16_t>(board::kModelFrameOffset);
constexpr Field kModelWord = field<std::uint16_t>(board::kModelWordOffset, 3);
constexpr Field kModel[] = {kModelFrame, kModelWord};

constexpr Field kCommandByte = field<std::uint8_t>(0);
constexpr Field kCommand[] = {kCommandByte};

constexpr Field kIdentifyProtocol = field<std::uint16_t>(board::kIdentifyProtocolOffset);
constexpr Field kIdentifyDepth = field<std::uint16_t>(board::kIdentifyDepthOffset);
constexpr Field kIdentifyBuildId = field<std::uint32_t>(board::kIdentifyBuildIdOffset);
constexpr Field kIdentifyWeightsCrc = field<std::uint32_t>(board::kIdentifyWeightsCrcOffset);
constexpr Field kIdentifyNetworkClock = field<std::uint32_t>(board::kIdentifyNetworkClockOffset);
constexpr Field kIdentifyBoardClock = field<std::uint32_t>(board::kIdentifyBoardClockOffset);
constexpr Field kIdentifyControlRate = field<std::uint16_t>(board::kIdentifyControlRateOffset);
constexpr Field kIdentifySetpointRate = field<std::uint16_t>(board::kIdentifySetpointRateOffset);
constexpr Field kIdentify[] = {kIdentifyProtocol,     kIdentifyDepth,      kIdentifyBuildId,     kIdentifyWeightsCrc,
                               kIdentifyNetworkClock, kIdentifyBoardClock, kIdentifyControlRate, kIdentifySetpointRate};

constexpr Field kTelemetrySampleIndex = field<std::uint32_t>(board::kTelemetrySampleIndexOffset);
constexpr Field kTelemetryTick = field<std::uint32_t>(board::kTelemetryTickOffset);
constexpr Field kTelemetryCounts = field<std::int16_t>(board::kTelemetryCountsOffset, 3);
constexpr Field kTelemetryReferences = field<std::int32_t>(board::kTelemetryReferencesOffset, 3);
constexpr Field kTelemetryCurrents = field<std::int16_t>(board::kTelemetryCurrentsOffset, 3);
constexpr Field kTelemetryFault = field<std::uint8_t>(board::kTelemetryFaultOffset);
constexpr Field kTelemetryFlags = field<std::uint8_t>(board::kTelemetryFlagsOffset);
constexpr Field kTelemetryFill = field<std::uint16_t>(board::kTelemetryFillOffset);
constexpr Field kTelemetryBadFrames = field<std::uint16_t>(board::kTelemetryBadFramesOffset);
constexpr Field kTelemetryUnderruns = field<std::uint16_t>(board::kTelemetryUnderrunsOffset);
constexpr Field kTelemetrySaturations = field<std::uint16_t>(board::kTelemetrySaturationsOffset);
constexpr Field kTelemetrySlewLimits = field<std::uint16_t>(board::kTelemetrySlewLimitsOffset);
constexpr Field kTelemetrySequence = field<std::uint8_t>(board::kTelemetrySequenceOffset);
constexpr Field kTelemetryRejected = field<std::uint16_t>(board::kTelemetryRejectedOffset);
constexpr Field kTelemetryHome = field<std::uint8_t>(board::kTelemetryHomeOffset);
constexpr Field kTelemetry[] = {kTelemetrySampleIndex, kTelemetryTick,      kTelemetryReferences,  kTelemetryCounts,
                                kTelemetryCurrents,    kTelemetryFault,     kTelemetryFlags,       kTelemetryFill,
                                kTelemetryBadFrames,   kTelemetryUnderruns, kTelemetrySaturations, kTelemetrySlewLimits,
                                kTelemetryRejected,    kTelemetrySequence,  kTelemetryHome};

// True when the fields, in the order listed, start at 0, each begins where the previous ends, and
// the last ends at `payload_bytes`: an exact tiling.
template <std::size_t N>
constexpr bool tiles(const Field (&fields)[N], long long payload_bytes) {
  std::size_t at = 0;
  for (std::size_t i = 0; i < N; ++i) {
    if (fields[i].offset != at) return false;
    at = fields[i].end();
  }
  return static_cast<long long>(at) == payload_bytes;
}

static_assert(tiles(kSetpoint, board::kSetpointPayloadBytes), "setpoint payload: package offsets and fields differ");
static_assert(tiles(kCommand, board::kCommandPayloadBytes), "command payload: package and codec differ");
static_assert(tiles(kModel, board::kModelPayloadBytes), "model payload: package offsets and fields differ");
static_assert(board::kModelWordBits == 48, "a model word is three 16-bit lanes");
static_assert(tiles(kIdentify, board::kIdentifyPayloadBytes), "identify payload: package offsets and fields differ");
static_assert(tiles(kTelemetry, board::kTelemetryPayloadBytes), "telemetry payload: package offsets and fields differ");
static_assert(board::kSetpointPayloadBytes <= board::kFrameMaxPayloadBytes &&
                  board::kCommandPayloadBytes <= board::kFrameMaxPayloadBytes &&
                  board::kModelPayloadBytes <= board::kFrameMaxPayloadBytes &&
                  board::kIdentifyPayloadBytes <= board::kFrameMaxPayloadBytes &&
                  board::kTelemetryPayloadBytes <= board::kFrameMaxPayloadBytes,
              "a payload larger than a frame holds");

}  // namespace layout
}  // namespace delta::link
