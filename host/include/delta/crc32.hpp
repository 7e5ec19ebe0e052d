// CRC-32/ISO-HDLC, the CRC of zlib, Ethernet and PNG: reflected polynomial 0xEDB88320, initial
// value and final XOR 0xFFFFFFFF; check value of "123456789": 0xCBF43926. Used for the network's
// weights CRC in the link's identify payload (delta::weights_crc).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace delta {

// zlib's convention: `crc` is the result over the preceding bytes (0 for none), so
// crc32(b, crc32(a)) == crc32(a followed by b).
std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0);
inline std::uint32_t crc32(const std::vector<std::uint8_t>& bytes, std::uint32_t crc = 0) {
  return crc32(bytes.data(), bytes.size(), crc);
}

}  // namespace delta
