// The shipped data beside the program (see shipped_data.hpp).
#include "delta/shipped_data.hpp"

#include <filesystem>
#include <system_error>

namespace delta {

std::string shipped_data_dir() {
  namespace fs = std::filesystem;
  std::error_code ignored;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ignored);
  if (!exe.empty()) {
    const fs::path beside = exe.parent_path().parent_path() / "share/deltactl";
    if (fs::is_directory(beside, ignored)) return beside.string();
  }
  return "/usr/share/deltactl";
}

}  // namespace delta
