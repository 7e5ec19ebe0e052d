// The frame codec of the board link v2 (docs/board_link.md): a pair of pure functions, encode a
// frame and feed bytes to a decoder that yields whole checked frames and counts what it dropped.
// No device, no clock: testable alone, and the same layout the RTL will use (every constant comes
// from rtl/board/delta_board_pkg.sv through delta/board_facts.hpp).
//
// Frame: sync, length (payload bytes), sequence, type, payload, CRC-16 high byte, low byte. The
// CRC (CCITT-FALSE: polynomial 0x1021, initial 0xFFFF, no reflection) covers length..payload.
// A frame is accepted only if its type is known and its length is that type's payload size;
// anything else is dropped, counted by reason, and the decoder looks for the next sync after the
// dropped frame's sync byte (so a sync byte inside a corrupted frame is found again).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "delta/board_facts.hpp"

namespace delta::link {

constexpr std::uint8_t kSync = board::kFrameSync;
constexpr std::size_t kHeaderBytes = board::kFrameHeaderBytes;
constexpr std::size_t kCrcBytes = board::kFrameCrcBytes;
constexpr std::size_t kMaxPayloadBytes = board::kFrameMaxPayloadBytes;
constexpr std::size_t kMaxFrameBytes = kHeaderBytes + kMaxPayloadBytes + kCrcBytes;

enum class FrameType : std::uint8_t {
  kIdentifyRequest = board::kFrameTypeIdentifyRequest,
  kSetpoint = board::kFrameTypeSetpoint,
  kCommand = board::kFrameTypeCommand,
  kIdentify = board::kFrameTypeIdentify,
  kTelemetry = board::kFrameTypeTelemetry,
};

// The payload size of a known type, or nothing for an unknown type byte.
std::optional<std::size_t> payload_bytes(std::uint8_t type);

std::uint16_t crc16(const std::uint8_t* data, std::size_t size, std::uint16_t crc = board::kFrameCrcInit);

struct Frame {
  std::uint8_t sequence = 0;
  FrameType type = FrameType::kIdentifyRequest;
  std::vector<std::uint8_t> payload;
};

// The bytes of a frame. Throws std::invalid_argument when the payload is not the type's size.
std::vector<std::uint8_t> encode_frame(const Frame& frame);

struct DecoderCounters {
  std::uint64_t frames = 0;         // accepted
  std::uint64_t bad_crc = 0;        // dropped: CRC mismatch
  std::uint64_t bad_length = 0;     // dropped: length not the type's payload size (also oversized)
  std::uint64_t unknown_type = 0;   // dropped: a type byte the link does not define
  std::uint64_t skipped_bytes = 0;  // bytes outside any frame while hunting for a sync
};

class FrameDecoder {
 public:
  // Feeds bytes; returns every checked frame they completed, in order (a drop can release more
  // than one: the bytes after the dropped frame's sync are scanned again).
  std::vector<Frame> feed(const std::uint8_t* data, std::size_t size);
  std::vector<Frame> feed(const std::vector<std::uint8_t>& bytes) { return feed(bytes.data(), bytes.size()); }
  const DecoderCounters& counters() const { return counters_; }
  std::uint64_t dropped() const { return counters_.bad_crc + counters_.bad_length + counters_.unknown_type; }

 private:
  // Drops the frame being assembled and rescans the bytes after its sync for the next one.
  void drop_and_rescan(std::uint64_t DecoderCounters::*reason, std::vector<Frame>& frames);
  void accept_byte(std::uint8_t byte, std::vector<Frame>& frames);

  std::vector<std::uint8_t> buffer_;  // from the sync byte on
  std::size_t expected_ = 0;          // whole frame size once the header is in
  DecoderCounters counters_;
};

}  // namespace delta::link
