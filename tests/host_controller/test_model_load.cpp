// The host side of a model load (LinkSession::load_model, controller::load_board_model) against a
// scripted board that keeps the board's rules for model frames (docs/board_link.md, "The model")
// and its receive ring: the load paced by the board's acceptance keeps the ring within its 512
// bytes even on a board that takes frames slower than the line brings them; a frame lost on the
// line, a corrupted word, a board with the drives on, another gateware and a board that reports
// another CRC are each named, and a refused or mismatched load is tried once more from frame 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "delta/controller/model_load.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/crc32.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/io/byte_stream.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"
#include "delta/link/session.hpp"
#include "support/line_time_board.hpp"
#include "support/tree_paths.hpp"

namespace delta {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
const std::string kOtherWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";

// A board in process, in line time: the host's bytes queue in its adapter and reach the board at
// the line's rate (one byte per 10 us at 1 Mbaud); they wait in the board's receive ring until it
// takes them, `byte_cost` byte times a byte (a model frame's bytes are taken slower than the line
// when byte_cost > 1); every 100 byte times (1 ms) it sends telemetry, and it answers identify
// requests. Its model rules are the spec's: frame 0 starts a load (no model from then), the next
// frame number is taken, any other is refused and counted, the commit ends the load with a model
// if and only if the CRC-32 of the words taken is the commit's; nothing is taken with the drives on.
class ScriptedBoard : public test::LineTimeBoard {
 public:
  double byte_cost = 1.0;                     // board byte times per received byte (model frames)
  bool drives_on = false;                     // every model frame refused
  std::optional<std::size_t> corrupt_byte;    // of the host's bytes (0-based): flipped on the line
  std::optional<std::uint16_t> corrupt_word;  // frame whose word is stored with a bit flipped (every load)
  std::optional<std::uint32_t> reported_crc;  // identify reports this instead of the checked CRC
  std::uint32_t build_id = kGatewareBuildId;
  int ms_before_each_write = 0;  // board time that passes before each write of the host reaches the line

  std::size_t ring_high_water = 0;  // the most bytes waiting in the ring (more than board::kRxRingBytes: overflowed)
  int loads_started = 0;            // frame 0 taken
  bool model = false;
  std::uint32_t model_crc = 0;

  void write_all(const std::uint8_t* data, std::size_t size, int) override {
    // A board faster than the host: board time runs before the host's bytes reach the line, its
    // telemetry piling up for the host.
    for (long steps = 0; steps < 100L * ms_before_each_write; ++steps) step();
    for (std::size_t i = 0; i < size; ++i, ++host_bytes_) {
      adapter_.push_back(corrupt_byte && *corrupt_byte == host_bytes_ ? static_cast<std::uint8_t>(data[i] ^ 0x10)
                                                                      : data[i]);
    }
  }

  void load_directly(const golden::QuantisedNetwork& q) {  // a board that had a model before
    model = true;
    model_crc = weights_crc(q);
  }

 private:
  // One byte time (10 us).
  void step() override {
    ++time_;
    if (!adapter_.empty()) {  // the line brings one byte
      ring_.push_back(adapter_.front());
      adapter_.pop_front();
      ring_high_water = std::max(ring_high_water, ring_.size());
    }
    budget_ += 1.0 / byte_cost;
    while (!ring_.empty() && budget_ >= 1.0) {  // the board takes bytes from its ring
      budget_ -= 1.0;
      const std::uint8_t byte = ring_.front();
      ring_.pop_front();
      for (const link::Frame& frame : decoder_.feed(&byte, 1)) take(frame);
    }
    if (ring_.empty()) budget_ = std::min(budget_, 1.0);
    if (time_ % 100 == 0) send_telemetry();
  }

