// The board core end to end over its UART: framed requests (positions as raw input codes) in,
// framed answers (joint references as raw output codes) out, equal to the golden model; a bad
// checksum is answered with NAK. UART at 4 clocks per bit.
#include <gtest/gtest.h>

#include <cstdint>
#include <iostream>
#include <memory>
#include <vector>

#include "Vboard_core.h"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "rtl_fixture.hpp"

namespace delta::test {
namespace {

constexpr int kClocksPerBit = 4;  // -GClocksPerBit of the Verilated board core (rtl/board/CMakeLists.txt)

class BoardUart {
 public:
  explicit BoardUart(const std::string& mem_dir) : context_(new VerilatedContext) {
    const std::string plusarg = "+delta_mem_dir=" + mem_dir;
    const char* argv[] = {"board_uart", plusarg.c_str()};
    context_->commandArgs(2, argv);
    core_ = std::make_unique<Vboard_core>(context_.get(), "board");
    core_->uart_rx_i = 1;
    core_->encoder_a_i = 0;
    core_->encoder_b_i = 0;
    core_->rst_ni = 0;
    for (int i = 0; i < 4; ++i) tick();
    core_->rst_ni = 1;
    tick();
    listening_ = true;  // tx_o is undefined before reset
  }
  ~BoardUart() { core_->final(); }

  // Sends the bytes (8N1, LSB first) while decoding what the board transmits; returns the bytes
  // received until the line has been idle for 40 bit times after the last one.
  std::vector<std::uint8_t> exchange(const std::vector<std::uint8_t>& request) {
    for (std::uint8_t byte : request) {
      send_bit(0);
      for (int b = 0; b < 8; ++b) send_bit((byte >> b) & 1);
      send_bit(1);
    }
    int idle = 0;
    while (idle < 40 * kClocksPerBit * 10 && context_->time() < 100'000'000) {
      idle = received_.size() > received_before_idle_ ? 0 : idle + 1;
      received_before_idle_ = received_.size();
      tick();
    }
    std::vector<std::uint8_t> answer(received_.begin(), received_.end());
    received_.clear();
    received_before_idle_ = 0;
    return answer;
  }

 private:
  void send_bit(int bit) {
    core_->uart_rx_i = bit;
    for (int i = 0; i < kClocksPerBit; ++i) tick();
  }

  // One clock; the receiver samples tx_o mid-bit after a falling edge (a start bit).
  void tick() {
    core_->clk_i = 1;
    core_->eval();
    core_->clk_i = 0;
    core_->eval();
    context_->timeInc(1);
    const int tx = core_->uart_tx_o;
    if (!listening_) return;
    if (rx_phase_ < 0) {
      if (tx == 0) rx_phase_ = 0;  // start bit
    } else {
      ++rx_phase_;
      const int bit_index = (rx_phase_ - kClocksPerBit / 2) / kClocksPerBit;  // 0: start, 1..8: data, 9: stop
      if ((rx_phase_ - kClocksPerBit / 2) % kClocksPerBit == 0 && bit_index >= 1 && bit_index <= 8) {
        rx_byte_ |= tx << (bit_index - 1);
      }
      if (bit_index == 9 && (rx_phase_ - kClocksPerBit / 2) % kClocksPerBit == 0) {
        received_.push_back(static_cast<std::uint8_t>(rx_byte_));
        rx_byte_ = 0;
        rx_phase_ = -1;
      }
    }
  }

  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Vboard_core> core_;
  std::vector<std::uint8_t> received_;
  std::size_t received_before_idle_ = 0;
  bool listening_ = false;
  int rx_phase_ = -1;
  int rx_byte_ = 0;
};

std::vector<std::uint8_t> request_frame(const std::array<std::int64_t, 3>& codes, std::uint8_t checksum_error = 0) {
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

TEST(BoardUart, AnswersEqualTheGoldenModel) {
  constexpr std::uint64_t kSeed = 20260105;
  std::cout << "vector seed " << kSeed << "\n";
  const golden::QuantisedNetwork q = golden::quantise(random_network(31));
  const std::string mem_dir = fresh_directory("board_uart_mem");
  golden::write_export(q, mem_dir);
  BoardUart board(mem_dir);
  InputVectors inputs(q, kSeed);
  for (int v = 0; v < 20; ++v) {
    const std::array<std::int64_t, 3> x = inputs.next();
    const std::vector<std::uint8_t> answer = board.exchange(request_frame(x));
    ASSERT_EQ(answer.size(), 11u) << "vector " << v;  // 5A, 3 x 3 bytes, checksum
    EXPECT_EQ(answer[0], 0x5A);
    std::uint8_t sum = 0;
    std::array<std::int64_t, 3> y{};
    for (int o = 0; o < 3; ++o) {
      std::uint32_t raw = 0;
      for (int b = 0; b < 3; ++b) {
        raw |= static_cast<std::uint32_t>(answer[1 + 3 * o + b]) << (8 * b);
        sum += answer[1 + 3 * o + b];
      }
      y[o] = static_cast<std::int32_t>(raw << 8) >> 8;  // sign-extend 24 bits
    }
    EXPECT_EQ(static_cast<std::uint8_t>(sum + answer[10]), 0) << "answer checksum, vector " << v;
    EXPECT_EQ(y, golden::evaluate_raw(q, x).alpha) << "vector " << v;
  }
  // A wrong checksum gets NAK, and the link then serves the next request.
  EXPECT_EQ(board.exchange(request_frame(inputs.next(), 1)), std::vector<std::uint8_t>{0x15});
  const std::array<std::int64_t, 3> x = inputs.next();
  EXPECT_EQ(board.exchange(request_frame(x)).size(), 11u);
}

}  // namespace
}  // namespace delta::test
