// The board's identify over the link, a bitstream's identify.mem, the configured weights CRC.
#include "delta/deploy/board_probe.hpp"

#include <poll.h>
#include <sys/stat.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <vector>

#include "delta/golden/export.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/input_error.hpp"
#include "delta/io/serial_port.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::deploy {

std::string hex32(std::uint32_t value) {
  char text[16];
  std::snprintf(text, sizeof(text), "%08x", value);
  return text;
}

link::IdentifyPayload identify_board(const std::string& port, int baud, int timeout_ms) {
  io::SerialPort serial(port, baud);
  const std::uint8_t sequence = 0x5a;
  const std::vector<std::uint8_t> request = link::encode_frame(link::make_identify_request(sequence));
  serial.write_all(request.data(), request.size(), timeout_ms);
  link::FrameDecoder decoder(link::Receiver::kHost);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  std::uint8_t buffer[256];
  while (true) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) break;
    pollfd fd{serial.fd(), POLLIN, 0};
    if (::poll(&fd, 1, static_cast<int>(left)) <= 0) continue;
    const std::size_t got = serial.read_some(buffer, sizeof(buffer));
    for (const link::Frame& frame : decoder.feed(buffer, got)) {
      if (frame.type == link::FrameType::kIdentify && frame.sequence == sequence) {
        return link::decode_identify(frame.payload);
      }
    }
  }
  throw std::runtime_error(port + ": no identify reply within " + std::to_string(timeout_ms) + " ms (" +
                           std::to_string(decoder.counters().frames) + " frames, " + std::to_string(decoder.dropped()) +
                           " dropped)");
}

link::IdentifyPayload read_identify_mem(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open identify.mem");
  std::vector<std::uint8_t> payload;
  std::string text;
  std::size_t line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (text.empty() || text.rfind("//", 0) == 0) continue;
    if (text.size() != 4 || text.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos) {
      throw InputError(path, line, "expected a 4-digit hex word: " + quoted_excerpt(text));
    }
    const unsigned word = static_cast<unsigned>(std::stoul(text, nullptr, 16));
    payload.push_back(static_cast<std::uint8_t>(word & 0xff));
    payload.push_back(static_cast<std::uint8_t>(word >> 8));
  }
  if (payload.size() != static_cast<std::size_t>(board::kIdentifyPayloadBytes)) {
    throw InputError(path, line,
                     std::to_string(payload.size()) + " payload bytes, the identify payload has " +
                         std::to_string(board::kIdentifyPayloadBytes));
  }
  return link::decode_identify(payload);
}

std::optional<std::string> identify_mem_beside(const std::string& bitstream) {
  const auto slash = bitstream.rfind('/');
  const std::string path =
      (slash == std::string::npos ? std::string(".") : bitstream.substr(0, slash)) + "/identify.mem";
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return std::nullopt;
  return path;
}

std::uint32_t weights_file_crc(const std::string& weights_path) {
  const nn::WeightsFile weights = nn::read_weights_file(weights_path);
  return weights_crc(golden::quantise_file(weights_path, weights));
}

}  // namespace delta::deploy
