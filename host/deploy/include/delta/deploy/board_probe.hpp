// What `deltactl flash` and `deltactl doctor` ask of a board and a bitstream: the board's identify
// over the link, the identify a bitstream carries (identify.mem beside it), and the configured
// network's weights CRC.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "delta/link/payloads.hpp"

namespace delta::deploy {

// Sends an identify request on `port` at `baud` and waits up to `timeout_ms` for the reply.
// Throws std::runtime_error (or std::system_error from the port) naming the port and the cause.
link::IdentifyPayload identify_board(const std::string& port, int baud, int timeout_ms);

// identify.mem (golden::identify_mem_file's format: `//` comment lines, one 4-digit hex word per
// line) decoded; bad input names the file and line.
link::IdentifyPayload read_identify_mem(const std::string& path);

// The identify.mem that describes `bitstream`: BITSTREAM's folder/identify.mem (the fpga flow's
// output folder and the package's /usr/share/deltactl both keep it there). Empty if absent.
std::optional<std::string> identify_mem_beside(const std::string& bitstream);

// delta::weights_crc of the quantised W.json (bad input: file, reason).
std::uint32_t weights_file_crc(const std::string& weights_path);

std::string hex32(std::uint32_t value);

}  // namespace delta::deploy
