// The board link v2 frame codec (host/include/delta/link/frame_codec.hpp): the CRC's check value,
// round trips of every frame type through a stream with noise between frames, every single-bit
// corruption dropped and counted with the next frame still found, truncation, unknown types, the
// other direction's types and wrong lengths, and random bytes; each for the board's and the host's
// decoder.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <iostream>
#include <random>
#include <vector>

#include "delta/link/frame_codec.hpp"

namespace delta::link {
namespace {

constexpr FrameType kBoardTypes[] = {FrameType::kIdentifyRequest, FrameType::kSetpoint, FrameType::kCommand};
constexpr FrameType kHostTypes[] = {FrameType::kIdentify, FrameType::kTelemetry};
constexpr Receiver kReceivers[] = {Receiver::kBoard, Receiver::kHost};

const char* name(Receiver receiver) { return receiver == Receiver::kBoard ? "board" : "host"; }

// A frame of a type `receiver` takes.
Frame random_frame(std::mt19937_64& random, Receiver receiver) {
  Frame frame;
  frame.type = receiver == Receiver::kBoard ? kBoardTypes[random() % 3] : kHostTypes[random() % 2];
  frame.sequence = static_cast<std::uint8_t>(random());
  frame.payload.resize(*payload_bytes(static_cast<std::uint8_t>(frame.type)));
  for (auto& byte : frame.payload) byte = static_cast<std::uint8_t>(random());
  return frame;
}

bool same(const Frame& a, const Frame& b) {
  return a.sequence == b.sequence && a.type == b.type && a.payload == b.payload;
}

TEST(FrameCodec, CrcIsCcittFalse) {
  const char* check = "123456789";
  EXPECT_EQ(crc16(reinterpret_cast<const std::uint8_t*>(check), std::strlen(check)),
            0x29B1);  // the catalogue's check value
}

TEST(FrameCodec, EveryFrameTypeRoundTripsThroughAStreamWithNoiseBetweenFrames) {
  for (Receiver receiver : kReceivers) {
    const std::uint64_t seed = 20261123;
    std::cout << name(receiver) << " seed " << seed << "\n";
    std::mt19937_64 random(seed);
    std::vector<Frame> sent;
    std::vector<std::uint8_t> stream;
    std::size_t noise = 0;
    for (int i = 0; i < 2000; ++i) {
      const int gap = static_cast<int>(random() % 4);
      for (int g = 0; g < gap; ++g) {
        std::uint8_t byte = static_cast<std::uint8_t>(random());
        if (byte == kSync) byte ^= 1;  // noise without sync bytes: no chance frame
        stream.push_back(byte);
        ++noise;
      }
      sent.push_back(random_frame(random, receiver));
      const std::vector<std::uint8_t> bytes = encode_frame(sent.back());
      stream.insert(stream.end(), bytes.begin(), bytes.end());
    }
    FrameDecoder decoder(receiver);
    std::vector<Frame> received;
    for (std::size_t i = 0; i < stream.size(); i += 7) {  // arbitrary chunks, as a serial port delivers
      const auto frames = decoder.feed(stream.data() + i, std::min<std::size_t>(7, stream.size() - i));
      received.insert(received.end(), frames.begin(), frames.end());
    }
    ASSERT_EQ(received.size(), sent.size()) << name(receiver);
    for (std::size_t i = 0; i < sent.size(); ++i) ASSERT_TRUE(same(received[i], sent[i])) << "frame " << i;
    EXPECT_EQ(decoder.dropped(), 0u);
    EXPECT_EQ(decoder.counters().skipped_bytes, noise);
  }
}

TEST(FrameCodec, EverySingleBitCorruptionIsDroppedAndTheNextFrameStillArrives) {
  for (Receiver receiver : kReceivers) {
    std::mt19937_64 random(7);
    std::size_t corrupted_frames = 0;
    for (int trial = 0; trial < 50; ++trial) {
      const Frame frame = random_frame(random, receiver), next = random_frame(random, receiver);
      const std::vector<std::uint8_t> bytes = encode_frame(frame), next_bytes = encode_frame(next);
      for (std::size_t bit = 0; bit < 8 * bytes.size(); ++bit) {
        std::vector<std::uint8_t> stream = bytes;
        stream[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
        stream.insert(stream.end(), next_bytes.begin(), next_bytes.end());
        FrameDecoder decoder(receiver);
        const std::vector<Frame> frames = decoder.feed(stream);
        ASSERT_EQ(frames.size(), 1u) << name(receiver) << " trial " << trial << " bit " << bit;
        ASSERT_TRUE(same(frames[0], next)) << name(receiver) << " trial " << trial << " bit " << bit;
        // Counted: a dropped frame, or (sync bit hit) the whole corrupted frame skipped as noise.
        ASSERT_TRUE(decoder.dropped() >= 1 || decoder.counters().skipped_bytes >= 1);
        ++corrupted_frames;
      }
    }
    std::cout << name(receiver) << ": " << corrupted_frames << " corrupted frames, none accepted\n";
  }
}

TEST(FrameCodec, TruncatedFrameIsDroppedAndTheDecoderResynchronises) {
  for (Receiver receiver : kReceivers) {
    std::mt19937_64 random(3);
    for (int trial = 0; trial < 200; ++trial) {
      const Frame cut = random_frame(random, receiver), next = random_frame(random, receiver);
      const std::vector<std::uint8_t> whole = encode_frame(cut);
      std::vector<std::uint8_t> stream = whole;
      stream.resize(1 + random() % (stream.size() - 1));  // cut after the sync, before the end
      const std::vector<std::uint8_t> next_bytes = encode_frame(next);
      stream.insert(stream.end(), next_bytes.begin(), next_bytes.end());
      // Not a truncation when the next bytes happen to be the missing ones (e.g. a CRC low byte 0x7E).
      if (stream.size() >= whole.size() && std::equal(whole.begin(), whole.end(), stream.begin())) continue;
      FrameDecoder decoder(receiver);
      std::vector<Frame> frames = decoder.feed(stream);
      // The next frame may be swallowed by the cut one's length: the cut frame is dropped once
      // its length is in (its CRC fails), and what follows is found again. The link streams, so
      // more frames follow; within one maximal frame's worth of bytes one must come out.
      std::size_t extra = 0;
      while (frames.empty() && extra <= kMaxFrameBytes) {
        for (const Frame& frame : decoder.feed(next_bytes)) frames.push_back(frame);
        extra += next_bytes.size();
      }
      ASSERT_GE(frames.size(), 1u) << name(receiver) << " trial " << trial;
      for (const Frame& frame : frames) ASSERT_TRUE(same(frame, next)) << name(receiver) << " trial " << trial;
      ASSERT_GE(decoder.dropped(), 1u) << name(receiver) << " trial " << trial;
    }
  }
}

TEST(FrameCodec, UnknownTypesAndWrongLengthsAreDroppedByReason) {
  FrameDecoder decoder(Receiver::kHost);
  std::vector<std::uint8_t> unknown = {kSync, 0, 0, 0x55, 0, 0};
  EXPECT_TRUE(decoder.feed(unknown).empty());
  EXPECT_EQ(decoder.counters().unknown_type, 1u);
  std::vector<std::uint8_t> oversized = {kSync, 200, 0, static_cast<std::uint8_t>(FrameType::kTelemetry)};
  EXPECT_TRUE(decoder.feed(oversized).empty());
  EXPECT_EQ(decoder.counters().bad_length, 1u);
  Frame command;
  command.type = FrameType::kCommand;
  command.payload = {1, 2};  // the command payload is one byte
  EXPECT_THROW(encode_frame(command), std::invalid_argument);
}

TEST(FrameCodec, EachReceiverTakesOnlyItsDirectionsTypesAndCountsTheOthersAsUnknown) {
  std::mt19937_64 random(11);
  for (Receiver receiver : kReceivers) {
    const Receiver other = receiver == Receiver::kBoard ? Receiver::kHost : Receiver::kBoard;
    for (int trial = 0; trial < 100; ++trial) {
      // A valid frame of the other direction (right length, right CRC), then one of this one's.
      const Frame foreign = random_frame(random, other), own = random_frame(random, receiver);
      EXPECT_FALSE(payload_bytes(receiver, static_cast<std::uint8_t>(foreign.type)).has_value());
      EXPECT_EQ(payload_bytes(receiver, static_cast<std::uint8_t>(own.type)),
                payload_bytes(static_cast<std::uint8_t>(own.type)));
      std::vector<std::uint8_t> stream = encode_frame(foreign);
      const std::vector<std::uint8_t> own_bytes = encode_frame(own);
      stream.insert(stream.end(), own_bytes.begin(), own_bytes.end());
      FrameDecoder decoder(receiver);
      const std::vector<Frame> frames = decoder.feed(stream);
      ASSERT_GE(frames.size(), 1u) << name(receiver) << " trial " << trial;
      ASSERT_TRUE(same(frames.back(), own)) << name(receiver) << " trial " << trial;
      for (const Frame& frame : frames) {
        ASSERT_TRUE(payload_bytes(receiver, static_cast<std::uint8_t>(frame.type)).has_value());
      }
      // Dropped at its type byte (never its length or CRC); its payload bytes rescanned, never acted on.
      EXPECT_GE(decoder.counters().unknown_type, 1u);
      EXPECT_EQ(decoder.counters().bad_crc + decoder.counters().bad_length + decoder.counters().unknown_type,
                decoder.dropped());
    }
  }
  // The type decides before the length: a foreign type with a wrong length is unknown_type.
  FrameDecoder board(Receiver::kBoard);
  EXPECT_TRUE(board.feed({kSync, 200, 0, static_cast<std::uint8_t>(FrameType::kTelemetry)}).empty());
  EXPECT_EQ(board.counters().unknown_type, 1u);
  EXPECT_EQ(board.counters().bad_length, 0u);
}

TEST(FrameCodec, RandomBytesYieldOnlyFramesWithAValidCrc) {
  for (Receiver receiver : kReceivers) {
    const std::uint64_t seed = 99;
    std::cout << name(receiver) << " seed " << seed << "\n";
    std::mt19937_64 random(seed);
    std::vector<std::uint8_t> noise(100000);
    for (auto& byte : noise) byte = static_cast<std::uint8_t>(random() % 16 == 0 ? kSync : random());
    FrameDecoder decoder(receiver);
    const std::vector<Frame> frames = decoder.feed(noise);
    for (const Frame& frame : frames) {
      ASSERT_TRUE(payload_bytes(receiver, static_cast<std::uint8_t>(frame.type)).has_value());
      const std::vector<std::uint8_t> bytes = encode_frame(frame);  // re-encodes: type and length valid
      EXPECT_EQ(bytes.size(), kHeaderBytes + frame.payload.size() + kCrcBytes);
    }
    std::cout << name(receiver) << ": " << frames.size()
              << " chance frames in 1e5 random bytes (CRC-16: about 1 in 65536 candidates), " << decoder.dropped()
              << " dropped\n";
    EXPECT_LT(frames.size(), 5u);
    EXPECT_GT(decoder.dropped(), 1000u);
  }
}

}  // namespace
}  // namespace delta::link
