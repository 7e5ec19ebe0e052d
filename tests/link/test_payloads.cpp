// The board link v2 payloads (host/include/delta/link/payloads.hpp): random round trips of every
// payload, little-endian bytes at the package's offsets, the flag helpers, size errors, and the
// layout table against the package.
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <stdexcept>
#include <string>

#include "delta/link/payloads.hpp"
#include "delta/link/session.hpp"

namespace delta::link {
namespace {

constexpr std::uint64_t kSeed = 20261201;
constexpr int kTrials = 2000;

template <typename T>
T random_value(std::mt19937_64& random) {
  return static_cast<T>(random());  // every bit pattern, negative codes included
}

template <typename T, std::size_t N>
void fill(std::mt19937_64& random, std::array<T, N>& values) {
  for (T& value : values) value = random_value<T>(random);
}

TEST(LinkPayloads, SetpointRoundTripsOnRandomValues) {
  std::cout << "seed " << kSeed << "\n";
  std::mt19937_64 random(kSeed);
  for (int trial = 0; trial < kTrials; ++trial) {
    SetpointPayload sent;
    sent.sample_index = random_value<std::uint32_t>(random);
    fill(random, sent.input_code);
    const std::vector<std::uint8_t> bytes = encode(sent);
    ASSERT_EQ(bytes.size(), static_cast<std::size_t>(board::kSetpointPayloadBytes));
    const SetpointPayload received = decode_setpoint(bytes);
    ASSERT_EQ(received.sample_index, sent.sample_index) << "trial " << trial;
    ASSERT_EQ(received.input_code, sent.input_code) << "trial " << trial;
    ASSERT_EQ(encode(received), bytes);
  }
}

TEST(LinkPayloads, IdentifyRoundTripsOnRandomValues) {
  std::cout << "seed " << kSeed + 1 << "\n";
  std::mt19937_64 random(kSeed + 1);
  for (int trial = 0; trial < kTrials; ++trial) {
    IdentifyPayload sent;
    sent.protocol_version = random_value<std::uint16_t>(random);
    sent.setpoint_depth = random_value<std::uint16_t>(random);
    sent.build_id = random_value<std::uint32_t>(random);
    sent.weights_crc = random_value<std::uint32_t>(random);
    sent.network_clock_hz = random_value<std::uint32_t>(random);
    sent.board_clock_hz = random_value<std::uint32_t>(random);
    sent.control_rate_hz = random_value<std::uint16_t>(random);
    sent.setpoint_rate_hz = random_value<std::uint16_t>(random);
    const std::vector<std::uint8_t> bytes = encode(sent);
    ASSERT_EQ(bytes.size(), static_cast<std::size_t>(board::kIdentifyPayloadBytes));
    const IdentifyPayload received = decode_identify(bytes);
    ASSERT_EQ(received.protocol_version, sent.protocol_version);
    ASSERT_EQ(received.setpoint_depth, sent.setpoint_depth);
    ASSERT_EQ(received.build_id, sent.build_id);
    ASSERT_EQ(received.weights_crc, sent.weights_crc);
    ASSERT_EQ(received.network_clock_hz, sent.network_clock_hz);
    ASSERT_EQ(received.board_clock_hz, sent.board_clock_hz);
    ASSERT_EQ(received.control_rate_hz, sent.control_rate_hz);
    ASSERT_EQ(received.setpoint_rate_hz, sent.setpoint_rate_hz);
    ASSERT_EQ(encode(received), bytes) << "trial " << trial;
  }
}

// The fault byte: the causes in its low bits, joint j's play side (its count last stepped up) in bit
// TelemetryPlaySideShift + j; a side is never read as a fault.
TEST(LinkPayloads, TheFaultByteCarriesThePlaySidesApartFromTheCauses) {
  TelemetryPayload sent;
  sent.rising = 0b101;
  std::vector<std::uint8_t> bytes = encode(sent);
  EXPECT_EQ(bytes[board::kTelemetryFaultOffset], 0b101 << board::kTelemetryPlaySideShift);
  TelemetryPayload received = decode_telemetry(bytes);
  EXPECT_EQ(received.fault_cause, 0);
  EXPECT_EQ(received.play_side(0), 1);
  EXPECT_EQ(received.play_side(1), -1);
  EXPECT_EQ(received.play_side(2), 1);
  bytes[board::kTelemetryFaultOffset] =
      static_cast<std::uint8_t>((0b010 << board::kTelemetryPlaySideShift) | (1 << board::kFaultWatchdog));
  received = decode_telemetry(bytes);
  EXPECT_EQ(received.fault_cause, 1 << board::kFaultWatchdog);
  EXPECT_EQ(received.rising, 0b010);
  static_assert(board::kTelemetryPlaySideShift >= board::kFaultCauseBits, "the sides above the causes");
  static_assert(board::kTelemetryPlaySideShift + 3 <= 8, "three sides in the byte");
}

TEST(LinkPayloads, TelemetryRoundTripsOnRandomValues) {
  std::cout << "seed " << kSeed + 2 << "\n";
  std::mt19937_64 random(kSeed + 2);
  for (int trial = 0; trial < kTrials; ++trial) {
    TelemetryPayload sent;
    sent.sample_index = random_value<std::uint32_t>(random);
    sent.tick = random_value<std::uint32_t>(random);
    fill(random, sent.counts);
    fill(random, sent.references);  // i32 Q24.8 counts
    fill(random, sent.currents);
    sent.fault_cause = random_value<std::uint8_t>(random) & ((1u << board::kFaultCauseBits) - 1);
    sent.rising = random_value<std::uint8_t>(random) & 7;
    sent.flags = random_value<std::uint8_t>(random);
    sent.fill = random_value<std::uint16_t>(random);
    sent.bad_frames = random_value<std::uint16_t>(random);
    sent.underruns = random_value<std::uint16_t>(random);
    sent.saturations = random_value<std::uint16_t>(random);
    sent.slew_limits = random_value<std::uint16_t>(random);
    sent.sequence = random_value<std::uint8_t>(random);
    sent.rejected = random_value<std::uint16_t>(random) & ((1u << board::kStatusCounterBits) - 1);
    sent.board_fault = random_value<std::uint8_t>(random) & ((1u << board::kBoardFaultBits) - 1);
    sent.estop = (random() & 1) != 0;
    const std::vector<std::uint8_t> bytes = encode(sent);
    ASSERT_EQ(bytes.size(), static_cast<std::size_t>(board::kTelemetryPayloadBytes));
    const TelemetryPayload received = decode_telemetry(bytes);
    ASSERT_EQ(received.sample_index, sent.sample_index);
    ASSERT_EQ(received.tick, sent.tick);
    ASSERT_EQ(received.counts, sent.counts);
    ASSERT_EQ(received.references, sent.references);
    ASSERT_EQ(received.currents, sent.currents);
    ASSERT_EQ(received.fault_cause, sent.fault_cause);
    ASSERT_EQ(received.rising, sent.rising);
    ASSERT_EQ(received.flags, sent.flags);
    ASSERT_EQ(received.fill, sent.fill);
    ASSERT_EQ(received.bad_frames, sent.bad_frames);
    ASSERT_EQ(received.underruns, sent.underruns);
    ASSERT_EQ(received.saturations, sent.saturations);
    ASSERT_EQ(received.slew_limits, sent.slew_limits);
    ASSERT_EQ(received.sequence, sent.sequence);
    ASSERT_EQ(received.rejected, sent.rejected);
    ASSERT_EQ(received.board_fault, sent.board_fault);
    ASSERT_EQ(received.estop, sent.estop);
    ASSERT_EQ(encode(received), bytes) << "trial " << trial;
  }
}

TEST(LinkPayloads, EveryCommandRoundTripsAndOtherBytesAreNoCommand) {
  for (Command command : {Command::kEnable, Command::kDisable, Command::kHold, Command::kClearFault, Command::kSetHome,
                          Command::kHomeStart, Command::kEstop}) {
    const std::vector<std::uint8_t> bytes = encode(command);
    ASSERT_EQ(bytes.size(), static_cast<std::size_t>(board::kCommandPayloadBytes));
    EXPECT_EQ(decode_command(bytes), command);
  }
  EXPECT_EQ(encode(Command::kHold), std::vector<std::uint8_t>{board::kCommandHold});
  // The bench jog's six bytes, joint j and sign n at CommandJogBase + 2 j + n.
  for (int joint = 0; joint < 3; ++joint) {
    for (const bool negative : {false, true}) {
      const std::uint8_t byte = jog_command_byte(joint, negative);
      EXPECT_EQ(byte, board::kCommandJogBase + 2 * joint + (negative ? 1 : 0));
      EXPECT_EQ(decode_command({byte}), static_cast<Command>(byte));
    }
  }
  int known = 0;
  for (int byte = 0; byte < 256; ++byte) known += decode_command({static_cast<std::uint8_t>(byte)}).has_value();
  EXPECT_EQ(known, 7 + 6);
}

// The board's own causes: the e-stop command's latch in the fault byte's bit TelemetryEstopBit, the
// safety inputs' causes above the refused counter's 12 bits; each named, the board's first.
TEST(LinkPayloads, TheBoardCausesAreDecodedApartFromTheCountersAndNamed) {
  TelemetryPayload sent;
  std::vector<std::uint8_t> bytes = encode(sent);
  bytes[board::kTelemetryFaultOffset] = static_cast<std::uint8_t>((1 << board::kTelemetryEstopBit) | 0b10);
  bytes[board::kTelemetryRejectedOffset] = 0x23;
  bytes[board::kTelemetryRejectedOffset + 1] = 0x51;  // causes 0b0101 (e-stop input, drive 2), count 0x123
  TelemetryPayload t = decode_telemetry(bytes);
  EXPECT_TRUE(t.estop);
  EXPECT_EQ(t.fault_cause, 0b10);
  EXPECT_EQ(t.rejected, 0x123);
  EXPECT_EQ(t.board_fault, 0b0101);
  EXPECT_TRUE(t.has(BoardFault::kEstopInput));
  EXPECT_FALSE(t.has(BoardFault::kDrive1));
  EXPECT_TRUE(t.has(BoardFault::kDrive2));
  EXPECT_TRUE(t.board_cause());
  EXPECT_EQ(describe_fault(t), "e-stop command, e-stop input open, drive 2 fault, following error");
  EXPECT_EQ(encode(t), bytes);
  // A saturated counter (4095) stays apart from the causes.
  sent.rejected = 4095;
  sent.board_fault = 0b1010;
  bytes = encode(sent);
  EXPECT_EQ(bytes[board::kTelemetryRejectedOffset], 0xFF);
  EXPECT_EQ(bytes[board::kTelemetryRejectedOffset + 1], 0xAF);
  t = decode_telemetry(bytes);
  EXPECT_EQ(t.rejected, 4095);
  EXPECT_EQ(describe_fault(t), "drive 1 fault, drive 3 fault");
  EXPECT_FALSE(t.estop);
  EXPECT_EQ(describe_fault(TelemetryPayload{}), "none");
}

TEST(LinkPayloads, FieldsAreLittleEndianAtThePackagesOffsets) {
  TelemetryPayload telemetry;
  telemetry.tick = 0x04030201u;
  telemetry.counts[1] = -2;      // 0xFFFE
  telemetry.references[0] = -2;  // i32: 0xFFFFFFFE
  telemetry.references[2] = 0x12345678;
  telemetry.slew_limits = 0x1234;
  telemetry.rejected = 0x0BCD;
  telemetry.board_fault = 0xA;
  const std::vector<std::uint8_t> bytes = encode(telemetry);
  const std::size_t tick = board::kTelemetryTickOffset;
  EXPECT_EQ(std::vector<std::uint8_t>(bytes.begin() + tick, bytes.begin() + tick + 4),
            (std::vector<std::uint8_t>{0x01, 0x02, 0x03, 0x04}));
  EXPECT_EQ(bytes[board::kTelemetryCountsOffset + 2], 0xFE);
  EXPECT_EQ(bytes[board::kTelemetryCountsOffset + 3], 0xFF);
  EXPECT_EQ(bytes[board::kTelemetryReferencesOffset + 0], 0xFE);
  EXPECT_EQ(bytes[board::kTelemetryReferencesOffset + 3], 0xFF);
  EXPECT_EQ(bytes[board::kTelemetryReferencesOffset + 4], 0x00);  // references[1] = 0
  EXPECT_EQ(bytes[board::kTelemetryReferencesOffset + 8], 0x78);
  EXPECT_EQ(bytes[board::kTelemetryReferencesOffset + 11], 0x12);
  EXPECT_EQ(bytes[board::kTelemetrySlewLimitsOffset], 0x34);
  EXPECT_EQ(bytes[board::kTelemetrySlewLimitsOffset + 1], 0x12);
  EXPECT_EQ(bytes[board::kTelemetryRejectedOffset], 0xCD);
  EXPECT_EQ(bytes[board::kTelemetryRejectedOffset + 1], 0xAB);
  EXPECT_EQ(decode_telemetry(bytes).references, telemetry.references);
  SetpointPayload setpoint;
  setpoint.input_code = {-1, 0, 0x7F00};
  const std::vector<std::uint8_t> position = encode(setpoint);
  for (int i = 0; i < 2; ++i) EXPECT_EQ(position[board::kSetpointInputOffset + i], 0xFF);
  EXPECT_EQ(position[board::kSetpointInputOffset + 5], 0x7F);
}

TEST(LinkPayloads, FlagAndFaultHelpersUseThePackagesBits) {
  TelemetryPayload telemetry;
  telemetry.set(TelemetryFlag::kHomed, true);
  telemetry.set(TelemetryFlag::kFault, true);
  EXPECT_EQ(telemetry.flags, (1u << board::kFlagHomed) | (1u << board::kFlagFault));
  EXPECT_TRUE(telemetry.has(TelemetryFlag::kHomed));
  EXPECT_FALSE(telemetry.has(TelemetryFlag::kDriveEnable));
  telemetry.set(TelemetryFlag::kHomed, false);
  EXPECT_EQ(telemetry.flags, 1u << board::kFlagFault);
  telemetry.set(FaultCause::kWatchdog, true);
  EXPECT_EQ(telemetry.fault_cause, 1u << board::kFaultWatchdog);
  EXPECT_TRUE(telemetry.has(FaultCause::kWatchdog));
  EXPECT_FALSE(telemetry.has(FaultCause::kTravel));
  EXPECT_EQ(mask(TelemetryFlag::kEncoderError), 1u << board::kFlagEncoderError);
}

TEST(LinkPayloads, WrongSizesAreRefusedWithBothSizesNamed) {
  const std::vector<std::uint8_t> short_payload(board::kTelemetryPayloadBytes - 1);
  try {
    decode_telemetry(short_payload);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("telemetry"), std::string::npos) << message;
    EXPECT_NE(message.find(std::to_string(board::kTelemetryPayloadBytes - 1)), std::string::npos) << message;
    EXPECT_NE(message.find(std::to_string(board::kTelemetryPayloadBytes)), std::string::npos) << message;
  }
  EXPECT_THROW(decode_setpoint(std::vector<std::uint8_t>(board::kSetpointPayloadBytes + 1)), std::invalid_argument);
  EXPECT_THROW(decode_identify({}), std::invalid_argument);
  EXPECT_THROW(decode_command({}), std::invalid_argument);
  EXPECT_THROW(decode_command({1, 2}), std::invalid_argument);
}

TEST(LinkPayloads, FramesOfPayloadsPassTheDecoder) {
  SetpointPayload setpoint;
  setpoint.sample_index = 7;
  std::vector<std::uint8_t> to_board = encode_frame(make_frame(1, setpoint));
  for (const auto& frame : {make_frame(2, Command::kEnable), make_identify_request(3)}) {
    const std::vector<std::uint8_t> bytes = encode_frame(frame);
    to_board.insert(to_board.end(), bytes.begin(), bytes.end());
  }
  FrameDecoder board_side(Receiver::kBoard);
  const std::vector<Frame> frames = board_side.feed(to_board);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(decode_setpoint(frames[0].payload).sample_index, 7u);
  EXPECT_EQ(decode_command(frames[1].payload), Command::kEnable);
  EXPECT_EQ(frames[2].type, FrameType::kIdentifyRequest);
  FrameDecoder host_side(Receiver::kHost);
  const IdentifyPayload identify = board_identify(0x12345678u, 0x9ABCDEF0u);
  const std::vector<Frame> answers = host_side.feed(encode_frame(make_frame(3, identify)));
  ASSERT_EQ(answers.size(), 1u);
  const IdentifyPayload received = decode_identify(answers[0].payload);
  EXPECT_EQ(received.protocol_version, board::kProtocolVersion);
  EXPECT_EQ(received.setpoint_depth, board::kSetpointDepth);
  EXPECT_EQ(received.build_id, 0x12345678u);
  EXPECT_EQ(received.weights_crc, 0x9ABCDEF0u);
  EXPECT_EQ(received.network_clock_hz, board::kNetworkClockHz);
  EXPECT_EQ(received.board_clock_hz, board::kBoardClockHz);
  EXPECT_EQ(received.control_rate_hz, board::kControlRateHz);
  EXPECT_EQ(received.setpoint_rate_hz, board::kSetpointRateHz);
}

TEST(LinkPayloads, LayoutTablesTileEachPayload) {
  // The static_asserts in payloads.hpp already hold at compile time; this names them in CTest and
  // shows a drift is caught: one field moved by a byte no longer tiles.
  EXPECT_TRUE(layout::tiles(layout::kTelemetry, board::kTelemetryPayloadBytes));
  EXPECT_TRUE(layout::tiles(layout::kIdentify, board::kIdentifyPayloadBytes));
  EXPECT_TRUE(layout::tiles(layout::kModel, board::kModelPayloadBytes));
  layout::Field moved[] = {layout::kSetpointIndex, layout::kSetpointInput};
  moved[1].offset += 1;
  EXPECT_FALSE(layout::tiles(moved, board::kSetpointPayloadBytes));
  const layout::Field shrunk[] = {layout::kSetpointIndex, layout::kSetpointInput};
  EXPECT_FALSE(layout::tiles(shrunk, board::kSetpointPayloadBytes + 1));
}

}  // namespace
}  // namespace delta::link

namespace delta::link {
namespace {

TEST(LinkState, AHomingStoppedWithTheDrivesOffSaysHowFarItGot) {
  TelemetryPayload t;
  t.set(TelemetryFlag::kHomed, true);
  t.set(TelemetryFlag::kHoming, true);
  t.set(TelemetryFlag::kModel, true);
  t.home = 1u << 3;  // joint 1 referenced
  EXPECT_EQ(describe_state(t), "drives off, homed by hand, homing unfinished (1 of 3 joints referenced)");
  t.set(TelemetryFlag::kDriveEnable, true);
  EXPECT_EQ(describe_state(t), "drives on, homed by hand, homing");
  t.set(TelemetryFlag::kModel, false);
  EXPECT_EQ(describe_state(t), "drives on, homed by hand, no model, homing");
}

}  // namespace
}  // namespace delta::link
