// Host side of the board's first link (rtl/board/network_uart_link.sv): a position request in,
// the network's three joint references out, an 8-bit sum as the only check, one request in flight.
// The frame codec is a pair of pure functions; LinkV1Client keeps the one request in flight and
// decides, from the bytes and the silence after them, when an answer is complete.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "delta/board_facts.hpp"

namespace delta::link_v1 {

// The frames' constants come from the board's facts (rtl/board/delta_board_pkg.sv).
constexpr std::uint8_t kRequestSync = board::kLinkRequestSync;
constexpr std::uint8_t kAnswerSync = board::kLinkAnswerSync;
constexpr std::uint8_t kNak = board::kLinkNak;
constexpr int kRequestCodeBytes = static_cast<int>(board::kLinkRequestCodeBytes);
constexpr int kAnswerCodeBytes = static_cast<int>(board::kLinkAnswerCodeBytes);
constexpr std::size_t kAnswerBytes = 3 * kAnswerCodeBytes + 2;  // sync, codes, checksum

// Request: A5, three input codes of 4 bytes (little-endian two's complement), checksum (the 8-bit
// sum of code bytes and checksum is zero). checksum_error is added to the checksum (tests).
std::vector<std::uint8_t> request_frame(const std::array<std::int64_t, 3>& codes, std::uint8_t checksum_error = 0);

// Answer: 5A, three output codes of 3 bytes (sign-extended from 24 bits), checksum. Nothing for
// a NAK, a wrong length, sync byte or checksum.
std::optional<std::array<std::int64_t, 3>> parse_answer(const std::vector<std::uint8_t>& answer);

// One request in flight. Time is counted in the caller's units (board cycles in the
// co-simulation), units_per_bit of them per bit on the line.
class LinkV1Client {
 public:
  explicit LinkV1Client(int units_per_bit) : units_per_bit_(units_per_bit) {}
  bool idle() const { return !awaiting_; }
  // The request's bytes (to write to the line); the client now awaits its answer.
  std::vector<std::uint8_t> request(const std::array<std::int64_t, 3>& codes);
  // A byte arrived from the board.
  void receive(std::uint8_t byte);
  // One more unit of time has passed with the request sent. Returns true when the answer is
  // complete: 11 bytes after the answer sync, or a NAK followed by 20 bit times of silence, or
  // nothing usable after 4000 bit times of silence (a lost answer).
  bool elapse();
  const std::vector<std::uint8_t>& answer() const { return answer_; }

 private:
  int units_per_bit_;
  bool awaiting_ = false;
  long silent_units_ = 0;
  std::vector<std::uint8_t> received_;
  std::vector<std::uint8_t> answer_;
};

}  // namespace delta::link_v1
