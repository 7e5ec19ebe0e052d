// Writes every byte to a non-blocking descriptor, polling for room until a deadline (shared by the
// serial port and the pseudo-terminal).
#pragma once

#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <string>
#include <system_error>

namespace delta::io::detail {

inline void write_all_to(int fd, const std::string& name, const std::uint8_t* data, std::size_t size, int timeout_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (size > 0) {
    const ssize_t written = ::write(fd, data, size);
    if (written > 0) {
      data += written;
      size -= static_cast<std::size_t>(written);
      continue;
    }
    if (written < 0 && errno == EINTR) continue;
    if (written < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      throw std::system_error(errno, std::generic_category(), name + ": write");
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) throw std::system_error(ETIMEDOUT, std::generic_category(), name + ": write");
    pollfd p{fd, POLLOUT, 0};
    ::poll(&p, 1, static_cast<int>(left.count()));
  }
}

// Reads what is there without blocking; throws on a hang-up (the other side closed) or an error.
inline std::size_t read_some_from(int fd, const std::string& name, std::uint8_t* data, std::size_t capacity) {
  for (;;) {
    const ssize_t got = ::read(fd, data, capacity);
    if (got > 0) return static_cast<std::size_t>(got);
    if (got == 0) {
      // A terminal in raw mode with VMIN = VTIME = 0 (serial port, pty slave) reads 0 for "nothing
      // there" even when non-blocking; only with a hang-up pending does 0 mean the other side left.
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR)) != 0) {
        throw std::system_error(EPIPE, std::generic_category(), name + ": the other side hung up");
      }
      return 0;
    }
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) return 0;
    if (errno == EIO) throw std::system_error(EIO, std::generic_category(), name + ": the other side hung up");
    throw std::system_error(errno, std::generic_category(), name + ": read");
  }
}

}  // namespace delta::io::detail
