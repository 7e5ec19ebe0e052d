// The board core's link v2 (docs/board_link.md) end to end through its UART pins, as built (23
// clocks per bit, 2325 clocks per control period, the network on its own clock at twice the
// board's): identify; the receiver against the host's FrameDecoder on the same byte streams
// (valid, corrupted, truncated, oversized, unknown and wrong-direction frames, junk); random bytes
// never enable the drives nor move a reference; the watchdog; the commands and their refusals;
// setpoints played at 1 kHz and the 10 kHz references bit for bit against the golden interpolation;
// the model loaded through the link (its rules: drives off, in order, the CRC-32 checked).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "Vboard_core.h"
#include "Vboard_core___024root.h"
#include "board_link_bench.hpp"
#include "delta/gateware.hpp"
#include "delta/geometry.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/golden/setpoint_interpolation.hpp"
#include "delta/kinematics.hpp"
#include "delta/nn/weights_file.hpp"
#include "rtl_fixture.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

using Bench = LinkBench<Vboard_core>;
using link::Command;
using link::Frame;
using link::FrameType;

const std::string kShippedWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";

golden::QuantisedNetwork shipped_network() { return golden::quantise(nn::read_weights_file(kShippedWeights).network); }

std::string export_directory(const golden::QuantisedNetwork& q, const std::string& name) {
  const std::string directory = fresh_directory(name);
  golden::write_export(q, directory);
  return directory;
}

// What the receiver delivered, watched on its public signals cycle by cycle.
struct ReceiverLog {
  std::vector<Frame> accepted;
  std::uint64_t dropped = 0;
  std::vector<std::uint8_t> payload;

  void watch(Vboard_core& core) {
    const auto& root = *core.rootp;
    if (root.board_core__DOT__payload_valid) {
      if (root.board_core__DOT__payload_index == 0) payload.clear();
      payload.push_back(root.board_core__DOT__payload_byte);
    }
    if (root.board_core__DOT__frame_ok) {
      Frame frame;
      frame.type = static_cast<FrameType>(root.board_core__DOT__frame_type);
      frame.sequence = root.board_core__DOT__frame_sequence;
      const auto size = link::payload_bytes(link::Receiver::kBoard, root.board_core__DOT__frame_type);
      if (size && *size > 0) frame.payload = payload;
      accepted.push_back(std::move(frame));
      payload.clear();
    }
    if (root.board_core__DOT__frame_bad) {
      ++dropped;
      payload.clear();
    }
  }
};

std::array<std::int32_t, 3> board_references(Vboard_core& core) {
  std::array<std::int32_t, 3> r{};
  for (int j = 0; j < 3; ++j) r[j] = static_cast<std::int32_t>(core.rootp->board_core__DOT__references[j]);
  return r;
}

// ---- identify --------------------------------------------------------------------------------

TEST(BoardLink, IdentifyAnswersWithItsBuildIdWeightsCrcAndClocks) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_link_identify"));
  bench.send(link::make_identify_request(0x42));
  ASSERT_TRUE(bench.run_until([&] { return !bench.identify_frames().empty(); }, 3 * kCyclesPerMillisecond));
  const Frame& reply = bench.identify_frames().front();
  EXPECT_EQ(reply.sequence, 0x42);  // the request's
  const link::IdentifyPayload identify = link::decode_identify(reply.payload);
  EXPECT_EQ(identify.protocol_version, board::kProtocolVersion);
  EXPECT_EQ(identify.build_id, kGatewareBuildId);
  EXPECT_EQ(identify.weights_crc, 0u);  // no model loaded yet
  EXPECT_EQ(identify.board_clock_hz, board::kBoardClockHz);
  EXPECT_EQ(identify.network_clock_hz, board::kNetworkClockHz);
  EXPECT_EQ(identify.setpoint_depth, board::kSetpointDepth);
  EXPECT_EQ(identify.setpoint_rate_hz, board::kSetpointRateHz);
  // Telemetry flows meanwhile, one frame per millisecond, sequence numbers consecutive.
  bench.run(5 * kCyclesPerMillisecond);
  const auto& sequences = bench.telemetry_sequences();
  ASSERT_GE(sequences.size(), 5u);
  for (std::size_t i = 1; i < sequences.size(); ++i)
    EXPECT_EQ(static_cast<std::uint8_t>(sequences[i - 1] + 1), sequences[i]);
  EXPECT_EQ(bench.host_decoder().bad_crc + bench.host_decoder().bad_length + bench.host_decoder().unknown_type, 0u);
  // With the model loaded, its CRC-32 (the host's weights CRC).
  bench.load_model(q);
  bench.send(link::make_identify_request(0x43));
  ASSERT_TRUE(bench.run_until([&] { return bench.identify_frames().size() == 2; }, 3 * kCyclesPerMillisecond));
  EXPECT_EQ(link::decode_identify(bench.identify_frames().back().payload).weights_crc, weights_crc(q));
  EXPECT_NE(weights_crc(q), 0u);
}

