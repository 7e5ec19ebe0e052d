// A board in process for the host's tests, in line time (one step() a byte time, 10 us at 1 Mbaud):
// what it sends waits in to_host_ for the host's read_some, and the host's wait runs its byte
// times until a byte is there or the wait's time has passed. A test's board adds how it takes the
// host's bytes (write_all) and what it does each byte time (step).
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "delta/io/byte_stream.hpp"
#include "delta/link/frame_codec.hpp"

namespace delta::test {

class LineTimeBoard : public io::ByteStream {
 public:
  std::size_t read_some(std::uint8_t* data, std::size_t capacity) override {
    const std::size_t n = std::min(capacity, to_host_.size());
    std::copy(to_host_.begin(), to_host_.begin() + static_cast<std::ptrdiff_t>(n), data);
    to_host_.erase(to_host_.begin(), to_host_.begin() + static_cast<std::ptrdiff_t>(n));
    return n;
  }
  int fd() const override { return -1; }
  using io::ByteStream::wait_readable;
  bool wait_readable(int timeout_ms) override {
    // Board time runs while the host waits: until a byte for the host is there, or the timeout.
    for (long steps = 0; to_host_.empty() && steps < 100L * timeout_ms; ++steps) step();
    return !to_host_.empty();
  }
  const std::string& name() const override { return name_; }

 protected:
  virtual void step() = 0;  // one byte time
  void send(const link::Frame& frame) {
    const std::vector<std::uint8_t> bytes = link::encode_frame(frame);
    to_host_.insert(to_host_.end(), bytes.begin(), bytes.end());
  }

  std::string name_ = "scripted-board";
  std::vector<std::uint8_t> to_host_;
};

}  // namespace delta::test