  void take(const link::Frame& frame) {
    last_sequence_ = frame.sequence;
    if (frame.type == link::FrameType::kIdentifyRequest) {
      const link::IdentifyPayload identify = link::board_identify(build_id, reported_crc ? *reported_crc
                                                                            : model      ? model_crc
                                                                                         : 0);
      send(link::make_frame(frame.sequence, identify));
      return;
    }
    if (frame.type == link::FrameType::kCommand) {  // enable only: refused without a model
      if (link::decode_command(frame.payload) == link::Command::kEnable) {
        if (model) {
          drives_on = true;
        } else {
          ++rejected_;
        }
      }
      return;
    }
    if (frame.type != link::FrameType::kModel) return;
    const link::ModelPayload p = link::decode_model(frame.payload);
    if (drives_on) {
      ++rejected_;
      return;
    }
    if (p.frame == 0) {
      ++loads_started;
      model = false;
      model_crc = 0;
      words_.clear();
      loading_ = true;
    } else if (!loading_ || p.frame != words_.size()) {
      ++rejected_;
      return;
    }
    if (p.frame == board::kModelCommitFrame) {
      std::vector<std::uint8_t> bytes;
      for (const std::uint64_t w : words_) {
        for (int b = 0; b < 6; ++b) bytes.push_back(static_cast<std::uint8_t>(w >> (8 * b)));
      }
      loading_ = false;
      model = crc32(bytes) == static_cast<std::uint32_t>(p.value());
      model_crc = model ? static_cast<std::uint32_t>(p.value()) : 0;
      return;
    }
    words_.push_back(corrupt_word && *corrupt_word == p.frame ? p.value() ^ 1 : p.value());
  }