// ---- the receiver against the codec ------------------------------------------------------------

// A stream of frames for the board, good and bad, seeded: every way a frame can go wrong.
class FrameStream {
 public:
  explicit FrameStream(std::uint64_t seed) : random_(seed) {}

  std::vector<std::uint8_t> next() {
    const int kind = static_cast<int>(random_() % 100);
    if (kind < 45) return valid_frame();
    if (kind < 60) return corrupt(valid_frame());
    if (kind < 70) return truncate(valid_frame());
    if (kind < 76) return bad_length();
    if (kind < 82) return other_type();
    if (kind < 88) return wrong_direction();
    return junk();
  }

 private:
  std::uint8_t byte() { return static_cast<std::uint8_t>(random_()); }
  std::vector<std::uint8_t> valid_frame() {
    Frame frame;
    frame.sequence = byte();
    const int type = static_cast<int>(random_() % 4);
    frame.type = type == 0   ? FrameType::kIdentifyRequest
                 : type == 1 ? FrameType::kSetpoint
                 : type == 2 ? FrameType::kCommand
                             : FrameType::kModel;
    frame.payload.resize(*link::payload_bytes(link::Receiver::kBoard, static_cast<std::uint8_t>(frame.type)));
    for (auto& b : frame.payload) b = byte();
    // Commands: mostly harmless ones (hold, clear fault, unknown); setpoints: any bytes.
    if (frame.type == FrameType::kCommand && frame.payload[0] == board::kCommandSetHome) frame.payload[0] = 0x77;
    // Model frames: mostly the first frames of a load (taken: the parser stalls for their CRC).
    if (frame.type == FrameType::kModel && random_() % 2 == 0) {
      frame.payload[0] = static_cast<std::uint8_t>(random_() % 3);
      frame.payload[1] = 0;
    }
    return link::encode_frame(frame);
  }
  std::vector<std::uint8_t> corrupt(std::vector<std::uint8_t> bytes) {
    const int flips = 1 + static_cast<int>(random_() % 3);
    for (int i = 0; i < flips; ++i) bytes[random_() % bytes.size()] ^= static_cast<std::uint8_t>(1u << (random_() % 8));
    return bytes;
  }
  std::vector<std::uint8_t> truncate(std::vector<std::uint8_t> bytes) {
    bytes.resize(1 + random_() % (bytes.size() - 1));
    return bytes;
  }
  // A known type with a length that is not its size (oversized up to 255 included), CRC valid.
  std::vector<std::uint8_t> bad_length() {
    std::vector<std::uint8_t> bytes = valid_frame();
    std::uint8_t length = byte();
    while (length == bytes[1]) length = byte();
    bytes[1] = length;
    return recrc(bytes);
  }
  std::vector<std::uint8_t> other_type() {
    std::vector<std::uint8_t> bytes = valid_frame();
    std::uint8_t type = byte();
    while (link::payload_bytes(link::Receiver::kBoard, type)) type = byte();
    bytes[3] = type;
    return recrc(bytes);
  }
  std::vector<std::uint8_t> wrong_direction() {  // a telemetry or identify frame, perfectly formed
    Frame frame;
    frame.sequence = byte();
    frame.type = random_() % 2 ? FrameType::kTelemetry : FrameType::kIdentify;
    frame.payload.resize(*link::payload_bytes(link::Receiver::kHost, static_cast<std::uint8_t>(frame.type)));
    for (auto& b : frame.payload) b = byte();
    return link::encode_frame(frame);
  }
  std::vector<std::uint8_t> junk() {
    std::vector<std::uint8_t> bytes(1 + random_() % 12);
    for (auto& b : bytes) b = random_() % 5 == 0 ? board::kFrameSync : byte();
    return bytes;
  }
  static std::vector<std::uint8_t> recrc(std::vector<std::uint8_t> bytes) {
    const std::uint16_t crc = link::crc16(bytes.data() + 1, bytes.size() - 3);
    bytes[bytes.size() - 2] = static_cast<std::uint8_t>(crc >> 8);
    bytes[bytes.size() - 1] = static_cast<std::uint8_t>(crc & 0xFF);
    return bytes;
  }
  std::mt19937_64 random_;
};

