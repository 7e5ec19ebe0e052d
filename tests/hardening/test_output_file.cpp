// delta::OutputFile and the shared readers at the library level: targets that are not regular
// files, links, read-only files, failing writes, signals, and files used twice in one run.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "../support/run_command.hpp"
#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/json_input.hpp"
#include "delta/output_file.hpp"
#include "delta/run_files.hpp"

namespace delta {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using test::write_text;

// A fresh, empty folder per test.
fs::path fresh_folder(const std::string& name) {
  const fs::path folder = fs::path(::testing::TempDir()) / ("output_file_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(folder);
  fs::create_directories(folder);
  forget_run_files();
  return folder;
}

std::size_t entries(const fs::path& folder) {
  return static_cast<std::size_t>(std::distance(fs::directory_iterator(folder), fs::directory_iterator()));
}

TEST(OutputFile, FollowsALinkInsteadOfReplacingIt) {
  const fs::path folder = fresh_folder("link");
  write_text((folder / "real.txt").string(), "old\n");
  fs::create_symlink(folder / "real.txt", folder / "link.txt");
  OutputFile file((folder / "link.txt").string());
  file.stream() << "new\n";
  file.commit();
  EXPECT_TRUE(fs::is_symlink(folder / "link.txt"));
  EXPECT_EQ(read_text((folder / "real.txt").string()), "new\n");
  EXPECT_EQ(entries(folder), 2u);
}

TEST(OutputFile, RefusesAReadOnlyFileAndAFolder) {
  const fs::path folder = fresh_folder("readonly");
  const std::string locked = (folder / "locked.txt").string();
  write_text(locked, "keep\n");
  ::chmod(locked.c_str(), 0444);
  try {
    OutputFile file(locked);
    FAIL() << "a read-only file was accepted as an output";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("read-only"), std::string::npos) << error.what();
  }
  EXPECT_EQ(read_text(locked), "keep\n");
  EXPECT_THROW(OutputFile{folder.string()}, InputError);
  EXPECT_EQ(entries(folder), 1u);
}

// As root, a private device node (a broken writer must not replace the machine's /dev/null);
// otherwise the real one, which an ordinary user cannot replace anyway.
std::string device(const fs::path& folder, const std::string& name, unsigned minor) {
  const std::string path = (folder / name).string();
  return ::mknod(path.c_str(), S_IFCHR | 0666, ::makedev(1, minor)) == 0 ? path : "/dev/" + name;
}

TEST(OutputFile, WritesADeviceDirectlyAndLeavesItADevice) {
  const fs::path folder = fresh_folder("device");
  const std::string null = device(folder, "null", 3), full = device(folder, "full", 7);
  {
    OutputFile file(null);
    file.stream() << "discarded\n";
    file.commit();
  }
  struct stat status {};
  ASSERT_EQ(::stat(null.c_str(), &status), 0);
  EXPECT_TRUE(S_ISCHR(status.st_mode)) << null << " was replaced by a regular file";
  OutputFile to_full(full);
  to_full.stream() << std::string(1 << 16, 'x');
  EXPECT_THROW(to_full.commit(), InputError);
  ASSERT_EQ(::stat(full.c_str(), &status), 0);
  EXPECT_TRUE(S_ISCHR(status.st_mode));
}

TEST(OutputFile, ALongNameNeedsNoLongerTemporaryName) {
  const fs::path folder = fresh_folder("long");
  const std::string name = (folder / std::string(250, 'n')).string();  // NAME_MAX is 255
  OutputFile file(name);
  file.stream() << "ok\n";
  file.commit();
  EXPECT_EQ(read_text(name), "ok\n");
}

// The child writes with a file-size limit (a full disk without root), or dies of SIGINT mid-write.
int in_child(const std::function<void()>& body) {
  const pid_t child = ::fork();
  if (child == 0) {
    try {
      body();
    } catch (const InputError&) {
      ::_exit(2);
    }
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST(OutputFile, AFullDiskFailsTheCommitAndLeavesNothing) {
  const fs::path folder = fresh_folder("full");
  write_text((folder / "out.txt").string(), "previous\n");
  const int code = in_child([&] {
    ::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    OutputFile file((folder / "out.txt").string());
    file.stream() << std::string(100000, 'x');
    file.commit();
  });
  EXPECT_EQ(code, 2);
  EXPECT_EQ(read_text((folder / "out.txt").string()), "previous\n");
  EXPECT_EQ(entries(folder), 1u);
}

TEST(OutputFile, SigintRemovesTheTemporaryFile) {
  const fs::path folder = fresh_folder("sigint");
  const int code = in_child([&] {
    OutputFile file((folder / "out.txt").string());
    file.stream() << "partial" << std::flush;
    ::raise(SIGINT);
  });
  EXPECT_EQ(code, 128 + SIGINT);
  EXPECT_EQ(entries(folder), 0u) << "a partial file survived SIGINT";
}

TEST(RunFiles, AnOutputThatIsAnInputOrAnotherOutputIsRefused) {
  const fs::path folder = fresh_folder("same");
  track_run_files(true);
  const std::string data = (folder / "data.csv").string();
  write_text(data, "x_m,y_m,z_m\n0,0,-0.07\n");
  fs::create_symlink(data, folder / "alias.csv");
  read_csv(data, {"x_m"});
  EXPECT_THROW(OutputFile{(folder / "alias.csv").string()}, InputError);
  OutputFile first((folder / "a.txt").string());
  EXPECT_THROW(OutputFile{(folder / "." / "a.txt").string()}, InputError);
  EXPECT_EQ(read_text(data), "x_m,y_m,z_m\n0,0,-0.07\n");
  track_run_files(false);
}

TEST(JsonInput, DeepNestingIsAnErrorNotACrash) {
  const std::string deep = "{\"joint_offset\": " + std::string(100000, '[') + std::string(100000, ']') + "}";
  try {
    parse_json_input(deep, "deep.json");
    FAIL() << "accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(error.line(), 1u);
    EXPECT_NE(error.reason().find("nested deeper"), std::string::npos) << error.reason();
  }
}

TEST(JsonInput, AKeyGivenTwiceIsAnErrorNamingItsLine) {
  try {
    parse_json_input("{\n\"a\": 1,\n\"b\": {\"a\": 2},\n\"a\": 3\n}", "twice.json");
    FAIL() << "accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(error.line(), 4u);
    EXPECT_NE(error.reason().find("duplicate key 'a'"), std::string::npos) << error.reason();
  }
}

TEST(InputErrorText, QuotedExcerptIsShortAndPrintable) {
  const std::string shown = quoted_excerpt(std::string("\x1b[31mred\0", 9) + std::string(10000000, 'x'));
  EXPECT_LT(shown.size(), 80u);
  EXPECT_EQ(shown.find('\x1b'), std::string::npos);
  EXPECT_EQ(shown.find('\0'), std::string::npos);
  EXPECT_NE(shown.find("\\x1b"), std::string::npos);
}

}  // namespace
}  // namespace delta
