// The byte stream's default wait: poll its descriptor (see byte_stream.hpp).
#include "delta/io/byte_stream.hpp"

#include <poll.h>

#include <cerrno>
#include <system_error>

namespace delta::io {

bool ByteStream::wait_readable(int timeout_ms) {
  pollfd p{fd(), POLLIN, 0};
  const int ready = ::poll(&p, 1, timeout_ms);
  if (ready < 0 && errno != EINTR) throw std::system_error(errno, std::generic_category(), name() + ": poll");
  return ready > 0;
}

}  // namespace delta::io