void expect_same_frames(const std::vector<Frame>& codec, const std::vector<Frame>& rtl) {
  ASSERT_EQ(codec.size(), rtl.size());
  for (std::size_t i = 0; i < codec.size(); ++i) {
    EXPECT_EQ(codec[i].type, rtl[i].type) << "frame " << i;
    EXPECT_EQ(codec[i].sequence, rtl[i].sequence) << "frame " << i;
    EXPECT_EQ(codec[i].payload, rtl[i].payload) << "frame " << i;
    if (testing::Test::HasFailure()) return;
  }
}

TEST(BoardLink, ReceiverAndCodecAcceptTheSameFramesAndDropTheSameCount) {
  const std::uint64_t seed = 1201;
  std::cout << "seed " << seed << "\n";
  Bench bench(export_directory(shipped_network(), "board_link_agree"));
  ReceiverLog log;
  bench.hook = [&] { log.watch(bench.core()); };
  link::FrameDecoder codec(link::Receiver::kBoard);
  std::vector<Frame> codec_frames;
  FrameStream stream(seed);
  constexpr int kItems = 12000;
  for (int i = 0; i < kItems; ++i) {
    const std::vector<std::uint8_t> bytes = stream.next();
    for (Frame& frame : codec.feed(bytes)) codec_frames.push_back(std::move(frame));
    bench.send(bytes);
    bench.run_until_sent();
  }
  bench.run(200);  // the parser's last bytes
  std::cout << kItems << " items, " << codec.counters().frames << " frames accepted, " << codec.dropped()
            << " dropped (crc " << codec.counters().bad_crc << ", length " << codec.counters().bad_length << ", type "
            << codec.counters().unknown_type << ")\n";
  EXPECT_GT(codec.counters().frames, 5000u);
  EXPECT_GT(codec.counters().bad_crc, 1000u);
  EXPECT_GT(codec.counters().bad_length, 300u);
  EXPECT_GT(codec.counters().unknown_type, 300u);
  expect_same_frames(codec_frames, log.accepted);
  EXPECT_EQ(log.dropped, codec.dropped());
  // The board counts them too (its status counters saturate at 4095).
  const link::TelemetryPayload telemetry = bench.next_telemetry();
  EXPECT_EQ(telemetry.bad_frames, std::min<std::uint64_t>(codec.dropped(), (1u << board::kStatusCounterBits) - 1));
}

TEST(BoardLink, RandomBytesNeverEnableTheDrivesNorMoveAReferenceAndEveryDropIsCounted) {
  const std::uint64_t seed = 77;
  std::cout << "seed " << seed << "\n";
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_link_random"));
  bench.load_model(q);  // only the homing stands between the random bytes and the drives
  ReceiverLog log;
  bool ever_enabled = false;
  bool reference_moved = false;
  const std::int32_t home_reference = kBoardHomeCount * 256;
  bench.run(kCyclesPerMillisecond);  // the first update puts the references on the encoders
  ASSERT_EQ(board_references(bench.core()),
            (std::array<std::int32_t, 3>{home_reference, home_reference, home_reference}));
  bench.hook = [&] {
    log.watch(bench.core());
    ever_enabled = ever_enabled || bench.core().drive_enable_o;
    // The joints read their references at the period's start (between updates they hold).
    if (bench.core().rootp->board_core__DOT__tick == 2) {
      for (std::int32_t r : board_references(bench.core())) reference_moved = reference_moved || r != home_reference;
    }
  };
  link::FrameDecoder codec(link::Receiver::kBoard);
  std::vector<Frame> codec_frames;
  std::mt19937_64 random(seed);
  std::vector<std::uint8_t> bytes(100000);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(random());
  for (Frame& frame : codec.feed(bytes)) codec_frames.push_back(std::move(frame));
  bench.send(bytes);
  bench.run_until_sent();
  bench.run(200);
  std::cout << "1e5 random bytes: " << codec.dropped() << " frames dropped, " << codec_frames.size() << " accepted\n";
  EXPECT_FALSE(ever_enabled);
  EXPECT_FALSE(reference_moved);
  EXPECT_GT(codec.dropped(), 100u);
  EXPECT_EQ(log.dropped, codec.dropped());
  expect_same_frames(codec_frames, log.accepted);
  const link::TelemetryPayload telemetry = bench.next_telemetry();
  EXPECT_EQ(telemetry.bad_frames, codec.dropped());
  EXPECT_FALSE(telemetry.has(link::TelemetryFlag::kDriveEnable));
}

