// The iCE40 UP5K bitstream check of `deltactl flash` (see bitstream.hpp).
#include "delta/deploy/bitstream.hpp"

#include <sys/stat.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>

#include "delta/input_error.hpp"

namespace delta::deploy {
namespace {

// The UP5K's configuration RAM as icepack writes it: four banks, 692 bits wide.
constexpr std::size_t kCramWidth = 692;
constexpr std::array<std::size_t, 4> kCramRows = {336, 176, 336, 176};
// Its block RAM banks (the blank bitstream's): 128 rows, 160 or 80 bits wide.
constexpr std::size_t kBramRows = 128;
constexpr std::array<std::size_t, 4> kBramWidth = {160, 80, 160, 80};
constexpr std::uint8_t kSync[] = {0x7e, 0xaa, 0x99, 0x7e};

// CRC-16/CCITT as the iCE40 checks it: polynomial 0x1021, reset to 0xFFFF, MSB first.
std::uint16_t crc16(const std::uint8_t* data, std::size_t size, std::uint16_t crc = 0xffff) {
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= static_cast<std::uint16_t>(data[i] << 8);
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 0x8000) ? static_cast<std::uint16_t>((crc << 1) ^ 0x1021) : crc << 1;
  }
  return crc;
}

std::string hex_byte(unsigned value) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%02x", value & 0xffu);
  return text;
}

}  // namespace

BitstreamSummary check_up5k_bitstream(const std::vector<std::uint8_t>& bytes, const std::string& name) {
  auto bad = [&name](std::size_t offset, const std::string& reason) {
    return InputError(name, 0, "not an iCE40 UP5K bitstream: " + reason + " (byte " + std::to_string(offset) + ")");
  };
  BitstreamSummary summary;
  summary.bytes = bytes.size();
  std::size_t at = 0;
  if (bytes.size() >= 2 && bytes[0] == 0xff && bytes[1] == 0x00) {  // comment strings up to 0x00 0xFF
    at = 2;
    while (at + 1 < bytes.size() && !(bytes[at] == 0x00 && bytes[at + 1] == 0xff)) ++at;
    if (at + 1 >= bytes.size()) throw bad(2, "a comment that never ends");
    at += 2;
  }
  if (bytes.size() < at + sizeof kSync || std::memcmp(bytes.data() + at, kSync, sizeof kSync) != 0) {
    throw bad(at, "no sync word 7EAA997E");
  }
  at += sizeof kSync;
  std::size_t width = 0, height = 0, bank = 0;
  std::size_t crc_from = 0;
  bool crc_reset = false, crc_checked = false, woke = false;
  std::array<std::size_t, 4> cram_rows{};
  while (at < bytes.size() && !woke) {
    const std::size_t command_at = at;
    const unsigned opcode = bytes[at] >> 4;
    const std::size_t length = bytes[at] & 0x0f;
    if (at + 1 + length > bytes.size()) throw bad(at, "a command past the end of the file");
    if (length > 2) throw bad(at, "command " + hex_byte(bytes[at]) + " with a payload of " + std::to_string(length));
    std::size_t payload = 0;
    for (std::size_t i = 0; i < length; ++i) payload = payload << 8 | bytes[at + 1 + i];
    at += 1 + length;
    switch (opcode) {
      case 0x0:
        if (payload == 1 || payload == 3) {  // CRAM or BRAM data: width x height bits, two zero bytes
          if (width == 0 || height == 0 || width * height % 8 != 0)
            throw bad(command_at, "a data block without a size");
          const std::size_t block = width * height / 8;
          if (at + block + 2 > bytes.size()) throw bad(command_at, "a data block past the end of the file");
          if (bytes[at + block] != 0 || bytes[at + block + 1] != 0) throw bad(at + block, "a data block not closed");
          if (payload == 1) {
            if (width != kCramWidth) {
              throw bad(command_at, "configuration banks " + std::to_string(width) + " bits wide (the UP5K's: " +
                                        std::to_string(kCramWidth) + "): another iCE40 device");
            }
            cram_rows[bank] += height;
            summary.cram_bits += width * height;
          } else {
            summary.bram_bits += width * height;
          }
          at += block + 2;
        } else if (payload == 5) {
          crc_reset = true;
          crc_from = at;
        } else if (payload == 6) {
          woke = true;
        } else {
          throw bad(command_at, "command " + std::to_string(payload) + " (icepack writes 1, 3, 5 and 6)");
        }
        break;
      case 0x1:
        if (payload > 3) throw bad(command_at, "bank " + std::to_string(payload));
        bank = payload;
        break;
      case 0x2: {
        if (!crc_reset || length != 2) throw bad(command_at, "a CRC check without a CRC reset");
        if (crc16(bytes.data() + crc_from, at - crc_from) != 0) throw bad(command_at, "CRC mismatch (a damaged file)");
        summary.crc = static_cast<std::uint16_t>(payload);
        crc_checked = true;
        break;
      }
      case 0x4:
      case 0x5:
      case 0x8:
      case 0x9:
        break;  // boot address, oscillator range, bank offset, warm boot
      case 0x6:
        width = payload + 1;
        break;
      case 0x7:
        height = payload;
        break;
      default:
        throw bad(command_at, "unknown command " + hex_byte(bytes[command_at]));
    }
  }
  if (!woke) throw bad(at, "no wake-up command");
  if (!crc_checked) throw bad(at, "no CRC check");
  for (std::size_t i = 0; i < kCramRows.size(); ++i) {
    if (cram_rows[i] != kCramRows[i]) {
      throw bad(at, "configuration bank " + std::to_string(i) + " has " + std::to_string(cram_rows[i]) +
                        " rows (the UP5K's: " + std::to_string(kCramRows[i]) + ")");
    }
  }
  for (; at < bytes.size(); ++at) {
    if (bytes[at] != 0) throw bad(at, "data after the wake-up command");
  }
  return summary;
}

