// An output file that appears only when complete: written beside the target, renamed on commit().
//
// The target is resolved first: a link is followed, a folder or read-only file is refused, and a
// target that is not a regular file (/dev/null, a pipe, a terminal) is written directly, never
// replaced. Every write and the close are checked; on failure, destruction or SIGINT / SIGTERM /
// SIGHUP the temporary file is removed and the target is left as it was.
#pragma once

#include <fstream>
#include <string>

namespace delta {

class OutputFile {
 public:
  explicit OutputFile(const std::string& path);  // throws InputError: no such folder, a folder, read-only
  ~OutputFile();                                 // removes the partial file unless committed
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  std::ostream& stream();
  // The file to write for writers that need a name (matio, gnuplot): the temporary file, or the
  // target itself when that is not a regular file. Written there, the data is checked by the caller.
  const std::string& writing_path() const { return writing_path_; }
  // Flush and close, checking both; throws InputError naming the target (disk full, ...).
  void finish();
  // finish(), then rename into place. Commands with several outputs finish() all, then commit() all.
  void commit();

 private:
  std::string path_;          // as given, for messages
  std::string target_path_;   // links resolved
  std::string writing_path_;  // temporary file, or the target when written directly
  bool direct_ = false;
  int slot_ = -1;  // entry in the signal clean-up table
  std::ofstream stream_;
  bool finished_ = false;
  bool committed_ = false;
};

// Shortest decimal text that reads back to the same double.
std::string format_number(double value);

}  // namespace delta
