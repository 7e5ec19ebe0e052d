// Opening input files with one message per failure: missing, a folder, unreadable, or too large.
#pragma once

#include <fstream>
#include <string>

namespace delta {

// Largest input read whole (JSON) and longest line of a CSV: far beyond any real file, small
// enough that /dev/zero or a file without newlines fails fast instead of filling the memory.
constexpr std::size_t kMaxInputBytes = 16u << 20;
constexpr std::size_t kMaxLineBytes = 1u << 16;

// Throws InputError(path, 0, reason) when the path is missing, a folder, not a regular file (a
// FIFO, a device or a socket: opening a FIFO blocks until a writer comes, a device may never end),
// or cannot be read. Every reader of an input file opens it through here, or calls
// check_input_file first when it opens the file itself.
std::ifstream open_input_file(const std::string& path);
void check_input_file(const std::string& path);

}  // namespace delta
