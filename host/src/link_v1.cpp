// Host side of the board's first link (see link_v1.hpp).
#include "delta/link_v1.hpp"

namespace delta::link_v1 {

std::vector<std::uint8_t> request_frame(const std::array<std::int64_t, 3>& codes, std::uint8_t checksum_error) {
  std::vector<std::uint8_t> frame = {kRequestSync};
  std::uint8_t sum = 0;
  for (std::int64_t code : codes) {
    for (int b = 0; b < kRequestCodeBytes; ++b) {
      const auto byte = static_cast<std::uint8_t>((static_cast<std::uint64_t>(code) >> (8 * b)) & 0xFF);
      frame.push_back(byte);
      sum += byte;
    }
  }
  frame.push_back(static_cast<std::uint8_t>(-sum + checksum_error));
  return frame;
}

std::optional<std::array<std::int64_t, 3>> parse_answer(const std::vector<std::uint8_t>& answer) {
  if (answer.size() != kAnswerBytes || answer[0] != kAnswerSync) return std::nullopt;
  std::uint8_t sum = answer[kAnswerBytes - 1];
  std::array<std::int64_t, 3> codes{};
  constexpr int kUnusedBits = 32 - 8 * kAnswerCodeBytes;
  for (int o = 0; o < 3; ++o) {
    std::uint32_t raw = 0;
    for (int b = 0; b < kAnswerCodeBytes; ++b) {
      raw |= static_cast<std::uint32_t>(answer[1 + kAnswerCodeBytes * o + b]) << (8 * b);
      sum += answer[1 + kAnswerCodeBytes * o + b];
    }
    codes[o] = static_cast<std::int32_t>(raw << kUnusedBits) >> kUnusedBits;  // sign-extended
  }
  if (sum != 0) return std::nullopt;
  return codes;
}

std::vector<std::uint8_t> LinkV1Client::request(const std::array<std::int64_t, 3>& codes) {
  awaiting_ = true;
  silent_units_ = 0;
  return request_frame(codes);
}

void LinkV1Client::receive(std::uint8_t byte) {
  received_.push_back(byte);
  silent_units_ = 0;
}

bool LinkV1Client::elapse() {
  if (!awaiting_) return false;
  ++silent_units_;
  const bool complete = (received_.size() >= kAnswerBytes && received_[0] == kAnswerSync) ||
                        (received_.size() == 1 && received_[0] == kNak && silent_units_ > 20L * units_per_bit_);
  if (!complete && silent_units_ < 4000L * units_per_bit_) return false;
  answer_.assign(received_.begin(), received_.end());
  received_.clear();
  awaiting_ = false;
  return true;
}

}  // namespace delta::link_v1
