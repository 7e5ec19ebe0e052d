// Export of a quantised network: $readmemh files for the RTL and a C++ header for the HLS top
// (formats in hls/README.md, "Export for RTL ($readmemh) and C++").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "delta/golden/fixed_network.hpp"
#include "delta/link/payloads.hpp"

namespace delta::golden {

struct ExportFile {
  std::string name;  // file name inside the export folder
  std::string text;  // exact content (deterministic: no dates, no paths)
};

// Every file of the export, in a fixed order: the .mem files, then fixed_network_weights.hpp.
std::vector<ExportFile> export_files(const QuantisedNetwork& q);

// Writes export_files(q) and board_identify_file(q) into `directory` (which must exist): all
// files appear, or none. What a Verilated network or board core loads (+delta_mem_dir).
void write_export(const QuantisedNetwork& q, const std::string& directory);

// Writes `files` into `directory`: every file is complete before the first one is put in place,
// so an error, a full disk or SIGINT leaves none of them.
void write_export_files(const std::vector<ExportFile>& files, const std::string& directory);

// One word as ceil(bits/4) hex digits of its two's complement masked to `bits`.
std::string hex_word(std::int64_t value, int bits);

// The bytes the weights CRC covers: the model as the board loads it, golden::model_crc_bytes
// (model_image.hpp: every word of the load's frames as 6 little-endian bytes, in frame order).
std::vector<std::uint8_t> weights_crc_bytes(const QuantisedNetwork& q);

// identify.mem: the identify payload for the board's 256 x 16 block RAM ($readmemh): comment
// lines, then one 4-digit hex word per line, word w = payload byte 2w (low) | byte 2w+1 (high).
ExportFile identify_mem_file(const link::IdentifyPayload& identify);

// identify.mem of a board built from this tree (kGatewareBuildId) holding network q.
ExportFile board_identify_file(const QuantisedNetwork& q);

}  // namespace delta::golden

namespace delta {

// CRC-32/ISO-HDLC (delta::crc32) of golden::weights_crc_bytes(q): the model's CRC, which a board
// that loaded it reports in its identify payload, so the host can tell which model a board holds.
std::uint32_t weights_crc(const golden::QuantisedNetwork& q);

}  // namespace delta