// ---- commands and safety -----------------------------------------------------------------------

TEST(BoardLink, CommandsAreTakenOnlyWhenAllowedAndAFaultNeverReenables) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_link_commands"));
  bench.load_model(q);
  link::TelemetryPayload t = bench.exchange(bench.command(Command::kEnable));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable)) << "enable before set home";
  EXPECT_EQ(t.rejected, 1);
  t = bench.exchange(bench.command(Command::kSetHome));
  bench.homed();
  EXPECT_TRUE(t.has(link::TelemetryFlag::kHomed));
  t = bench.exchange(bench.command(Command::kEnable));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_EQ(bench.core().drive_enable_o, 1);
  t = bench.exchange(bench.command(Command::kSetHome));
  EXPECT_EQ(t.rejected, 2) << "set home with the drives on";
  t = bench.exchange(bench.command(Command::kHold));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kHolding));
  t = bench.exchange(bench.command(Command::kEnable));  // resume
  EXPECT_FALSE(t.has(link::TelemetryFlag::kHolding));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  t = bench.exchange(bench.command(Command::kDisable));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));
  t = bench.exchange(bench.command(Command::kHold));
  EXPECT_EQ(t.rejected, 3) << "hold with the drives off";
  Frame unknown = bench.command(Command::kHold);
  unknown.payload[0] = 0x99;
  t = bench.exchange(unknown);
  EXPECT_EQ(t.rejected, 4) << "unknown command byte";

  // A fault (the watchdog: drives on, then silence) turns the drives off and stays latched.
  t = bench.exchange(bench.command(Command::kEnable));
  ASSERT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  bench.run((board::kWatchdogPeriods / board::kPeriodsPerSetpoint + 10) * kCyclesPerMillisecond);
  EXPECT_EQ(bench.core().drive_enable_o, 0);
  EXPECT_EQ(bench.core().joint_fault_o, 1);
  t = bench.exchange(bench.command(Command::kEnable));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable)) << "enable with a fault latched";
  EXPECT_TRUE(t.has(link::TelemetryFlag::kFault));
  EXPECT_EQ(t.fault_cause, 1 << board::kFaultWatchdog);
  t = bench.exchange(bench.command(Command::kClearFault));  // the cause is gone: accepted
  EXPECT_FALSE(t.has(link::TelemetryFlag::kFault));
  EXPECT_EQ(t.fault_cause, 0);
  bench.run(10 * kCyclesPerMillisecond);
  EXPECT_EQ(bench.core().drive_enable_o, 0) << "cleared is not enabled";
  t = bench.exchange(bench.command(Command::kEnable));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
}

TEST(BoardLink, ClearFaultIsRefusedWhileACausePersists) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_link_clear"));
  bench.load_model(q);
  bench.exchange(bench.command(Command::kSetHome));
  bench.homed();
  bench.exchange(bench.command(Command::kEnable));
  // Joint 1 is pushed away while its reference holds: a following error at 512 counts stops the
  // torque; pushed on past the end of the travel (9215 counts), it is outside the travel, a
  // cause that persists with the drives off (their reference is then the encoder count itself).
  bench.target_counts[1] = 9400;
  ASSERT_TRUE(bench.run_until([&] { return bench.core().joint_fault_o == 1; }, 20 * kCyclesPerMillisecond));
  ASSERT_TRUE(bench.run_until([&] { return bench.counts()[1] == 9400; }, 200 * kCyclesPerMillisecond));
  link::TelemetryPayload t = bench.next_telemetry();
  EXPECT_EQ(t.fault_cause, 1 << board::kFaultFollowing);
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));
  const int rejected = t.rejected;
  t = bench.exchange(bench.command(Command::kClearFault));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kFault)) << "the joint is outside its travel";
  EXPECT_EQ(t.rejected, rejected + 1);
  bench.target_counts[1] = 9000;  // back inside: the clear is taken, the drives stay off
  ASSERT_TRUE(bench.run_until([&] { return bench.counts()[1] == 9000; }, 200 * kCyclesPerMillisecond));
  bench.run(kCyclesPerMillisecond);
  t = bench.exchange(bench.command(Command::kClearFault));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kFault));
  EXPECT_EQ(t.fault_cause, 0);
  EXPECT_EQ(t.rejected, rejected + 1);
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));
}

