// Where a test finds the tree: the build folder, the source folder and deltactl, found at run time.
// A test executable lives in <build>/tests (delta_add_gtest); the build's CMakeCache.txt names the
// source folder. No absolute path is compiled in, so a clone in another folder (CI's) compiles
// every test source to the same object and hits the compiler cache.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace delta::test {

namespace tree_detail {

[[noreturn]] inline void fail(const std::string& what) {
  std::fprintf(stderr, "tree_paths: %s\n", what.c_str());
  std::exit(2);
}

inline std::string find_binary_dir() {
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) fail("cannot read /proc/self/exe: " + error.message());
  // <build>/tests/<test executable>
  const std::filesystem::path build = exe.parent_path().parent_path();
  if (!std::filesystem::is_regular_file(build / "CMakeCache.txt", error)) {
    fail(exe.string() + " is not in <build>/tests: no " + (build / "CMakeCache.txt").string());
  }
  return build.string();
}

}  // namespace tree_detail

// The build folder (CMake's PROJECT_BINARY_DIR).
inline const std::string& binary_dir() {
  static const std::string dir = tree_detail::find_binary_dir();
  return dir;
}

// A variable of the build's cache (CMakeCache.txt's NAME:TYPE=VALUE), e.g. DELTA_NETWORK_WEIGHTS.
inline std::string cache_value(const std::string& name) {
  const std::string cache = binary_dir() + "/CMakeCache.txt";
  std::ifstream input(cache);
  for (std::string line; std::getline(input, line);) {
    const auto colon = line.find(':');
    const auto equals = line.find('=');
    if (colon != std::string::npos && equals != std::string::npos && colon < equals &&
        line.compare(0, colon, name) == 0 && colon == name.size()) {
      return line.substr(equals + 1);
    }
  }
  tree_detail::fail(cache + ": no " + name + " (reconfigure the build)");
}

// The source tree (CMake's PROJECT_SOURCE_DIR).
inline const std::string& source_dir() {
  static const std::string dir = cache_value("CMAKE_HOME_DIRECTORY");
  return dir;
}

// The deltactl this build made.
inline const std::string& deltactl_path() {
  static const std::string path = binary_dir() + "/bin/deltactl";
  return path;
}

}  // namespace delta::test

// The spellings the tests use (they were compile-time strings once): const char*, found at run time.
#define DELTA_SOURCE_DIR (::delta::test::source_dir().c_str())
#define DELTA_BINARY_DIR (::delta::test::binary_dir().c_str())
#define DELTACTL_PATH (::delta::test::deltactl_path().c_str())
