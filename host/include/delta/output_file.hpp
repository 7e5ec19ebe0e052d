// An output file that appears only when complete: written beside the target, renamed on commit().
#pragma once

#include <fstream>
#include <string>

namespace delta {

class OutputFile {
 public:
  explicit OutputFile(const std::string& path);  // throws InputError if the folder is not writable
  ~OutputFile();                                 // removes the partial file unless committed
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  std::ostream& stream() { return stream_; }
  void commit();  // flush, close and rename into place

 private:
  std::string path_;
  std::string temporary_path_;
  std::ofstream stream_;
  bool committed_ = false;
};

// Shortest decimal text that reads back to the same double.
std::string format_number(double value);

}  // namespace delta
