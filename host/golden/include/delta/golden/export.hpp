// Export of a quantised network: $readmemh files for the RTL and a C++ header for the HLS top
// (formats in hls/README.md, "Export for RTL ($readmemh) and C++").
#pragma once

#include <string>
#include <vector>

#include "delta/golden/fixed_network.hpp"

namespace delta::golden {

struct ExportFile {
  std::string name;  // file name inside the export folder
  std::string text;  // exact content (deterministic: no dates, no paths)
};

// Every file of the export, in a fixed order: the .mem files, then fixed_network_weights.hpp.
std::vector<ExportFile> export_files(const QuantisedNetwork& q);

// Writes export_files(q) into `directory` (which must exist): all files appear, or none.
void write_export(const QuantisedNetwork& q, const std::string& directory);

// Writes `files` into `directory`: every file is complete before the first one is put in place,
// so an error, a full disk or SIGINT leaves none of them.
void write_export_files(const std::vector<ExportFile>& files, const std::string& directory);

// One word as ceil(bits/4) hex digits of its two's complement masked to `bits`.
std::string hex_word(std::int64_t value, int bits);

}  // namespace delta::golden
