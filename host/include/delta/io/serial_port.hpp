// A serial port opened the way a controller must own it: raw 8N1, no echo, no line discipline,
// exclusive (a second opener is refused, also another program), non-blocking, and with the
// driver's low-latency flag where it has one (FTDI adapters otherwise batch reads for 16 ms).
// A pseudo-terminal refuses the serial ioctls (ENOTTY) and ignores the rate: both are tolerated
// and reported, so the same code drives the real board and the virtual one.
#pragma once

#include <string>

#include "delta/io/byte_stream.hpp"

namespace delta::io {

struct SerialPortInfo {
  bool low_latency = false;   // ASYNC_LOW_LATENCY set (false: the device has no such flag)
  bool rate_applied = false;  // the device accepted the rate (a pty accepts and ignores it)
  std::string notes;          // what was tolerated, one line, e.g. "TIOCGSERIAL: not a serial driver"
};

class SerialPort : public ByteStream {
 public:
  // Opens PATH (a device or a link to one, e.g. /dev/serial/by-id/...). Throws std::system_error
  // naming the path and what to do: not found, permission (the dialout group), in use.
  SerialPort(const std::string& path, int baud);
  ~SerialPort() override;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  std::size_t read_some(std::uint8_t* data, std::size_t capacity) override;
  void write_all(const std::uint8_t* data, std::size_t size, int timeout_ms = 100) override;
  int fd() const override { return fd_; }
  const std::string& name() const override { return path_; }
  const SerialPortInfo& info() const { return info_; }

 private:
  std::string path_;
  int fd_ = -1;
  SerialPortInfo info_;
};

// The termios speed constant of a rate (B115200, B1000000, ...); throws std::invalid_argument
// for a rate termios has no constant for.
unsigned baud_constant(int baud);

}  // namespace delta::io