TEST(BoardLink, WatchdogTurnsTheTorqueOffWithinItsBoundOfTheLastValidFrame) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_link_watchdog"));
  bench.load_model(q);
  std::int64_t last_valid = 0;
  bench.hook = [&] {
    if (bench.core().rootp->board_core__DOT__frame_ok) last_valid = bench.cycles();
  };
  const double bound_ms = board::kWatchdogPeriods * 1e3 / board::kControlRateHz;  // 250 ms
  const int gap_ms = static_cast<int>(bound_ms) - 10;
  bench.exchange(bench.command(Command::kSetHome));
  bench.homed();
  bench.exchange(bench.command(Command::kEnable));
  for (int i = 0; i < 3; ++i) {  // a frame every bound - 10 ms keeps it alive
    bench.send(link::make_identify_request(bench.next_sequence()));
    bench.run(gap_ms * kCyclesPerMillisecond);
    ASSERT_EQ(bench.core().drive_enable_o, 1) << "after " << (i + 1) * gap_ms << " ms";
  }
  bench.run_until([&] { return bench.core().drive_enable_o == 0; }, 2 * gap_ms * kCyclesPerMillisecond);
  const double off_after_ms = static_cast<double>(bench.cycles() - last_valid) / board::kBoardClockHz * 1e3;
  std::cout << "torque off " << off_after_ms << " ms after the last valid frame (bound " << bound_ms << " ms)\n";
  EXPECT_EQ(bench.core().drive_enable_o, 0);
  EXPECT_EQ(bench.core().joint_fault_cause_o, 1 << board::kFaultWatchdog);
  EXPECT_LE(off_after_ms, bound_ms + 0.1 + 0.01);  // the bound + one control period (+ the output register)
  EXPECT_GE(off_after_ms, bound_ms - 0.1);
}

// ---- setpoints, the network and the interpolated references ------------------------------------

// Positions around the home pose (every joint at 30 deg): a 2 mm circle at 1 Hz with a 4 mm jump.
Vec3 home_position() { return forward_kinematics(Geometry::nominal(), Vec3(30.0, 30.0, 30.0)).position_m; }

