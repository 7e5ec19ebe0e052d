// Atomic output files and exact number formatting.
#include "delta/output_file.hpp"

#include <unistd.h>

#include <charconv>
#include <cstdio>

#include "delta/input_error.hpp"

namespace delta {

OutputFile::OutputFile(const std::string& path)
    : path_(path), temporary_path_(path + ".partial." + std::to_string(::getpid())) {
  stream_.open(temporary_path_, std::ios::out | std::ios::trunc);
  if (!stream_) throw InputError(path, 0, "cannot write here (does the folder exist?)");
}

OutputFile::~OutputFile() {
  if (!committed_) {
    stream_.close();
    std::remove(temporary_path_.c_str());
  }
}

void OutputFile::commit() {
  stream_.flush();
  const bool written = static_cast<bool>(stream_);
  stream_.close();
  if (!written || std::rename(temporary_path_.c_str(), path_.c_str()) != 0) {
    std::remove(temporary_path_.c_str());
    throw InputError(path_, 0, "could not be written completely (disk full or folder removed?)");
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
