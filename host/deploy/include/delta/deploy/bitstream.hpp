// An iCE40 UP5K bitstream as icepack writes it (fpga-icestorm's format.html): an optional comment
// (0xFF 0x00 ... 0x00 0xFF), the sync word 0x7EAA997E, then commands; the CRAM banks of a UP5K are
// 692 bits wide and 336, 176, 336, 176 rows high; a CRC-16/CCITT check; the wake-up command.
// `deltactl flash` refuses a .bin that is not one before it runs the programmer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace delta::deploy {

// A UP5K bitstream is 104,090 bytes; a file beyond this is not one (and is not read whole).
constexpr std::size_t kMaxBitstreamBytes = 1u << 20;

struct BitstreamSummary {
  std::size_t bytes = 0;
  std::size_t cram_bits = 0;  // configuration bits written (the UP5K's: 692 x 1024)
  std::size_t bram_bits = 0;  // block RAM bits written
  std::uint16_t crc = 0;      // the CRC the bitstream checks
};

// Parses `bytes` as a UP5K bitstream; throws InputError(name, 0, reason) naming the first thing
// that is not (the sync word, an unknown command, a block past the end, another device's CRAM
// geometry, a CRC mismatch, no wake-up).
BitstreamSummary check_up5k_bitstream(const std::vector<std::uint8_t>& bytes, const std::string& name);

// The file at `path` read (at most kMaxBitstreamBytes) and checked as above.
BitstreamSummary check_up5k_bitstream_file(const std::string& path);

// A bitstream of the UP5K's geometry with every bit zero (an empty design): what the checks
// accept, for tests of `deltactl flash` and of the package where no real bitstream is built.
std::vector<std::uint8_t> blank_up5k_bitstream();

}  // namespace delta::deploy
