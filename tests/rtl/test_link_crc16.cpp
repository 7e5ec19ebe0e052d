// The link v2's CRC-16 in RTL (rtl/board/link_crc16.sv) against the C++ codec's crc16(), its
// golden model: the catalogue check value and every CRC of random frames, byte by byte, with
// clears and idle cycles between bytes.
#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <vector>

#include "Vlink_crc16.h"
#include "delta/link/frame_codec.hpp"
#include "verilated.h"

namespace delta::test {
namespace {

class Crc16Bench {
 public:
  Crc16Bench() {
    top_.clk_i = 0;
    top_.rst_ni = 0;
    top_.clear_i = 0;
    top_.valid_i = 0;
    top_.eval();
    tick();
    top_.rst_ni = 1;
  }
  void tick() {
    top_.clk_i = 1;
    top_.eval();
    top_.clk_i = 0;
    top_.eval();
  }
  // One cycle with these inputs; returns the CRC shown after it.
  std::uint16_t cycle(bool clear, bool valid, std::uint8_t data) {
    top_.clear_i = clear;
    top_.valid_i = valid;
    top_.data_i = data;
    tick();
    top_.clear_i = 0;
    top_.valid_i = 0;
    return top_.crc_o;
  }

 private:
  VerilatedContext context_;
  Vlink_crc16 top_{&context_};
};

TEST(LinkCrc16, CheckValueOfTheCatalogue) {
  Crc16Bench bench;
  std::uint16_t crc = bench.cycle(true, false, 0);
  EXPECT_EQ(crc, 0xFFFF);
  for (char c : std::string("123456789")) crc = bench.cycle(false, true, static_cast<std::uint8_t>(c));
  EXPECT_EQ(crc, 0x29B1);
}

TEST(LinkCrc16, EqualsTheCodecOnRandomFramesWithIdleCycles) {
  const std::uint64_t seed = 1123;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  Crc16Bench bench;
  std::size_t bytes_checked = 0;
  for (int frame = 0; frame < 2000; ++frame) {
    std::vector<std::uint8_t> data(1 + random() % link::kMaxFrameBytes);
    for (auto& byte : data) byte = static_cast<std::uint8_t>(random());
    // The first byte either after a separate clear or together with it.
    const bool together = random() % 2;
    std::uint16_t crc =
        together ? bench.cycle(true, true, data[0]) : (bench.cycle(true, false, 0), bench.cycle(false, true, data[0]));
    ASSERT_EQ(crc, link::crc16(data.data(), 1)) << "frame " << frame;
    for (std::size_t i = 1; i < data.size(); ++i) {
      while (random() % 4 == 0) bench.cycle(false, false, static_cast<std::uint8_t>(random()));  // idle: no change
      crc = bench.cycle(false, true, data[i]);
      ASSERT_EQ(crc, link::crc16(data.data(), i + 1)) << "frame " << frame << " byte " << i;
    }
    bytes_checked += data.size();
  }
  std::cout << bytes_checked << " bytes, every intermediate CRC equal to the codec's\n";
}

}  // namespace
}  // namespace delta::test
