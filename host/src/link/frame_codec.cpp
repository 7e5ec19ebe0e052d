// The frame codec of the board link v2 (see frame_codec.hpp).
#include "delta/link/frame_codec.hpp"

#include <array>
#include <stdexcept>
#include <string>

namespace delta::link {

std::optional<std::size_t> payload_bytes(std::uint8_t type) {
  switch (type) {
    case board::kFrameTypeIdentifyRequest:
      return 0;
    case board::kFrameTypeSetpoint:
      return board::kSetpointPayloadBytes;
    case board::kFrameTypeCommand:
      return board::kCommandPayloadBytes;
    case board::kFrameTypeModel:
      return board::kModelPayloadBytes;
    case board::kFrameTypeIdentify:
      return board::kIdentifyPayloadBytes;
    case board::kFrameTypeTelemetry:
      return board::kTelemetryPayloadBytes;
    default:
      return std::nullopt;
  }
}

std::optional<std::size_t> payload_bytes(Receiver receiver, std::uint8_t type) {
  switch (type) {
    case board::kFrameTypeIdentifyRequest:
    case board::kFrameTypeSetpoint:
    case board::kFrameTypeCommand:
    case board::kFrameTypeModel:
      return receiver == Receiver::kBoard ? payload_bytes(type) : std::nullopt;
    case board::kFrameTypeIdentify:
    case board::kFrameTypeTelemetry:
      return receiver == Receiver::kHost ? payload_bytes(type) : std::nullopt;
    default:
      return std::nullopt;
  }
}

namespace {

// The CRC of each byte value from a zero register: the polynomial's eight shifts, a byte at once.
struct Crc16Table {
  std::array<std::uint16_t, 256> entry{};
  constexpr Crc16Table() {
    for (int value = 0; value < 256; ++value) {
      auto crc = static_cast<std::uint16_t>(value << 8);
      for (int bit = 0; bit < 8; ++bit) {
        crc = (crc & 0x8000) ? static_cast<std::uint16_t>((crc << 1) ^ board::kFrameCrcPolynomial)
                             : static_cast<std::uint16_t>(crc << 1);
      }
      entry[static_cast<std::size_t>(value)] = crc;
    }
  }
};
constexpr Crc16Table kCrc16Table;

}  // namespace

std::uint16_t crc16(const std::uint8_t* data, std::size_t size, std::uint16_t crc) {
  for (std::size_t i = 0; i < size; ++i) {
    crc = static_cast<std::uint16_t>((crc << 8) ^ kCrc16Table.entry[((crc >> 8) ^ data[i]) & 0xFF]);
  }
  return crc;
}

std::vector<std::uint8_t> encode_frame(const Frame& frame) {
  const auto size = payload_bytes(static_cast<std::uint8_t>(frame.type));
  if (!size || *size != frame.payload.size()) {
    throw std::invalid_argument("link frame of type " + std::to_string(static_cast<int>(frame.type)) + " with " +
                                std::to_string(frame.payload.size()) + " payload bytes");
  }
  std::vector<std::uint8_t> bytes;
  bytes.reserve(kHeaderBytes + frame.payload.size() + kCrcBytes);
  for (std::uint8_t header : {kSync, static_cast<std::uint8_t>(frame.payload.size()), frame.sequence,
                              static_cast<std::uint8_t>(frame.type)}) {
    bytes.push_back(header);
  }
  bytes.insert(bytes.end(), frame.payload.begin(), frame.payload.end());
  const std::uint16_t crc = crc16(bytes.data() + 1, bytes.size() - 1);
  bytes.push_back(static_cast<std::uint8_t>(crc >> 8));
  bytes.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  return bytes;
}

std::vector<Frame> FrameDecoder::feed(const std::uint8_t* data, std::size_t size) {
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < size; ++i) accept_byte(data[i], frames);
  return frames;
}

std::size_t FrameDecoder::bytes_to_decide() const {
  if (buffer_.empty()) return 1;
  return (expected_ != 0 ? expected_ : kHeaderBytes) - buffer_.size();
}

void FrameDecoder::accept_byte(std::uint8_t byte, std::vector<Frame>& frames) {
  if (buffer_.empty()) {
    if (byte == kSync) {
      buffer_.push_back(byte);
      expected_ = 0;
    } else {
      ++counters_.skipped_bytes;
    }
    return;
  }
  buffer_.push_back(byte);
  if (buffer_.size() == kHeaderBytes) {
    const std::size_t length = buffer_[1];
    const auto size = payload_bytes(receiver_, buffer_[3]);
    if (!size) return drop_and_rescan(&DecoderCounters::unknown_type, frames);
    if (length != *size || length > kMaxPayloadBytes) return drop_and_rescan(&DecoderCounters::bad_length, frames);
    expected_ = kHeaderBytes + length + kCrcBytes;
  }
  if (expected_ == 0 || buffer_.size() < expected_) return;
  const std::uint16_t crc = crc16(buffer_.data() + 1, expected_ - 1 - kCrcBytes);
  const auto received = static_cast<std::uint16_t>(buffer_[expected_ - 2] << 8 | buffer_[expected_ - 1]);
  if (crc != received) return drop_and_rescan(&DecoderCounters::bad_crc, frames);
  Frame frame;
  frame.sequence = buffer_[2];
  frame.type = static_cast<FrameType>(buffer_[3]);
  frame.payload.assign(buffer_.begin() + kHeaderBytes,
                       buffer_.begin() + static_cast<std::ptrdiff_t>(expected_ - kCrcBytes));
  buffer_.clear();
  expected_ = 0;
  ++counters_.frames;
  frames.push_back(std::move(frame));
}

void FrameDecoder::drop_and_rescan(std::uint64_t DecoderCounters::*reason, std::vector<Frame>& frames) {
  ++(counters_.*reason);
  // The bytes after the dropped frame's sync may hold the next frame's start (or whole frames).
  const std::vector<std::uint8_t> rest(buffer_.begin() + 1, buffer_.end());
  buffer_.clear();
  expected_ = 0;
  for (std::uint8_t byte : rest) accept_byte(byte, frames);
}

}  // namespace delta::link