// Streams 400 setpoints (a circle with a slew-limited jump) to the board and compares every
// period's references with the golden interpolation (with q's backlash half-plays, if any).
// first: a model loaded before q's, which q's load replaces.
void expect_references_equal_the_golden_interpolation(const golden::QuantisedNetwork& q, const std::string& name,
                                                      const golden::QuantisedNetwork* first = nullptr) {
  Bench bench(export_directory(q, name));
  if (first) bench.load_model(*first);
  bench.load_model(q);
  Vboard_core& core = bench.core();
  auto& root = *core.rootp;
  // The plant: the encoders follow the references (a perfect joint), so no following error.
  // The golden model runs alongside, fed with what the board plays (its pops) and the golden
  // network's answers; every period's references must match, bit for bit.
  std::vector<std::array<std::int64_t, 3>> codes;  // setpoint n's position codes
  golden::SetpointInterpolator golden_interpolator(golden::interpolation::half_play_counts(q.compensation));
  bool enabled = false, compared_any = false;
  std::uint32_t played = 0;
  std::int64_t periods_compared = 0, mismatches = 0;
  bench.hook = [&] {
    const int tick = root.board_core__DOT__tick;
    if (tick == 2) {  // a new period has begun (phase_q and the references are this period's)
      const int phase = root.board_core__DOT__phase_q;
      const std::array<std::int32_t, 3> rtl = board_references(core);
      if (enabled) {
        if (phase == 0) {
          // The board pops at tick 1 when it plays; sample_index has advanced by then.
          if (root.board_core__DOT__sample_index > played) {
            const auto answer = golden::evaluate_raw(q, codes.at(played)).alpha;
            golden_interpolator.begin_segment({static_cast<std::int32_t>(answer[0]),
                                               static_cast<std::int32_t>(answer[1]),
                                               static_cast<std::int32_t>(answer[2])});
            ++played;
          } else {
            golden_interpolator.begin_hold_segment();
          }
        }
        const auto expected = golden_interpolator.reference(phase);
        ++periods_compared;
        compared_any = true;
        if (expected != rtl) {
          if (++mismatches < 5)
            ADD_FAILURE() << "period " << periods_compared << " k " << phase << ": rtl " << rtl[0] << ' ' << rtl[1]
                          << ' ' << rtl[2] << ", golden " << expected[0] << ' ' << expected[1] << ' ' << expected[2];
        }
      }
      if (!enabled && core.drive_enable_o) {
        // The first period with the drives on starts where the encoders were (r = count << 8,
        // D = 0); from the next segment start on the references interpolate the answers.
        enabled = true;
        std::array<std::int16_t, 3> counts{};
        for (int j = 0; j < 3; ++j) counts[j] = static_cast<std::int16_t>(rtl[j] >> 8);
        golden_interpolator.follow_encoders(counts);
        if (phase == 0 && root.board_core__DOT__sample_index > played) {
          const auto answer = golden::evaluate_raw(q, codes.at(played)).alpha;
          golden_interpolator.begin_segment({static_cast<std::int32_t>(answer[0]), static_cast<std::int32_t>(answer[1]),
                                             static_cast<std::int32_t>(answer[2])});
          ++played;
        }
      }
      if (core.drive_enable_o) {  // the joint follows its reference while driven, holds still otherwise
        for (int j = 0; j < 3; ++j) bench.target_counts[j] = static_cast<int>(golden::round_shift(rtl[j], 8));
      }
    }
  };
  bench.exchange(bench.command(Command::kSetHome));
  bench.homed();
  // 400 setpoints: 0.4 s around a 2 mm circle, sent ahead as the fill allows (target fill 16).
  const Vec3 centre = home_position();
  for (int n = 0; n < 400; ++n) {
    const double angle = 2.0 * 3.141592653589793 * n / 1000.0;
    // Setpoints 200..239 jump 4 mm up: changes beyond 1.28 deg per millisecond, slew-limited.
    const double jump_m = (n >= 200 && n < 240) ? 0.004 : 0.0;
    const Vec3 p = centre + Vec3(0.002 * std::cos(angle) - 0.002, 0.002 * std::sin(angle), jump_m);
    codes.push_back(golden::encode_position(q.formats, p));
  }
  std::uint32_t next_index = 0;
  auto stream_some = [&](const link::TelemetryPayload& t) {
    const std::uint32_t wanted = t.sample_index + 16;
    while (next_index < codes.size() && next_index < wanted && next_index < t.sample_index + t.fill + 4) {
      link::SetpointPayload setpoint;
      setpoint.sample_index = next_index;
      setpoint.input_code = golden::setpoint_input(q, codes[next_index]);
      bench.send(link::make_frame(bench.next_sequence(), setpoint));
      ++next_index;
    }
  };
  link::TelemetryPayload t = bench.exchange(bench.command(Command::kEnable));
  ASSERT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  std::size_t seen = bench.telemetry().size();
  int underruns_while_streaming = -1;
  while (bench.telemetry().back().sample_index < codes.size() && bench.cycles() < 2000 * kCyclesPerMillisecond) {
    bench.run_until([&] { return bench.telemetry().size() > seen; }, 2 * kCyclesPerMillisecond);
    seen = bench.telemetry().size();
    t = bench.telemetry().back();
    if (t.sample_index > 20 && underruns_while_streaming < 0) underruns_while_streaming = t.underruns;
    stream_some(t);
    ASSERT_FALSE(t.has(link::TelemetryFlag::kFault)) << "fault " << int(t.fault_cause);
  }
  const link::TelemetryPayload end_of_stream = bench.telemetry().back();
  bench.run(20 * kCyclesPerMillisecond);  // the buffer runs dry: underruns, the reference holds
  const link::TelemetryPayload after = bench.next_telemetry();
  std::cout << periods_compared << " periods compared, " << played << " setpoints played, underruns at the end "
            << after.underruns << ", slew limits " << after.slew_limits << "\n";
  EXPECT_TRUE(compared_any);
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(played, codes.size());
  EXPECT_EQ(after.sample_index, codes.size());
  EXPECT_EQ(after.rejected, 0);
  EXPECT_EQ(end_of_stream.underruns, underruns_while_streaming) << "no underrun while the host kept the buffer filled";
  EXPECT_GE(after.underruns, end_of_stream.underruns + 15);
  EXPECT_GT(after.slew_limits, 0) << "the 4 mm jump is slew-limited";
  EXPECT_EQ(after.slew_limits, golden_interpolator.saturations()[0] + golden_interpolator.saturations()[1] +
                                   golden_interpolator.saturations()[2]);
  EXPECT_EQ(after.references, board_references(core)) << "the telemetry's references are the board's";
}

