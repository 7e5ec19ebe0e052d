// CRC-32/ISO-HDLC (see crc32.hpp), bit by bit: the data it covers is a few kilobytes.
#include "delta/crc32.hpp"

namespace delta {

std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc) {
  constexpr std::uint32_t kReflectedPolynomial = 0xEDB88320u;  // 0x04C11DB7 bit-reversed
  crc = ~crc;                                                  // initial value 0xFFFFFFFF for crc == 0
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1u) ? (crc >> 1) ^ kReflectedPolynomial : crc >> 1;
  }
  return ~crc;  // final XOR 0xFFFFFFFF
}

}  // namespace delta
