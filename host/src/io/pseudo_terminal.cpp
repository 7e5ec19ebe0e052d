// A pseudo-terminal linked at a path (see pseudo_terminal.hpp).
#include "delta/io/pseudo_terminal.hpp"

#include <fcntl.h>
#include <pty.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

#include "write_all.hpp"

namespace delta::io {
namespace {

// Where the link at PATH points ("" if PATH is not a link).
std::string link_target(const std::string& path) {
  char target[256] = {};
  const ssize_t length = ::readlink(path.c_str(), target, sizeof target - 1);
  return length > 0 ? std::string(target, static_cast<std::size_t>(length)) : std::string();
}

// A link at PATH may be replaced only if it is a link into /dev/pts whose pseudo-terminal is gone
// (a previous virtual board's that did not clean up). A live one is another board's: refused.
void check_replaceable(const std::string& path) {
  struct stat link_status {};
  if (::lstat(path.c_str(), &link_status) != 0) return;  // nothing there
  const std::string to = S_ISLNK(link_status.st_mode) ? link_target(path) : std::string();
  if (to.rfind("/dev/pts/", 0) != 0) {
    throw std::system_error(EEXIST, std::generic_category(),
                            path + ": exists and is not a link to a pseudo-terminal; choose another --link path");
  }
  struct stat pty_status {};
  if (::stat(to.c_str(), &pty_status) == 0) {
    throw std::system_error(EBUSY, std::generic_category(),
                            path + ": links to " + to +
                                ", a live pseudo-terminal (another virtual board?); stop it "
                                "or choose another --link path");
  }
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
  check_replaceable(link_path);
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
    // Opens and closes of the slave by other programs (ours was opened before the watch).
    opens_fd_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (opens_fd_ < 0 || ::inotify_add_watch(opens_fd_, slave_path_.c_str(), IN_OPEN | IN_CLOSE) < 0) {
      throw std::system_error(errno, std::generic_category(), "inotify on " + slave_path_);
    }
    ::unlink(link_path.c_str());
    if (::symlink(slave_path_.c_str(), link_path.c_str()) != 0) {
      throw std::system_error(errno, std::generic_category(), link_path + ": cannot link it to " + slave_path_);
    }
  } catch (...) {
    ::close(master_fd_);
    ::close(slave_fd_);
    if (opens_fd_ >= 0) ::close(opens_fd_);
    throw;
  }
}

PseudoTerminal::~PseudoTerminal() {
  if (link_target(link_path_) == slave_path_) ::unlink(link_path_.c_str());  // never another's link
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
  if (opens_fd_ >= 0) ::close(opens_fd_);
}

bool PseudoTerminal::release_exclusive() {
  alignas(inotify_event) char events[4096];
  bool closed = false;
  for (;;) {
    const ssize_t n = ::read(opens_fd_, events, sizeof events);
    if (n <= 0) break;
    for (ssize_t at = 0; at < n;) {
      const auto* event = reinterpret_cast<const inotify_event*>(events + at);
      if (event->mask & IN_OPEN) ++openers_;
      if ((event->mask & IN_CLOSE) && openers_ > 0) {
        --openers_;
        closed = true;
      }
      at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
    }
  }
  // The last other program closed PATH: a serial port's exclusive mode ends with its last close,
  // but the pty stays open here (ours), so it is cleared as the kernel would.
  if (closed && openers_ == 0) return ::ioctl(slave_fd_, TIOCNXCL) == 0;
  return false;
}

std::size_t PseudoTerminal::read_some(std::uint8_t* data, std::size_t capacity) {
  return detail::read_some_from(master_fd_, link_path_, data, capacity);
}

void PseudoTerminal::write_all(const std::uint8_t* data, std::size_t size, int timeout_ms) {
  detail::write_all_to(master_fd_, link_path_, data, size, timeout_ms);
}

}  // namespace delta::io
