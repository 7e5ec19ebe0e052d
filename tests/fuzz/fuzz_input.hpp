// Shared by the harnesses: the fuzzer's bytes as a file (the readers take paths), and the rule
// that a reader may only answer with a value or an InputError.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "delta/run_files.hpp"

namespace delta::fuzz {

// One file per process, rewritten for every input; `extension` matters to the .mat importer.
inline std::string as_file(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  static const std::string path = "/tmp/delta_fuzz_" + std::to_string(::getpid()) + extension;
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) std::abort();
  if (size && std::fwrite(data, 1, size, file) != size) std::abort();
  std::fclose(file);
  forget_run_files();  // every input is a new run
  return path;
}

}  // namespace delta::fuzz
