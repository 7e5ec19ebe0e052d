// UartLine's runs of held levels (hold_rx_pin, hold_tx_pin: the model board's path) against its
// cycle-by-cycle calls (rx_pin, sample_tx_pin): the same levels, bytes and completion cycles.
#include <gtest/gtest.h>

#include <cstdint>
#include <iostream>
#include <random>
#include <vector>

#include "delta/rtl/uart_line.hpp"

namespace delta::rtl {
namespace {

constexpr int kClocksPerBit = 23;

// The TX pin of a UART sending `bytes` (8N1) with `gap` idle cycles before each.
std::vector<int> tx_levels(const std::vector<std::uint8_t>& bytes, const std::vector<int>& gaps) {
  std::vector<int> levels;
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    levels.insert(levels.end(), static_cast<std::size_t>(gaps[k]), 1);
    std::vector<int> bits{0};
    for (int b = 0; b < 8; ++b) bits.push_back((bytes[k] >> b) & 1);
    bits.push_back(1);
    for (int bit : bits) levels.insert(levels.end(), kClocksPerBit, bit);
  }
  levels.insert(levels.end(), 50, 1);
  return levels;
}

TEST(UartLine, HeldRunsEqualCycleByCycle) {
  const std::uint64_t seed = 16;
  std::cout << "seed " << seed << '\n';
  std::mt19937_64 random(seed);
  std::vector<std::uint8_t> bytes(300);
  std::vector<int> gaps(bytes.size());
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    bytes[k] = static_cast<std::uint8_t>(random());
    gaps[k] = k % 3 == 0 ? static_cast<int>(random() % 40) : 0;
  }

  // Board -> line: runs of a held TX level, never past a level change or a completed byte.
  const std::vector<int> levels = tx_levels(bytes, gaps);
  UartLine by_cycle(kClocksPerBit), by_run(kClocksPerBit);
  std::vector<std::uint8_t> received_by_cycle, received_by_run;
  std::vector<std::size_t> ends_by_cycle, ends_by_run;
  for (std::size_t i = 0; i < levels.size(); ++i) {
    if (by_cycle.sample_tx_pin(levels[i])) {
      received_by_cycle.push_back(by_cycle.byte());
      ends_by_cycle.push_back(i);
    }
  }
  for (std::size_t i = 0; i < levels.size();) {
    std::size_t held = 1;
    while (i + held < levels.size() && levels[i + held] == levels[i]) ++held;
    const int to_byte = by_run.tx_cycles_to_byte(levels[i]);
    if (to_byte > 0) held = std::min(held, static_cast<std::size_t>(to_byte));
    held = std::min<std::size_t>(held, 1 + random() % 40);
    if (by_run.hold_tx_pin(levels[i], static_cast<int>(held))) {
      received_by_run.push_back(by_run.byte());
      ends_by_run.push_back(i + held - 1);
    }
    i += held;
  }
  EXPECT_EQ(received_by_cycle, bytes);
  EXPECT_EQ(received_by_run, received_by_cycle);
  EXPECT_EQ(ends_by_run, ends_by_cycle);

  // Line -> board: the RX pin's levels in runs up to the end of each bit.
  UartLine sender_by_cycle(kClocksPerBit), sender_by_run(kClocksPerBit);
  sender_by_cycle.send(bytes);
  sender_by_run.send(bytes);
  std::vector<int> rx_by_cycle, rx_by_run;
  while (sender_by_cycle.sending()) rx_by_cycle.push_back(sender_by_cycle.rx_pin());
  while (sender_by_run.sending()) {
    const int held = std::min(sender_by_run.rx_pin_holds(), 1 + static_cast<int>(random() % 30));
    ASSERT_EQ(sender_by_run.rx_pin_level(), rx_by_cycle[rx_by_run.size()]);
    const int level = sender_by_run.hold_rx_pin(held);
    rx_by_run.insert(rx_by_run.end(), static_cast<std::size_t>(held), level);
  }
  EXPECT_EQ(rx_by_run, rx_by_cycle);
  EXPECT_EQ(rx_by_cycle.size(), bytes.size() * 10 * kClocksPerBit);
  EXPECT_EQ(sender_by_run.rx_pin_holds(), 0);
  EXPECT_EQ(sender_by_run.hold_rx_pin(5), 1);  // idle: high
}

}  // namespace
}  // namespace delta::rtl