TEST(BoardLink, SetpointsPlayAtOneKilohertzAndTheReferencesEqualTheGoldenInterpolation) {
  expect_references_equal_the_golden_interpolation(shipped_network(), "board_link_setpoints");
}

// The deployed model (weights/paper_like_deployed.json): its half-plays in half_play.mem, the
// board's play on C - B, bit for bit the golden interpolation's, across the circle's reversals,
// the slew-limited jump and the holds at the end.
TEST(BoardLink, TheDeployedModelsBacklashCompensationEqualsTheGoldenInterpolation) {
  const std::string path = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
  const golden::QuantisedNetwork q = golden::quantise_file(path, nn::read_weights_file(path));
  ASSERT_TRUE(q.compensation.any());
  std::cout << "half-plays " << q.compensation.half_play[0] << ' ' << q.compensation.half_play[1] << ' '
            << q.compensation.half_play[2] << " output LSBs\n";
  expect_references_equal_the_golden_interpolation(q, "board_link_setpoints_deployed");
}

// The second model's load replaces the first: the references are the golden interpolation of the
// second's answers (the random network of the RTL tests, deployed model's memories overwritten).
TEST(BoardLink, ASecondLoadReplacesTheModelAndTheBoardPlaysIt) {
  const std::string path = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
  const golden::QuantisedNetwork deployed = golden::quantise_file(path, nn::read_weights_file(path));
  const golden::QuantisedNetwork shipped = shipped_network();
  ASSERT_NE(weights_crc(deployed), weights_crc(shipped));
  expect_references_equal_the_golden_interpolation(shipped, "board_link_second_load", &deployed);
}

// ---- the model (docs/board_link.md, "The model") ------------------------------------------------

link::IdentifyPayload identify(Bench& bench) {
  const std::size_t seen = bench.identify_frames().size();
  bench.send(link::make_identify_request(bench.next_sequence()));
  bench.run_until([&] { return bench.identify_frames().size() > seen; }, 3 * kCyclesPerMillisecond);
  EXPECT_GT(bench.identify_frames().size(), seen) << "no identify reply";
  return link::decode_identify(bench.identify_frames().back().payload);
}

TEST(BoardModel, WithoutAModelEnableIsRefusedAndCountedAndNothingMoves) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_model_none"));
  bool ever_enabled = false;
  bench.hook = [&] { ever_enabled = ever_enabled || bench.core().drive_enable_o || bench.core().drive_pwm_o; };
  link::TelemetryPayload t = bench.exchange(bench.command(Command::kSetHome));
  bench.homed();
  EXPECT_TRUE(t.has(link::TelemetryFlag::kHomed));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kModel));
  t = bench.exchange(bench.command(Command::kEnable));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable)) << "enable without a model";
  EXPECT_EQ(t.rejected, 1);
  link::SetpointPayload setpoint;
  setpoint.sample_index = 0;
  t = bench.exchange(link::make_frame(bench.next_sequence(), setpoint));
  EXPECT_EQ(t.rejected, 2) << "a setpoint with the drives off";
  bench.run(5 * kCyclesPerMillisecond);
  EXPECT_FALSE(ever_enabled);
  EXPECT_EQ(bench.next_telemetry().sample_index, 0u);
  EXPECT_EQ(identify(bench).weights_crc, 0u);
  // The same board with the model: the enable is taken.
  bench.load_model(q);
  t = bench.exchange(bench.command(Command::kEnable));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kModel));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_EQ(t.rejected, 2);
}

TEST(BoardModel, AGoodLoadSetsTheFlagAndIdentifiesItsCrc) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_model_good"));
  EXPECT_FALSE(bench.next_telemetry().has(link::TelemetryFlag::kModel));
  bench.load_model(q);
  const link::TelemetryPayload t = bench.next_telemetry();
  EXPECT_TRUE(t.has(link::TelemetryFlag::kModel));
  EXPECT_EQ(t.rejected, 0);
  EXPECT_EQ(t.bad_frames, 0);
  EXPECT_EQ(identify(bench).weights_crc, weights_crc(q));
}

