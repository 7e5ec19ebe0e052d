// A pseudo-terminal linked at a path (see pseudo_terminal.hpp).
#include "delta/io/pseudo_terminal.hpp"

#include <fcntl.h>
#include <pty.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

#include "write_all.hpp"

namespace delta::io {
namespace {

// A link at PATH may be replaced only if it is a link to a pseudo-terminal that is gone or
// to /dev/pts (a previous virtual board's).
bool replaceable(const std::string& path) {
  struct stat link_status {};
  if (::lstat(path.c_str(), &link_status) != 0) return true;  // nothing there
  if (!S_ISLNK(link_status.st_mode)) return false;
  char target[256] = {};
  const ssize_t length = ::readlink(path.c_str(), target, sizeof target - 1);
  if (length <= 0) return false;
  const std::string to(target, static_cast<std::size_t>(length));
  return to.rfind("/dev/pts/", 0) == 0;
}

void make_raw(int fd) {
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) throw std::system_error(errno, std::generic_category(), "tcgetattr on a pty");
  ::cfmakeraw(&tio);
  if (::tcsetattr(fd, TCSANOW, &tio) != 0)
    throw std::system_error(errno, std::generic_category(), "tcsetattr on a pty");
}

}  // namespace

PseudoTerminal::PseudoTerminal(const std::string& link_path) : link_path_(link_path) {
  if (!replaceable(link_path)) {
    throw std::system_error(EEXIST, std::generic_category(),
                            link_path + ": exists and is not a link to a pseudo-terminal; choose another --link path");
  }
  char name[128] = {};
  if (::openpty(&master_fd_, &slave_fd_, name, nullptr, nullptr) != 0) {
    throw std::system_error(errno, std::generic_category(), "openpty");
  }
  slave_path_ = name;
  try {
    make_raw(master_fd_);
    make_raw(slave_fd_);
    const int flags = ::fcntl(master_fd_, F_GETFL);
    ::fcntl(master_fd_, F_SETFL, flags | O_NONBLOCK);
    ::fcntl(master_fd_, F_SETFD, FD_CLOEXEC);
    ::fcntl(slave_fd_, F_SETFD, FD_CLOEXEC);
    ::unlink(link_path.c_str());
    if (::symlink(slave_path_.c_str(), link_path.c_str()) != 0) {
      throw std::system_error(errno, std::generic_category(), link_path + ": cannot link it to " + slave_path_);
    }
  } catch (...) {
    ::close(master_fd_);
    ::close(slave_fd_);
    throw;
  }
}

PseudoTerminal::~PseudoTerminal() {
  ::unlink(link_path_.c_str());
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
}

std::size_t PseudoTerminal::read_some(std::uint8_t* data, std::size_t capacity) {
  return detail::read_some_from(master_fd_, link_path_, data, capacity);
}

void PseudoTerminal::write_all(const std::uint8_t* data, std::size_t size, int timeout_ms) {
  detail::write_all_to(master_fd_, link_path_, data, size, timeout_ms);
}

}  // namespace delta::io
