// Atomic output files, their clean-up on signals, and exact number formatting.
#include "delta/output_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "delta/input_error.hpp"
#include "delta/run_files.hpp"

namespace delta {
namespace {

// Temporary files alive now, for the signal handler (which may only call async-signal-safe
// functions: it unlinks what the table holds, then dies of the signal as before).
constexpr int kSlots = 64;
std::atomic<char*> temporary_files[kSlots];

void remove_temporaries_and_die(int signal_number) {
  for (auto& slot : temporary_files) {
    if (char* path = slot.load()) ::unlink(path);
  }
  ::signal(signal_number, SIG_DFL);
  ::raise(signal_number);
}

int register_temporary(const std::string& path) {
  // Not over a handler the program installed (the host controller's stop requests). SIGINT and
  // SIGTERM also where they were inherited ignored (a shell starts `cmd &` with SIGINT ignored; an
  // interrupt sent to it must still leave no file); SIGHUP only where default (nohup keeps working).
  static const bool installed = [] {
    for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction present {};
      if (::sigaction(signal_number, nullptr, &present) != 0 || (present.sa_flags & SA_SIGINFO)) continue;
      const bool ignored = present.sa_handler == SIG_IGN;
      if (present.sa_handler == SIG_DFL || (ignored && signal_number != SIGHUP)) {
        ::signal(signal_number, remove_temporaries_and_die);
      }
    }
    return true;
  }();
  (void)installed;
  for (int i = 0; i < kSlots; ++i) {
    char* expected = nullptr;
    char* copy = ::strdup(path.c_str());
    if (temporary_files[i].compare_exchange_strong(expected, copy)) return i;
    std::free(copy);
  }
  return -1;  // more than kSlots files open at once: still removed on errors, not on signals
}

void unregister_temporary(int slot) {
  if (slot < 0) return;
  std::free(temporary_files[slot].exchange(nullptr));
}

std::string reason_of(int error_number) { return std::strerror(error_number); }

}  // namespace

OutputFile::OutputFile(const std::string& path) : path_(path), target_path_(path) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (path.empty()) throw InputError("(empty path)", 0, "an output needs a file name");
  struct stat target {};
  bool exists = ::stat(path.c_str(), &target) == 0;
  // /dev/stdout, /dev/fd/N and the like name an open descriptor (perhaps a pipe, or a file opened
  // for appending): written directly, like any target that is not a regular file.
  const bool names_descriptor = path.rfind("/dev/", 0) == 0 || path.rfind("/proc/", 0) == 0;
  const fs::file_status link_status = fs::symlink_status(path, error);
  if (fs::is_symlink(link_status) && !(exists && (names_descriptor || !S_ISREG(target.st_mode)))) {
    const fs::path resolved = fs::weakly_canonical(path, error);
    if (error) throw InputError(path, 0, "a link that cannot be followed: " + error.message());
    target_path_ = resolved.string();
    exists = ::stat(target_path_.c_str(), &target) == 0;
  }
  mode_t mode = 0666;
  if (exists) {
    if (S_ISDIR(target.st_mode)) throw InputError(path, 0, "is a folder, not a file");
    if (::access(target_path_.c_str(), W_OK) != 0 || (target.st_mode & 0222) == 0) {
      throw InputError(path, 0, "is read-only; not overwritten");
    }
    direct_ = !S_ISREG(target.st_mode) || names_descriptor;
    mode = target.st_mode & 07777;
  }
  if (direct_) {
    writing_path_ = target_path_;
    return;
  }
  note_output_file(path_);
  const fs::path folder = fs::path(target_path_).parent_path();
  std::string pattern = (folder.empty() ? std::string(".") : folder.string()) + "/.deltactl-XXXXXX";
  const int descriptor = ::mkstemp(pattern.data());
  if (descriptor < 0) {
    const int error_number = errno;
    forget_output_file(path_);
    errno = error_number;
    throw InputError(path, 0, "cannot write here (" + reason_of(errno) + "; does the folder exist?)");
  }
  if (!exists) {
    const mode_t mask = ::umask(0);
    ::umask(mask);
    mode &= ~mask;
  }
  ::fchmod(descriptor, mode);
  ::close(descriptor);
  writing_path_ = pattern;
  slot_ = register_temporary(writing_path_);
}

OutputFile::~OutputFile() {
  if (!committed_ && !direct_) {
    stream_.close();
    std::remove(writing_path_.c_str());
  }
  unregister_temporary(slot_);
  if (!direct_) forget_output_file(path_);
}

std::ostream& OutputFile::stream() {
  if (!stream_.is_open() && !finished_) {
    stream_.open(writing_path_, direct_ ? std::ios::out | std::ios::app : std::ios::out | std::ios::trunc);
    if (!stream_) throw InputError(path_, 0, "cannot be opened for writing (" + reason_of(errno) + ")");
  }
  return stream_;
}

void OutputFile::finish() {
  if (finished_) return;
  finished_ = true;
  if (!stream_.is_open()) return;
  stream_.flush();
  bool written = static_cast<bool>(stream_);
  stream_.close();
  written = written && !stream_.fail();
  if (!written) throw InputError(path_, 0, "could not be written completely (disk full?); nothing written");
}

void OutputFile::commit() {
  finish();
  if (!direct_ && std::rename(writing_path_.c_str(), target_path_.c_str()) != 0) {
    throw InputError(path_, 0, "could not be put in place (" + reason_of(errno) + ")");
  }
  committed_ = true;
}

std::string format_number(double value) {
  char buffer[64];
  if (value == 0.0) value = 0.0;  // print -0 as 0
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

}  // namespace delta
