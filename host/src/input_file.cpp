// Opening input files: the reason a path cannot be read, named before reading starts.
#include "delta/input_file.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include "delta/input_error.hpp"
#include "delta/run_files.hpp"

namespace delta {

void check_input_file(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0)
    throw InputError(path, 0, std::string("cannot open file: ") + std::strerror(errno));
  if (S_ISDIR(status.st_mode)) throw InputError(path, 0, "is a folder, not a file");
  if (!S_ISREG(status.st_mode)) throw InputError(path, 0, "not a regular file (a FIFO, a device or a socket)");
}

std::ifstream open_input_file(const std::string& path) {
  check_input_file(path);
  note_input_file(path);
  std::ifstream input(path, std::ios::binary);
  if (!input) throw InputError(path, 0, std::string("cannot open file: ") + std::strerror(errno));
  return input;
}

}  // namespace delta