  void send_telemetry() {
    link::TelemetryPayload t;
    t.tick = static_cast<std::uint32_t>(time_ / 10);
    t.sequence = last_sequence_;
    t.rejected = rejected_;
    t.bad_frames = static_cast<std::uint16_t>(decoder_.dropped());
    t.set(link::TelemetryFlag::kDriveEnable, drives_on);
    t.set(link::TelemetryFlag::kModel, model);
    send(link::make_frame(telemetry_sequence_++, t));
  }
  std::deque<std::uint8_t> adapter_, ring_;
  link::FrameDecoder decoder_{link::Receiver::kBoard};
  std::size_t host_bytes_ = 0;
  long long time_ = 0;
  double budget_ = 0.0;
  std::uint8_t last_sequence_ = 0, telemetry_sequence_ = 0;
  std::uint16_t rejected_ = 0;
  std::vector<std::uint64_t> words_;
  bool loading_ = false;
};

golden::QuantisedNetwork network(const std::string& path) { return golden::read_board_weights(path).network; }

struct Loading {
  ScriptedBoard board;
  link::LinkSession session{board, [] {
                              link::SessionOptions options;
                              options.frame_timeout_ms = 200;
                              return options;
                            }()};
};

TEST(ModelLoad, PacedByTheBoardsAcceptanceTheRingNeverOverflowsOnABoardSlowerThanTheLine) {
  const golden::QuantisedNetwork q = network(kWeights);
  const std::vector<link::ModelPayload> frames = golden::model_frames(q);
  for (const double cost : {1.0, 3.0, 10.0}) {
    Loading l;
    l.board.byte_cost = cost;
    const link::ModelLoadReport report = l.session.load_model(frames);
    EXPECT_TRUE(report.loaded) << "byte cost " << cost << ": " << report.problem;
    EXPECT_EQ(report.taken, frames.size());
    EXPECT_EQ(report.sent, frames.size());
    EXPECT_FALSE(report.refused_frame);
    EXPECT_TRUE(l.board.model);
    EXPECT_EQ(l.board.model_crc, weights_crc(q));
    EXPECT_TRUE(report.telemetry.has(link::TelemetryFlag::kModel));
    // The window: half the ring, whatever the board's speed.
    EXPECT_LE(l.board.ring_high_water, link::kModelLoadWindowBytes) << "byte cost " << cost;
    std::cout << "byte cost " << cost << ": ring high water " << l.board.ring_high_water << " bytes\n";
  }
}

TEST(ModelLoad, TelemetryThatPiledUpWhileTheHostWroteIsNoStall) {
  // The virtual board running free makes 25 ms of board time (25 telemetry frames, more than the
  // 20 a stall waits) before each write of the host reaches it: only the newest frame counts.
  const golden::QuantisedNetwork q = network(kWeights);
  Loading l;
  l.board.ms_before_each_write = 25;
  const link::ModelLoadReport report = l.session.load_model(golden::model_frames(q));
  EXPECT_TRUE(report.loaded) << report.problem;
  EXPECT_EQ(report.sent, static_cast<std::size_t>(board::kModelFrames));
  EXPECT_EQ(l.board.model_crc, weights_crc(q));
}

TEST(ModelLoad, WithoutPacingTheSlowBoardsRingWouldOverflow) {
  // The property the pacing buys: the whole load written at once overruns a board 3x slower than
  // the line (the scripted board's ring check fails), so the window is what keeps it.
  const std::vector<link::ModelPayload> frames = golden::model_frames(network(kWeights));
  ScriptedBoard board;
  board.byte_cost = 3.0;
  std::size_t bytes = 0;
  std::uint8_t sequence = 0;
  for (const link::ModelPayload& frame : frames) {
    const std::vector<std::uint8_t> encoded = link::encode_frame(link::make_frame(sequence++, frame));
    board.write_all(encoded.data(), encoded.size(), 100);
    bytes += encoded.size();
  }
  EXPECT_GT(bytes, static_cast<std::size_t>(board::kRxRingBytes));
  for (int ms = 0; ms < 100; ++ms) {  // 100 ms of board time: the line brings every byte in 26 ms
    board.wait_readable(1);
    std::uint8_t sink[512];
    board.read_some(sink, sizeof sink);
  }
  EXPECT_GT(board.ring_high_water, static_cast<std::size_t>(board::kRxRingBytes));
}

TEST(ModelLoad, AFrameLostOnTheLineNamesTheFirstRefusedFrameAndTheRetryFromFrameZeroLoads) {
  const golden::QuantisedNetwork q = network(kWeights);
  const std::vector<link::ModelPayload> frames = golden::model_frames(q);
  Loading l;
  const controller::Connected c = controller::connect_board(l.session);
  const std::size_t frame_bytes = link::encode_frame(link::make_frame(0, frames[0])).size();
  // A byte of model frame 40 flipped on the line (the identify request went before: 6 bytes).
  l.board.corrupt_byte = link::encode_frame(link::make_identify_request(0)).size() + 40 * frame_bytes + 7;
  const controller::ModelLoaded loaded = controller::load_board_model(l.session, c, q, "scripted-board");
  std::cout << "first attempt: " << loaded.retry_reason << '\n';
  EXPECT_EQ(loaded.attempts, 2);
  EXPECT_NE(loaded.retry_reason.find("the board refused model frame 41"), std::string::npos) << loaded.retry_reason;
  EXPECT_NE(loaded.retry_reason.find("frames lost on the line: 1"), std::string::npos) << loaded.retry_reason;
  EXPECT_EQ(loaded.crc, weights_crc(q));
  EXPECT_GT(loaded.frames, frames.size());
  EXPECT_EQ(l.board.loads_started, 2);
  EXPECT_TRUE(l.board.model);
  EXPECT_EQ(l.board.model_crc, weights_crc(q));
}

TEST(ModelLoad, WithTheDrivesOnEveryFrameIsRefusedAndTheBoardKeepsItsModel) {
  const golden::QuantisedNetwork q = network(kWeights);
  const golden::QuantisedNetwork other = network(kOtherWeights);
  ASSERT_NE(weights_crc(q), weights_crc(other));
  {
    Loading l;
    l.board.load_directly(other);
    l.board.drives_on = true;
    const link::ModelLoadReport report = l.session.load_model(golden::model_frames(q));
    EXPECT_FALSE(report.loaded);
    ASSERT_TRUE(report.refused_frame);
    EXPECT_EQ(*report.refused_frame, 0);
    EXPECT_NE(report.problem.find("a model is taken only with the drives off"), std::string::npos) << report.problem;
    EXPECT_TRUE(l.board.model);
    EXPECT_EQ(l.board.model_crc, weights_crc(other));
    EXPECT_EQ(l.board.loads_started, 0);
  }
  {
    // load_board_model sends nothing to a board whose drives are on: exit 3.
    Loading l;
    l.board.load_directly(other);
    l.board.drives_on = true;
    const controller::Connected c = controller::connect_board(l.session);
    try {
      controller::load_board_model(l.session, c, q, "scripted-board");
      ADD_FAILURE() << "loaded with the drives on";
    } catch (const controller::HostFailure& error) {
      EXPECT_EQ(error.code(), controller::kExitFault);
      EXPECT_NE(std::string(error.what()).find("the drives are on: disable first"), std::string::npos) << error.what();
    }
    EXPECT_EQ(l.board.loads_started, 0);
    EXPECT_EQ(l.board.model_crc, weights_crc(other));
  }
}

TEST(ModelLoad, ACorruptedWordLeavesNoModelAndFailsTwiceNamingIt) {
  const golden::QuantisedNetwork q = network(kWeights);
  Loading l;
  l.board.corrupt_word = 100;  // the board stores LW'_00 with a bit flipped: its CRC differs, every time
  const controller::Connected c = controller::connect_board(l.session);
  try {
    controller::load_board_model(l.session, c, q, "scripted-board");
    ADD_FAILURE() << "a corrupted load was taken";
  } catch (const controller::HostFailure& error) {
    const std::string what = error.what();
    std::cout << what << '\n';
    EXPECT_EQ(error.code(), controller::kExitFault);
    EXPECT_NE(what.find("twice from frame 0"), std::string::npos) << what;
    EXPECT_NE(what.find("shows no model"), std::string::npos) << what;
    EXPECT_NE(what.find("the board has no model now"), std::string::npos) << what;
  }
  EXPECT_EQ(l.board.loads_started, 2);
  EXPECT_FALSE(l.board.model);
}

TEST(ModelLoad, ABoardReportingAnotherCrcIsAMismatchNamingBoth) {
  const golden::QuantisedNetwork q = network(kWeights);
  Loading l;
  l.board.reported_crc = 0x12345678;
  const controller::Connected c = controller::connect_board(l.session);
  try {
    controller::load_board_model(l.session, c, q, "scripted-board");
    ADD_FAILURE() << "a mismatched CRC was taken";
  } catch (const controller::HostFailure& error) {
    const std::string what = error.what();
    EXPECT_EQ(error.code(), controller::kExitFault);
    EXPECT_NE(what.find("the board reports model CRC 12345678, the file's is " + golden::hex_word(weights_crc(q), 32)),
              std::string::npos)
        << what;
  }
  EXPECT_EQ(l.board.loads_started, 2);
}

TEST(ModelLoad, AnotherGatewareIsExitFiveNamingBothAndNothingIsSent) {
  const golden::QuantisedNetwork q = network(kWeights);
  Loading l;
  l.board.build_id = kGatewareBuildId ^ 0xFFu;
  const controller::Connected c = controller::connect_board(l.session);
  try {
    controller::load_board_model(l.session, c, q, "scripted-board");
    ADD_FAILURE() << "loaded onto another gateware";
  } catch (const controller::HostFailure& error) {
    const std::string what = error.what();
    EXPECT_EQ(error.code(), controller::kExitMismatch);
    EXPECT_NE(what.find(golden::hex_word(kGatewareBuildId ^ 0xFFu, 32)), std::string::npos) << what;
    EXPECT_NE(what.find(golden::hex_word(kGatewareBuildId, 32)), std::string::npos) << what;
  }
  EXPECT_EQ(l.board.loads_started, 0);
}

TEST(ModelLoad, TheRunsCheckNamesNoModelAnotherModelAndTheLoadCommand) {
  const golden::BoardWeights weights = golden::read_board_weights(kWeights);
  const golden::QuantisedNetwork other = network(kOtherWeights);
  controller::Connected c;
  c.identify = link::board_identify(kGatewareBuildId, 0);
  auto refusal = [&] {
    try {
      controller::check_board_identity(c, weights, "W.json", "/dev/ttyX");
    } catch (const controller::HostFailure& error) {
      EXPECT_EQ(error.code(), controller::kExitMismatch);
      return std::string(error.what());
    }
    return std::string();
  };
  EXPECT_NE(refusal().find("the board has no model"), std::string::npos) << refusal();
  EXPECT_NE(refusal().find("deltactl host load --port /dev/ttyX --weights W.json"), std::string::npos) << refusal();
  c.telemetry.set(link::TelemetryFlag::kModel, true);
  c.identify.weights_crc = weights_crc(other);
  EXPECT_NE(refusal().find("another model (CRC " + golden::hex_word(weights_crc(other), 32) + ")"), std::string::npos)
      << refusal();
  EXPECT_NE(refusal().find("deltactl host load --port /dev/ttyX --weights W.json"), std::string::npos) << refusal();
  c.identify.weights_crc = weights_crc(weights.network);
  EXPECT_EQ(refusal(), "");
}

TEST(ModelLoad, AnEnableRefusedForWantOfAModelSaysSoAndNamesHostLoad) {
  Loading l;
  try {
    l.session.enable();
    ADD_FAILURE() << "enabled without a model";
  } catch (const link::LinkError& error) {
    const std::string what = error.what();
    EXPECT_EQ(error.kind(), link::LinkError::Kind::kRefused);
    EXPECT_NE(what.find("the board refused the enable: it has no model"), std::string::npos) << what;
    EXPECT_NE(what.find("deltactl host load --port scripted-board --weights W.json"), std::string::npos) << what;
  }
  l.board.load_directly(network(kWeights));
  EXPECT_TRUE(l.session.enable().has(link::TelemetryFlag::kDriveEnable));
}

}  // namespace
}  // namespace delta
