// A serial line at the board's pins, 8N1 at clocks_per_bit board cycles per bit: bytes to send
// become the level of the board's RX pin cycle by cycle, and the board's TX pin becomes bytes.
// What an FTDI chip does between a host's byte stream and the FPGA; no framing, no protocol.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

namespace delta::rtl {

class UartLine {
 public:
  explicit UartLine(int clocks_per_bit) : clocks_per_bit_(clocks_per_bit) {}

  void send(const std::vector<std::uint8_t>& bytes) {
    for (std::uint8_t byte : bytes) {
      tx_bits_.push_back(0);
      for (int b = 0; b < 8; ++b) tx_bits_.push_back((byte >> b) & 1);
      tx_bits_.push_back(1);
    }
  }
  bool sending() const { return !tx_bits_.empty(); }

  // Level of the board's RX pin for this board cycle.
  int rx_pin() {
    if (tx_bits_.empty()) return 1;
    const int bit = tx_bits_.front();
    if (++tx_phase_ == clocks_per_bit_) {
      tx_phase_ = 0;
      tx_bits_.pop_front();
    }
    return bit;
  }

  // The board's TX pin after a board cycle; true when it completed a byte (then in byte()).
  bool sample_tx_pin(int level) {
    if (rx_phase_ < 0) {
      if (level == 0) rx_phase_ = 0;
      return false;
    }
    ++rx_phase_;
    const int offset = rx_phase_ - clocks_per_bit_ / 2;
    if (offset % clocks_per_bit_ != 0) return false;
    const int bit_index = offset / clocks_per_bit_;  // 0 start, 1..8 data, 9 stop
    if (bit_index >= 1 && bit_index <= 8) rx_byte_ |= level << (bit_index - 1);
    if (bit_index != 9) return false;
    byte_ = static_cast<std::uint8_t>(rx_byte_);
    rx_byte_ = 0;
    rx_phase_ = -1;
    return true;
  }
  std::uint8_t byte() const { return byte_; }

  // Runs of cycles at once (a board model that skips clocks in which its pins hold), exactly as
  // many rx_pin() or sample_tx_pin() calls.
  // RX pin: cycles its present level still holds (0 when idle: high for ever).
  int rx_pin_level() const { return tx_bits_.empty() ? 1 : tx_bits_.front(); }
  int rx_pin_holds() const { return tx_bits_.empty() ? 0 : clocks_per_bit_ - tx_phase_; }
  // The RX pin's level for `cycles` cycles (while sending, at most rx_pin_holds()).
  int hold_rx_pin(int cycles) {
    if (tx_bits_.empty()) return 1;
    const int bit = tx_bits_.front();
    tx_phase_ += cycles;
    if (tx_phase_ == clocks_per_bit_) {
      tx_phase_ = 0;
      tx_bits_.pop_front();
    }
    return bit;
  }
  // TX pin held at `level`: cycles up to and including the one that completes a byte (-1: none would).
  int tx_cycles_to_byte(int level) const {
    const int stop_sample = clocks_per_bit_ / 2 + 9 * clocks_per_bit_;
    if (rx_phase_ >= 0) return stop_sample - rx_phase_;
    return level == 0 ? stop_sample + 1 : -1;
  }
  // `cycles` cycles of the TX pin at `level` (at most tx_cycles_to_byte()); true when the last
  // completed a byte.
  bool hold_tx_pin(int level, int cycles) {
    if (rx_phase_ < 0) {
      if (level != 0) return false;
      rx_phase_ = 0;
      --cycles;
    }
    const int from = rx_phase_ + 1;
    rx_phase_ += cycles;
    // Bit b is sampled at phase clocks_per_bit / 2 + b clocks_per_bit (0 start, 1..8 data, 9 stop).
    const int half = clocks_per_bit_ / 2;
    for (int b = from <= half ? 0 : (from - half + clocks_per_bit_ - 1) / clocks_per_bit_;
         half + b * clocks_per_bit_ <= rx_phase_; ++b) {
      if (b >= 1 && b <= 8) rx_byte_ |= level << (b - 1);
      if (b == 9) {
        byte_ = static_cast<std::uint8_t>(rx_byte_);
        rx_byte_ = 0;
        rx_phase_ = -1;
        return true;
      }
    }
    return false;
  }

 private:
  int clocks_per_bit_;
  std::deque<int> tx_bits_;
  int tx_phase_ = 0;
  int rx_phase_ = -1;
  int rx_byte_ = 0;
  std::uint8_t byte_ = 0;
};

}  // namespace delta::rtl
