// The frame codec of the board link v2 (docs/board_link.md): a pair of pure functions, encode a
// frame and feed bytes to a decoder that yields whole checked frames and counts what it dropped.
// No device, no clock: testable alone, and the same layout the RTL will use (every constant comes
// from rtl/board/delta_board_pkg.sv through delta/board_facts.hpp).
//
// Frame: sync, length (payload bytes), sequence, type, payload, CRC-16 high byte, low byte. The
// CRC (CCITT-FALSE: polynomial 0x1021, initial 0xFFFF, no reflection) covers length..payload.
// A decoder belongs to one receiver (the board or the host) and accepts only the frame types sent
// to it; the precise rule, which the RTL decoder mirrors byte for byte, is at FrameDecoder.
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
  kModel = board::kFrameTypeModel,
  kIdentify = board::kFrameTypeIdentify,
  kTelemetry = board::kFrameTypeTelemetry,
};

// The payload size of a known type, or nothing for an unknown type byte.
std::optional<std::size_t> payload_bytes(std::uint8_t type);

// Which end of the link a decoder is: the board takes 0x01, 0x02, 0x03 (host -> board), the host
// 0x81, 0x82 (board -> host).
enum class Receiver { kBoard, kHost };

// The payload size of a type `receiver` takes, or nothing for any other type byte (unknown ones
// and those of the other direction alike).
std::optional<std::size_t> payload_bytes(Receiver receiver, std::uint8_t type);

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
  std::uint64_t unknown_type = 0;   // dropped: a type byte this receiver does not take (incl. the other direction's)
  std::uint64_t skipped_bytes = 0;  // bytes outside any frame while hunting for a sync
};

// The decoder's rule (the RTL decoder, rtl/board/link_*.sv, implements exactly this; BoardLink.*
// feeds both the same bytes):
//   1. Hunting: a byte other than kSync is skipped (skipped_bytes + 1); kSync starts a candidate.
//   2. When the candidate's 4th byte (the type) is in, in this order:
//      a. type not taken by this receiver (payload_bytes(receiver, type) empty): drop, unknown_type;
//      b. length byte != that type's payload size (or > kMaxPayloadBytes): drop, bad_length.
//      The length byte is therefore checked only for a type the receiver takes.
//   3. Otherwise the candidate completes after 4 + length + 2 bytes; CRC-16 over bytes 1 .. 3+length
//      (length, sequence, type, payload) against the last two (high byte first): equal -> the frame
//      is accepted (frames + 1) and the decoder hunts again from the next byte; not equal -> drop,
//      bad_crc.
//   4. A drop counts one reason, discards the candidate's sync byte only, and feeds the candidate's
//      remaining bytes (everything after that sync, up to the byte that caused the drop, inclusive)
//      through this same rule again, in order, before any newer byte: a sync among them starts a new
//      candidate (which may complete, or be dropped and rescanned in turn), the others count as
//      skipped bytes. At most kMaxFrameBytes - 1 bytes are rescanned per drop.
class FrameDecoder {
 public:
  explicit FrameDecoder(Receiver receiver) : receiver_(receiver) {}
  Receiver receiver() const { return receiver_; }
  // Feeds bytes; returns every checked frame they completed, in order (a drop can release more
  // than one: the bytes after the dropped frame's sync are scanned again).
  std::vector<Frame> feed(const std::uint8_t* data, std::size_t size);
  std::vector<Frame> feed(const std::vector<std::uint8_t>& bytes) { return feed(bytes.data(), bytes.size()); }
  const DecoderCounters& counters() const { return counters_; }
  // Bytes the decoder needs before it can complete or drop a frame: the rest of the header, then
  // the rest of the frame (1 between frames).
  std::size_t bytes_to_decide() const;
  std::uint64_t dropped() const { return counters_.bad_crc + counters_.bad_length + counters_.unknown_type; }

 private:
  // Drops the frame being assembled and rescans the bytes after its sync for the next one.
  void drop_and_rescan(std::uint64_t DecoderCounters::*reason, std::vector<Frame>& frames);
  void accept_byte(std::uint8_t byte, std::vector<Frame>& frames);

  Receiver receiver_;
  std::vector<std::uint8_t> buffer_;  // from the sync byte on
  std::size_t expected_ = 0;          // whole frame size once the header is in
  DecoderCounters counters_;
};

}  // namespace delta::link