TEST(BoardModel, ALoadWithTheDrivesOnIsRefusedAndChangesNothing) {
  const golden::QuantisedNetwork q = shipped_network();
  const std::string path = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
  const golden::QuantisedNetwork other = golden::quantise_file(path, nn::read_weights_file(path));
  Bench bench(export_directory(q, "board_model_drives_on"));
  bench.load_model(q);
  bench.exchange(bench.command(Command::kSetHome));
  bench.homed();
  link::TelemetryPayload t = bench.exchange(bench.command(Command::kEnable));
  ASSERT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  const std::vector<Frame> frames = bench.model_frames(other);
  bench.send_all(frames);
  t = bench.next_telemetry();
  EXPECT_EQ(t.rejected, static_cast<int>(frames.size())) << "every frame refused";
  EXPECT_TRUE(t.has(link::TelemetryFlag::kModel));
  EXPECT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_EQ(identify(bench).weights_crc, weights_crc(q));
  // Not even a start: after the disable the board still holds q and the first frames of a load
  // other than 0 are refused.
  bench.exchange(bench.command(Command::kDisable));
  bench.send_all({frames[1], frames[2]});
  t = bench.next_telemetry();
  EXPECT_EQ(t.rejected, static_cast<int>(frames.size()) + 2);
  EXPECT_TRUE(t.has(link::TelemetryFlag::kModel));
}

TEST(BoardModel, ALoadCutOffHalfWayLeavesNoModelAndResumesWhereItStopped) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_model_cut"));
  bench.load_model(q);
  const std::vector<Frame> frames = bench.model_frames(q);
  const std::size_t half = frames.size() / 2;
  bench.send_all(std::vector<Frame>(frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(half)));
  link::TelemetryPayload t = bench.next_telemetry();
  EXPECT_FALSE(t.has(link::TelemetryFlag::kModel)) << "a load void the model from its frame 0";
  EXPECT_EQ(identify(bench).weights_crc, 0u);
  bench.exchange(bench.command(Command::kSetHome));
  bench.homed();
  t = bench.exchange(bench.command(Command::kEnable));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_EQ(t.rejected, 1);
  // A lost frame: the rest is refused, frame by frame, until the host resends from there.
  bench.send_all(std::vector<Frame>(frames.begin() + static_cast<std::ptrdiff_t>(half) + 1, frames.end()));
  t = bench.next_telemetry();
  EXPECT_FALSE(t.has(link::TelemetryFlag::kModel));
  EXPECT_EQ(t.rejected, 1 + static_cast<int>(frames.size() - half - 1));
  bench.send_all(std::vector<Frame>(frames.begin() + static_cast<std::ptrdiff_t>(half), frames.end()));
  t = bench.next_telemetry();
  EXPECT_TRUE(t.has(link::TelemetryFlag::kModel));
  EXPECT_EQ(identify(bench).weights_crc, weights_crc(q));
}

TEST(BoardModel, OneCorruptedWordUnderTheOriginalsCrcLeavesNoModel) {
  const golden::QuantisedNetwork q = shipped_network();
  Bench bench(export_directory(q, "board_model_corrupt"));
  for (const std::size_t frame : {std::size_t{0}, std::size_t{90}, std::size_t{board::kModelCommitFrame - 1}}) {
    std::vector<link::ModelPayload> payloads = golden::model_frames(q);
    payloads[frame].word[0] ^= 0x0100;  // one bit of the word; the commit keeps the original's CRC
    std::vector<Frame> frames;
    for (const link::ModelPayload& payload : payloads)
      frames.push_back(link::make_frame(bench.next_sequence(), payload));
    bench.send_all(frames);
    const link::TelemetryPayload t = bench.next_telemetry();
    EXPECT_FALSE(t.has(link::TelemetryFlag::kModel)) << "frame " << frame << " corrupted";
    EXPECT_EQ(t.rejected, 0);
    EXPECT_EQ(identify(bench).weights_crc, 0u);
  }
  bench.load_model(q);
  EXPECT_TRUE(bench.next_telemetry().has(link::TelemetryFlag::kModel));
}

}  // namespace
}  // namespace delta::test
