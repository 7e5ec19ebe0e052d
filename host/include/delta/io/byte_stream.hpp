// One byte-stream interface between the host controller and a board: read what is there, write,
// and a file descriptor to poll. Two implementations: a serial port (the real board, or any
// serial device) and a pseudo-terminal's master side (the virtual board). Nothing above it knows
// which.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace delta::io {

class ByteStream {
 public:
  virtual ~ByteStream() = default;
  // Reads what is there, at most `capacity` bytes, without blocking; 0 when nothing is. Throws
  // std::system_error when the other side is gone (hang-up) or the read fails.
  virtual std::size_t read_some(std::uint8_t* data, std::size_t capacity) = 0;
  // Writes all `size` bytes (waiting for room at most timeout_ms in all); throws std::system_error
  // on failure or time-out.
  virtual void write_all(const std::uint8_t* data, std::size_t size, int timeout_ms = 100) = 0;
  virtual int fd() const = 0;  // for poll(); -1 for a stream without a descriptor (in process)
  // Waits until read_some has bytes or timeout_ms passed; true when readable. The default polls
  // fd(); a stream without a descriptor overrides it (the in-process virtual board advances its
  // simulated time here, so its timeout is in board time).
  virtual bool wait_readable(int timeout_ms);
  // The same, where the reader can do nothing before `bytes` bytes are there (the rest of a frame):
  // a stream may return with fewer; the in-process virtual board runs on until they are there
  // (or the timeout), without stopping at every byte.
  virtual bool wait_readable(int timeout_ms, std::size_t bytes) {
    static_cast<void>(bytes);
    return wait_readable(timeout_ms);
  }
  virtual const std::string& name() const = 0;
};

}  // namespace delta::io
