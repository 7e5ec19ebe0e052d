// Registry of the files a run reads and writes: identity by device and inode, else by path.
#include "delta/run_files.hpp"

#include <sys/stat.h>

#include <filesystem>
#include <map>
#include <mutex>

#include "delta/input_error.hpp"

namespace delta {
namespace {

enum class Role { input, output };

struct Registry {
  std::mutex mutex;
  bool enabled = false;
  std::map<std::string, std::pair<Role, std::string>> files;  // identity -> role, name as given
};

Registry& registry() {
  static Registry instance;
  return instance;
}

// "dev:inode" for an existing file, else the absolute path with links resolved as far as they exist.
std::string identity(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) == 0) {
    return std::to_string(status.st_dev) + ":" + std::to_string(status.st_ino);
  }
  std::error_code error;
  const std::filesystem::path resolved = std::filesystem::weakly_canonical(path, error);
  return "path:" + (error ? path : resolved.string());
}

bool is_special(const std::string& path) {
  struct stat status {};
  return ::stat(path.c_str(), &status) == 0 && !S_ISREG(status.st_mode);
}

void note(const std::string& path, Role role) {
  Registry& files = registry();
  const std::lock_guard<std::mutex> lock(files.mutex);
  if (!files.enabled || is_special(path)) return;
  const std::string key = identity(path);
  const auto found = files.files.find(key);
  if (found != files.files.end()) {
    const auto& [previous_role, previous_name] = found->second;
    if (role == Role::input && previous_role == Role::input) return;  // reading a file twice is fine
    const std::string what = previous_role == Role::input ? "an input" : "another output";
    throw InputError(path, 0,
                     "is the same file as " + what + " of this command (" + previous_name +
                         "); refused so that it is not overwritten");
  }
  files.files.emplace(key, std::make_pair(role, path));
}

}  // namespace

void track_run_files(bool enabled) {
  Registry& files = registry();
  const std::lock_guard<std::mutex> lock(files.mutex);
  files.enabled = enabled;
  files.files.clear();
}

void note_input_file(const std::string& path) { note(path, Role::input); }

void note_output_file(const std::string& path) { note(path, Role::output); }

void forget_output_file(const std::string& path) {
  Registry& files = registry();
  const std::lock_guard<std::mutex> lock(files.mutex);
  for (auto entry = files.files.begin(); entry != files.files.end(); ++entry) {
    if (entry->second.first == Role::output && entry->second.second == path) {
      files.files.erase(entry);
      return;
    }
  }
}

void forget_run_files() {
  Registry& files = registry();
  const std::lock_guard<std::mutex> lock(files.mutex);
  files.files.clear();
}

}  // namespace delta
