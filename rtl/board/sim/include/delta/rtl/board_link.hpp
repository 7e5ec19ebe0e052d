// Host side of board_core's UART frames (rtl/board/network_uart_link.sv) and the board's two
// clocks, shared by the co-simulation and the board tests.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace delta::cosim {

// Request: A5, three input codes of 4 bytes (little-endian two's complement), checksum (the 8-bit
// sum of code bytes and checksum is zero). checksum_error is added to the checksum (tests).
inline std::vector<std::uint8_t> request_frame(const std::array<std::int64_t, 3>& codes,
                                               std::uint8_t checksum_error = 0) {
  std::vector<std::uint8_t> frame = {0xA5};
  std::uint8_t sum = 0;
  for (std::int64_t code : codes) {
    for (int b = 0; b < 4; ++b) {
      const auto byte = static_cast<std::uint8_t>((static_cast<std::uint64_t>(code) >> (8 * b)) & 0xFF);
      frame.push_back(byte);
      sum += byte;
    }
  }
  frame.push_back(static_cast<std::uint8_t>(-sum + checksum_error));
  return frame;
}

// Answer: 5A, three output codes of 3 bytes (sign-extended from 24 bits), checksum. Nothing for
// a NAK (15), a wrong length, sync byte or checksum.
inline std::optional<std::array<std::int64_t, 3>> parse_answer(const std::vector<std::uint8_t>& answer) {
  if (answer.size() != 11 || answer[0] != 0x5A) return std::nullopt;
  std::uint8_t sum = answer[10];
  std::array<std::int64_t, 3> codes{};
  for (int o = 0; o < 3; ++o) {
    std::uint32_t raw = 0;
    for (int b = 0; b < 3; ++b) {
      raw |= static_cast<std::uint32_t>(answer[1 + 3 * o + b]) << (8 * b);
      sum += answer[1 + 3 * o + b];
    }
    codes[o] = static_cast<std::int32_t>(raw << 8) >> 8;
  }
  if (sum != 0) return std::nullopt;
  return codes;
}

// Quadrature encoder lines `steps` counts from the start ({A, B} = 00 -> 10 -> 11 -> 01 counting
// up, rtl/joint/quadrature_counter.sv).
inline int quadrature_a(int steps) { return ((steps % 4 + 4) % 4 + 1) / 2 % 2; }  // 0, 1, 1, 0
inline int quadrature_b(int steps) { return ((steps % 4 + 4) % 4) / 2; }          // 0, 0, 1, 1

// One board clock of a Verilated board_core: two network clocks, rising together with it (the
// PLL's GENCLK and GENCLK_HALF).
template <typename BoardCore>
void clock_board(BoardCore& core) {
  core.clk_i = 1;
  core.clk_network_i = 1;
  core.eval();
  core.clk_network_i = 0;
  core.eval();
  core.clk_i = 0;
  core.clk_network_i = 1;
  core.eval();
  core.clk_network_i = 0;
  core.eval();
}

}  // namespace delta::cosim