BitstreamSummary check_up5k_bitstream_file(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) throw InputError(path, 0, std::string("no bitstream: ") + std::strerror(errno));
  if (!S_ISREG(info.st_mode)) throw InputError(path, 0, "not a regular file");
  if (static_cast<std::size_t>(info.st_size) > kMaxBitstreamBytes) {
    throw InputError(path, 0,
                     "not an iCE40 UP5K bitstream: " + std::to_string(info.st_size) + " bytes (one is 104090)");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, std::string("cannot open the bitstream: ") + std::strerror(errno));
  std::vector<std::uint8_t> bytes(kMaxBitstreamBytes + 1);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<std::size_t>(in.gcount()));
  return check_up5k_bitstream(bytes, path);
}

std::vector<std::uint8_t> blank_up5k_bitstream() {
  std::vector<std::uint8_t> out = {0xff, 0x00, 0x00, 0xff, 0x7e, 0xaa, 0x99, 0x7e, 0x51, 0x00, 0x01, 0x05};
  const std::size_t crc_from = out.size();
  auto word = [&out](std::uint8_t command, std::size_t value) {
    out.insert(out.end(), {command, static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value)});
  };
  auto data = [&out](std::uint8_t kind, std::size_t bits) {
    out.insert(out.end(), {0x01, kind});
    out.insert(out.end(), bits / 8 + 2, 0x00);  // the bits, then the two closing zero bytes
  };
  word(0x92, 0x0020);  // warm boot, as icepack writes it
  word(0x62, kCramWidth - 1);
  word(0x82, 0);
  for (std::size_t bank = 0; bank < kCramRows.size(); ++bank) {
    word(0x72, kCramRows[bank]);
    out.insert(out.end(), {0x11, static_cast<std::uint8_t>(bank)});
    data(0x01, kCramWidth * kCramRows[bank]);
  }
  word(0x72, kBramRows);
  for (std::size_t bank = 0; bank < kBramWidth.size(); ++bank) {
    out.insert(out.end(), {0x11, static_cast<std::uint8_t>(bank)});
    for (const std::size_t offset : {std::size_t{0}, kBramRows}) {
      word(0x82, offset);
      word(0x62, kBramWidth[bank] - 1);
      data(0x03, kBramWidth[bank] * kBramRows);
    }
  }
  out.push_back(0x22);
  const std::uint16_t crc = crc16(out.data() + crc_from, out.size() - crc_from);
  out.insert(out.end(), {static_cast<std::uint8_t>(crc >> 8), static_cast<std::uint8_t>(crc), 0x01, 0x06, 0x00});
  return out;
}

}  // namespace delta::deploy
