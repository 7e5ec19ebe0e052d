// CRC-32/ISO-HDLC (host/include/delta/crc32.hpp): the catalogue's check value, zlib's chaining,
// and a table-free reference on random data (seed printed).
#include <gtest/gtest.h>

#include <cstring>
#include <iostream>
#include <random>
#include <vector>

#include "delta/crc32.hpp"

namespace delta {
namespace {

TEST(Crc32, CheckValueOfTheCatalogue) {
  const char* check = "123456789";
  EXPECT_EQ(crc32(reinterpret_cast<const std::uint8_t*>(check), std::strlen(check)), 0xCBF43926u);
  EXPECT_EQ(crc32(nullptr, 0), 0u);  // empty input: init and final XOR cancel, as zlib's crc32(0, NULL, 0)
  EXPECT_EQ(crc32(std::vector<std::uint8_t>{0}), 0xD202EF8Du);  // zlib.crc32(b"\0")
}

TEST(Crc32, ChainsLikeZlib) {
  const std::uint64_t seed = 32;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<std::uint8_t> data(random() % 300);
    for (auto& byte : data) byte = static_cast<std::uint8_t>(random());
    const std::size_t split = data.empty() ? 0 : random() % (data.size() + 1);
    const std::uint32_t first = crc32(data.data(), split);
    ASSERT_EQ(crc32(data.data() + split, data.size() - split, first), crc32(data)) << "trial " << trial;
  }
}

}  // namespace
}  // namespace delta
