// A pseudo-terminal whose slave side is linked at a path of the user's choice, so that any
// program that opens PATH as a serial port talks to whoever holds the master side (the virtual
// board). Both sides raw (no echo, no line discipline). The link is removed when this object
// goes (if it is still ours); a stale link (to a pty that is gone) is replaced, anything else at
// PATH, a live pty's link included, is refused.
#pragma once

#include <string>

#include "delta/io/byte_stream.hpp"

namespace delta::io {

class PseudoTerminal : public ByteStream {
 public:
  explicit PseudoTerminal(const std::string& link_path);
  ~PseudoTerminal() override;
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;

  // The master side: what the other program writes to PATH arrives here.
  std::size_t read_some(std::uint8_t* data, std::size_t capacity) override;
  void write_all(const std::uint8_t* data, std::size_t size, int timeout_ms = 100) override;
  int fd() const override { return master_fd_; }
  const std::string& name() const override { return link_path_; }
  const std::string& slave_path() const { return slave_path_; }  // /dev/pts/N
  // Call now and then: once the last other program that opened PATH has closed it, clears the
  // exclusive mode (TIOCEXCL) it may have set, as a serial port's last close does (this object
  // keeps the pty open). Returns true when it cleared it.
  bool release_exclusive();

 private:
  std::string link_path_;
  std::string slave_path_;
  int master_fd_ = -1;
  int slave_fd_ = -1;  // held open so that a client's close does not hang up the master
  int opens_fd_ = -1;  // inotify: other programs' opens and closes of the slave
  int openers_ = 0;
};

}  // namespace delta::io
