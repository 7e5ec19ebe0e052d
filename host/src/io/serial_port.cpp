// A serial port owned by the controller (see serial_port.hpp).
#include "delta/io/serial_port.hpp"

#include <fcntl.h>
#include <linux/serial.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include "write_all.hpp"

namespace delta::io {

unsigned baud_constant(int baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 500000:
      return B500000;
    case 921600:
      return B921600;
    case 1000000:
      return B1000000;
    case 1500000:
      return B1500000;
    case 2000000:
      return B2000000;
    case 3000000:
      return B3000000;
    default:
      throw std::invalid_argument("no termios rate constant for " + std::to_string(baud) + " baud");
  }
}

SerialPort::SerialPort(const std::string& path, int baud) : path_(path) {
  const speed_t speed = baud_constant(baud);
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    std::string advice;
    if (error == ENOENT) {
      advice = path.rfind("/dev/", 0) == 0 ? " (is the board plugged in? see /dev/serial/by-id/)"
                                           : " (is the board plugged in, or the virtual board that makes it running?)";
    }
    if (error == EACCES) advice = " (add the user to the dialout group, or run as the service user)";
    if (error == EBUSY) advice = " (another program holds it)";
    throw std::system_error(error, std::generic_category(), path + advice);
  }
  // Exclusive: an advisory lock that other careful programs (and a second deltactl) respect, and
  // TIOCEXCL, which makes the kernel refuse further opens by anyone but root.
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd_);
    throw std::system_error(error, std::generic_category(),
                            path +
                                ": in use by another program (if that is the controller, deltactl host serve, "
                                "ask it: deltactl host ctl status)");
  }
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) {
    const int error = errno;
    ::close(fd_);
    throw std::system_error(error, std::generic_category(), path + ": not a terminal device");
  }
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~(CSTOPB | PARENB | CRTSCTS);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  ::cfsetispeed(&tio, speed);
  ::cfsetospeed(&tio, speed);
  if (::tcsetattr(fd_, TCSANOW, &tio) != 0) {
    const int error = errno;
    ::close(fd_);
    throw std::system_error(error, std::generic_category(), path + ": cannot set raw 8N1 at " + std::to_string(baud));
  }
  termios check{};
  info_.rate_applied = ::tcgetattr(fd_, &check) == 0 && ::cfgetospeed(&check) == speed;
  if (::ioctl(fd_, TIOCEXCL) != 0) info_.notes += std::string("TIOCEXCL: ") + std::strerror(errno) + "; ";
  serial_struct serial{};
  if (::ioctl(fd_, TIOCGSERIAL, &serial) == 0) {
    serial.flags |= ASYNC_LOW_LATENCY;
    info_.low_latency = ::ioctl(fd_, TIOCSSERIAL, &serial) == 0;
    if (!info_.low_latency) info_.notes += std::string("TIOCSSERIAL low latency: ") + std::strerror(errno) + "; ";
  } else {
    info_.notes += std::string("TIOCGSERIAL: ") + std::strerror(errno) + " (not a serial driver, e.g. a pty); ";
  }
  ::tcflush(fd_, TCIOFLUSH);  // nothing stale from before the open
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t SerialPort::read_some(std::uint8_t* data, std::size_t capacity) {
  return detail::read_some_from(fd_, path_, data, capacity);
}

void SerialPort::write_all(const std::uint8_t* data, std::size_t size, int timeout_ms) {
  detail::write_all_to(fd_, path_, data, size, timeout_ms);
}

}  // namespace delta::io
