// deltactl against hostile and careless input: one test per way an input or an output can go
// wrong, then the bad-input table that runs every command on one shared set of malformed files. Each asserts exit code
// 2, a one-line message naming the file, line or option, and outputs left exactly as they were.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <matio.h>

#include "../support/run_command.hpp"
#include "support/tree_paths.hpp"

namespace delta {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using test::run_deltactl;
using test::write_text;

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";
const std::string kHeader = "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m\n";

fs::path folder() {
  static const fs::path path = [] {
    const fs::path p = fs::path(::testing::TempDir()) / ("hardening_" + std::to_string(::getpid()));
    fs::remove_all(p);
    fs::create_directories(p);
    return p;
  }();
  return path;
}

std::string temp(const std::string& name) { return (folder() / name).string(); }

// A valid recording of the nominal robot near home: `rows` rows, small motion on every axis.
std::string recording_text(int rows) {
  std::string text = kHeader;
  for (int i = 0; i < rows; ++i) {
    const double s = 0.001 * (i % 7), c = 0.001 * (i % 5), z = -0.072 - 0.0005 * (i % 3);
    text += std::to_string(0.1 * i) + ",30,30,30," + std::to_string(s) + "," + std::to_string(c) + "," +
            std::to_string(z) + "\n";
  }
  return text;
}

// The validation recording of the nominal robot, made once.
const std::string& good_recording() {
  static const std::string path = [] {
    const std::string p = temp("good.csv");
    const auto result = run_deltactl("simulate --experiment validation --out " + p);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return p;
  }();
  return path;
}

std::size_t lines(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

void expect_bad_input(const test::CommandResult& result, const std::string& must_name, const std::string& context) {
  EXPECT_EQ(result.exit_code, 2) << context << "\n" << result.err.substr(0, 500);
  EXPECT_NE(result.err.find(must_name), std::string::npos)
      << context << ": message must name '" << must_name << "': " << result.err.substr(0, 500);
  EXPECT_EQ(lines(result.err), 1u) << context << ": " << result.err.substr(0, 500);
  EXPECT_LT(result.err.size(), 400u) << context << ": " << result.err.substr(0, 500);
}

// The files of a folder (leftovers of a failed command show up here).
std::vector<std::string> listing(const fs::path& path) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(path)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// deltactl with a file-size limit: writes beyond `kib` KiB fail as on a full disk.
test::CommandResult run_on_full_disk(const std::string& arguments, int kib) {
  // dash counts ulimit -f in 512-byte blocks; SIGXFSZ ignored so that write() fails with EFBIG.
  return run_deltactl(arguments, "trap '' XFSZ; ulimit -f " + std::to_string(2 * kib) + "; ");
}

// Commands that once ran for ever or grew without bound: a regression fails instead of hanging.
const std::string kBounded = "ulimit -v 2000000; timeout 60 ";

// ---- Deep JSON is bad input, not a crash, in every effects and weights reader.
TEST(HostileInput, DeeplyNestedJsonIsBadInputInEveryReader) {
  const std::string deep = temp("deep.json");
  write_text(deep, "{\"joint_offset\": " + std::string(100000, '[') + std::string(100000, ']') + "}\n");
  const std::string out = temp("d1_out");
  for (const std::string& command :
       {"simulate --effects " + deep + " --out " + out,
        "ik --weights " + deep + " --in " + good_recording() + " --out " + out,
        "quantise --weights " + deep + " --out-dir " + folder().string(),
        "export-matlab --weights " + deep + " --out " + out + ".mat", "accuracy --weights " + deep,
        "table1 --data " + good_recording() + " --holdout " + good_recording() + " --network " + deep}) {
    const auto result = run_deltactl(command);
    expect_bad_input(result, deep + ":1: JSON nested deeper", command);
  }
  EXPECT_FALSE(fs::exists(out));
}

// ---- The output writer never replaces devices, links or read-only files.
TEST(SafeOutputs, OutputsThatAreNotPlainFilesAreNeverReplaced) {
  const std::string recording = recording_text(20);
  const std::string in = temp("d2_in.csv");
  write_text(in, recording);
  // As root a private null device: a broken writer must not replace the machine's /dev/null.
  std::string null = temp("d2_null");
  if (::mknod(null.c_str(), S_IFCHR | 0666, ::makedev(1, 3)) != 0) null = "/dev/null";
  const auto to_null = run_deltactl("ik --model nominal --in " + in + " --out " + null);
  EXPECT_EQ(to_null.exit_code, 0) << to_null.err;
  struct stat status {};
  ASSERT_EQ(::stat(null.c_str(), &status), 0);
  EXPECT_TRUE(S_ISCHR(status.st_mode)) << null << " is no longer a device";

  const std::string real = temp("d2_real.csv"), link = temp("d2_link.csv");
  write_text(real, "old\n");
  fs::create_symlink(real, link);
  const auto through_link = run_deltactl("ik --model nominal --in " + in + " --out " + link);
  EXPECT_EQ(through_link.exit_code, 0) << through_link.err;
  EXPECT_TRUE(fs::is_symlink(link)) << "the link was replaced";
  EXPECT_NE(read_text(real).find("alpha1_deg"), std::string::npos);

  // A link to this process's stdout (as /dev/stdout is), here a pipe: written into, not replaced.
  const std::string to_stdout = temp("d2_stdout");
  fs::create_symlink("/proc/self/fd/1", to_stdout);
  const auto piped = run_deltactl("ik --model nominal --in " + in + " --out " + to_stdout + " | cat");
  EXPECT_EQ(piped.out.rfind("alpha1_deg,alpha2_deg,alpha3_deg\n", 0), 0u) << piped.out << piped.err;
  EXPECT_TRUE(fs::is_symlink(to_stdout));

  const std::string locked = temp("d2_locked.csv");
  write_text(locked, "keep\n");
  ::chmod(locked.c_str(), 0444);
  expect_bad_input(run_deltactl("ik --model nominal --in " + in + " --out " + locked), locked + ": is read-only",
                   "read-only");
  EXPECT_EQ(read_text(locked), "keep\n");
}

// ---- A full disk is an error, not exit 0 with empty or truncated files.
TEST(SafeOutputs, AFullDiskIsAnErrorAndLeavesNoFile) {
  const fs::path where = folder() / "d3";
  fs::create_directories(where);
  const std::string mat = (where / "net.mat").string();
  const std::string png = (where / "errors.png").string();
  const std::string angles = (where / "angles.csv").string();
  expect_bad_input(run_on_full_disk("export-matlab --weights " + kWeights + " --out " + mat, 1), mat, "export-matlab");
  expect_bad_input(run_on_full_disk("compare --data " + good_recording() + " --plot " + png, 8), png, "compare --plot");
  expect_bad_input(run_on_full_disk("ik --model nominal --in " + good_recording() + " --out " + angles, 16), angles,
                   "ik");
  EXPECT_TRUE(listing(where).empty()) << "left: " << (listing(where).empty() ? "" : listing(where).front());
  // With room, the same commands succeed (the limit, not the command, made them fail).
  EXPECT_EQ(run_deltactl("export-matlab --weights " + kWeights + " --out " + mat).exit_code, 0);
}

// ---- Numeric options range-checked at parse time, naming the option.
TEST(OptionRanges, NumericOptionsAreRangeChecked) {
  const std::string out = temp("d4_out");
  const std::string rec = good_recording();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"quantise --weights " + kWeights + " --out-dir " + folder().string() + " --vectors -1", "--vectors"},
      {"simulate --out " + out + " --seed -1", "--seed"},
      {"simulate --out " + out + " --samples -5", "--samples"},
      {"simulate --out " + out + " --rate -10", "--rate"},
      {"simulate --out " + out + " --rate inf", "--rate"},
      {"simulate --out " + out + " --noise-deg -1", "--noise-deg"},
      {"simulate --out " + out + " --noise-deg nan", "--noise-deg"},
      {"accuracy --weights " + kWeights + " --margin-mm nan", "--margin-mm"},
      {"accuracy --weights " + kWeights + " --grid-points 100000", "--grid-points"},
      {"accuracy --weights " + kWeights + " --bound-deg 0", "--bound-deg"},
      {"train --data " + rec + " --out " + out + " --validation nan", "--validation"},
      {"train --data " + rec + " --out " + out + " --seed -1", "--seed"},
      {"diagnose --data " + rec + " --holdout " + rec + " --json " + out + " --predictions " + out +
           "2 --significance nan",
       "--significance"},
      {"cosim --weights " + kWeights + " --duration inf", "--duration"},
      {"cosim --weights " + kWeights + " --duration 1e12", "--duration"},
      {"joint-loop --load-step nan", "--load-step"},
      {"joint-loop --load-step 1", "--load-step"},
      {"ik --model nominal --backend fixed --in " + rec + " --out " + out, "--backend"},
  };
  for (const auto& [command, option] : cases) expect_bad_input(run_deltactl(command, kBounded), option, command);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(folder() / "golden_vectors.txt"));
}

// ---- Unbounded reads.
TEST(HostileInput, InputsWithoutLineBreaksOrOfAbsurdSizeFailFast) {
  const std::string out = temp("d5_out.csv"), no_breaks = temp("d5_no_breaks.csv"), huge = temp("d5_huge.json");
  write_text(no_breaks, std::string(200000, '1'));
  { std::ofstream(huge) << ""; }
  fs::resize_file(huge, (std::uintmax_t{17} << 20));  // sparse: 17 MiB of zero bytes
  expect_bad_input(run_deltactl("ik --model nominal --in " + no_breaks + " --out " + out, kBounded),
                   no_breaks + ":1: line longer than", "csv");
  expect_bad_input(run_deltactl("simulate --effects " + huge + " --out " + out, kBounded), huge + ": larger than",
                   "json");
  // A device is not read at all (it might never end).
  expect_bad_input(run_deltactl("ik --model nominal --in /dev/zero --out " + out, kBounded),
                   "/dev/zero: not a regular file", "csv device");
  expect_bad_input(run_deltactl("simulate --effects /dev/zero --out " + out, kBounded), "/dev/zero: not a regular file",
                   "json device");
  EXPECT_FALSE(fs::exists(out));
}

// ---- The lab's recording readers: a FIFO blocks an open until a writer comes, so every reader
// refuses one before opening it (plot, merge's two logs, train, diagnose's two recordings, and
// the other readers of recordings and JSON).
TEST(LabInputs, EveryReaderRefusesAFifoAtOnce) {
  const std::string fifo = temp("lab_fifo.csv"), out = temp("lab_fifo_out.csv"), out2 = temp("lab_fifo_out2.csv");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string rec = good_recording();
  const std::vector<std::string> commands = {
      "plot " + fifo + " --out " + out,
      "merge --run " + fifo + " --stage " + rec + " --out " + out,
      "merge --run " + rec + " --stage " + fifo + " --out " + out,
      "train --data " + fifo + " --out " + out,
      "diagnose --data " + fifo + " --holdout " + rec + " --json " + out + " --predictions " + out2,
      "diagnose --data " + rec + " --holdout " + fifo + " --json " + out + " --predictions " + out2,
      "compare --data " + fifo,
      "ik --model nominal --in " + fifo + " --out " + out,
      "ik --weights " + fifo + " --in " + rec + " --out " + out,
      "simulate --effects " + fifo + " --out " + out};
  for (const std::string& command : commands) {
    // timeout: before, each of these waited for a writer for ever (exit 124 here).
    expect_bad_input(run_deltactl(command, "timeout 10 "), fifo + ": not a regular file", command);
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out2));
}

// Numbers in recordings are decimal: a hexadecimal float (0x1p5, which strtod reads as 32) is
// not a number for any reader, named with its line.
TEST(LabInputs, HexadecimalFloatsAreNotNumbers) {
  const std::string hex = temp("lab_hex.csv"), out = temp("lab_hex_out.csv"), out2 = temp("lab_hex_out2.csv");
  std::string text = recording_text(60);
  const std::size_t line3 = text.find('\n', text.find('\n', text.find('\n') + 1) + 1) + 1;  // the 4th line
  text.replace(line3, text.find(',', line3) - line3, "0x1p5");                              // its t_s
  write_text(hex, text);
  const std::string rec = good_recording();
  for (const std::string& command :
       {"plot " + hex + " --out " + out, "merge --run " + hex + " --stage " + rec + " --out " + out,
        "merge --run " + rec + " --stage " + hex + " --out " + out, "train --data " + hex + " --out " + out,
        "diagnose --data " + rec + " --holdout " + hex + " --json " + out + " --predictions " + out2,
        "compare --data " + hex}) {
    expect_bad_input(run_deltactl(command), hex + ":4: column 't_s': '0x1p5' is not a number", command);
  }
  // The same in the trajectory of a run (a waypoint of move:) and in a numeric option.
  expect_bad_input(run_deltactl("host run --port " + temp("no_board") + " --weights " + kWeights +
                                " --trajectory 'move:0,0,-0x1p-4' --record " + out),
                   "waypoint", "move: waypoint");
  expect_bad_input(run_deltactl("cosim --weights " + kWeights + " --duration 0x1p1"), "--duration", "--duration");
  expect_bad_input(run_deltactl("virtual-board --link " + temp("hex_tty") + " --start-angles 30,0x1e,30"),
                   "--start-angles", "--start-angles");
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out2));
}

// merge applies the bounds diagnose and train apply, to the file the value is in: a run row of
// 1e308 deg or a stage row 1e6 m away is refused naming that file's line, and no DATA.csv.
TEST(LabInputs, MergeRefusesImplausibleRowsOfTheFileTheyAreIn) {
  const std::string rec = good_recording(), out = temp("lab_merge_out.csv");
  std::string text = read_text(rec);
  std::vector<std::string> lines;
  std::istringstream stream(text);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  std::size_t header = 0;
  while (lines[header].rfind('#', 0) == 0) ++header;
  auto with_field = [&](std::size_t row, std::size_t column, const std::string& value) {
    std::vector<std::string> copy = lines;
    std::string& line = copy[header + row];
    std::size_t begin = 0;
    for (std::size_t k = 0; k < column; ++k) begin = line.find(',', begin) + 1;
    line.replace(begin, line.find(',', begin) - begin, value);
    std::string joined;
    for (const std::string& l : copy) joined += l + "\n";
    return joined;
  };
  const std::string angle = temp("lab_merge_angle.csv"), far = temp("lab_merge_far.csv");
  write_text(angle, with_field(200, 1, "1e308"));  // alpha1_deg
  write_text(far, with_field(300, 4, "1e6"));      // x_m
  expect_bad_input(run_deltactl("merge --run " + angle + " --stage " + rec + " --out " + out),
                   angle + ":" + std::to_string(header + 201) + ": column 'alpha1_deg'", "run row");
  expect_bad_input(run_deltactl("merge --run " + rec + " --stage " + far + " --out " + out),
                   far + ":" + std::to_string(header + 301) + ": column 'x_m'", "stage row");
  EXPECT_FALSE(fs::exists(out));
}

// A 2 MB compressed .mat inflated to gigabytes before it was rejected: sizes are checked first.
TEST(HostileInput, ACompressedMatBombIsRejectedBeforeItIsInflated) {
  const std::string bomb = temp("d5_bomb.mat"), out = temp("d5_bomb.json");
  {
    std::vector<double> zeros(std::size_t{3} * 4000000, 0.0);  // 96 MB of zeros, about 100 kB compressed
    std::size_t dims[2] = {4000000, 3};
    mat_t* file = Mat_CreateVer(bomb.c_str(), nullptr, MAT_FT_MAT5);
    ASSERT_NE(file, nullptr);
    matvar_t* variable = Mat_VarCreate("IW", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, zeros.data(), MAT_F_DONT_COPY_DATA);
    ASSERT_EQ(Mat_VarWrite(file, variable, MAT_COMPRESSION_ZLIB), 0);
    Mat_VarFree(variable);
    Mat_Close(file);
  }
  ASSERT_LT(fs::file_size(bomb), 2000000u);
  expect_bad_input(run_deltactl("import-matlab --in " + bomb + " --out " + out, kBounded),
                   bomb + ": a compressed variable inflates beyond", "bomb");
  EXPECT_FALSE(fs::exists(out));
}

// The .mat inputs the fuzzer found (libmatio allocated 1.6 and 8.5 GB for them): bad input, in
// bounded memory.
TEST(HostileInput, MatFilesFoundByTheFuzzerAreBadInput) {
  const fs::path corpus = fs::path(DELTA_SOURCE_DIR) / "tests/fuzz/corpus/mat";
  int found = 0;
  for (const auto& entry : fs::directory_iterator(corpus)) {
    if (entry.path().filename().string().rfind("regression-", 0) != 0) continue;
    ++found;
    const std::string mat = temp("d5_" + entry.path().filename().string() + ".mat");
    fs::copy_file(entry.path(), mat, fs::copy_options::overwrite_existing);
    expect_bad_input(run_deltactl("import-matlab --in " + mat + " --out " + temp("d5_fuzz.json"), "ulimit -v 400000; "),
                     mat, entry.path().string());
  }
  EXPECT_GE(found, 3);
  EXPECT_FALSE(fs::exists(temp("d5_fuzz.json")));
}

// ---- A command's outputs appear together or not at all.
TEST(WholeOutputs, QuantiseWritesItsFileSetWhollyOrNotAtAll) {
  const fs::path where = folder() / "d6";
  fs::create_directories(where / "golden_vectors.txt");  // the last file cannot be written
  const auto result = run_deltactl("quantise --weights " + kWeights + " --out-dir " + where.string() + " --vectors 10");
  expect_bad_input(result, "golden_vectors.txt", "quantise");
  EXPECT_EQ(listing(where), std::vector<std::string>{"golden_vectors.txt"}) << "part of the file set was written";
}

TEST(WholeOutputs, DiagnoseWritesJsonAndPredictionsTogetherOrNeither) {
  const fs::path where = folder() / "d6_diagnose";
  fs::create_directories(where);
  const std::string check = temp("d6_check.csv");
  ASSERT_EQ(run_deltactl("simulate --experiment sweep --seed 3 --out " + check).exit_code, 0);
  // Room for the small JSON document, not for the predictions of every CHECK row.
  const std::string json = (where / "diag.json").string(), predictions = (where / "pred.csv").string();
  const auto result = run_on_full_disk("diagnose --data " + good_recording() + " --holdout " + check + " --json " +
                                           json + " --predictions " + predictions,
                                       64);
  expect_bad_input(result, predictions, "diagnose on a full disk");
  EXPECT_TRUE(listing(where).empty()) << "left: " << (listing(where).empty() ? "" : listing(where).front());
}

// SIGINT through the command line: each long command (train, diagnose, cosim) is interrupted a second in, while it
// computes or writes; it must exit non-zero and leave nothing in its output folder (no output, no
// temporary, no plot folder).
TEST(WholeOutputs, SigintDuringALongCommandLeavesNoFile) {
  const std::string check = temp("d6_sigint_check.csv");
  ASSERT_EQ(run_deltactl("simulate --experiment sweep --seed 3 --out " + check).exit_code, 0);
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"train", "train --data " + good_recording() + " --out {}/w.json"},
      {"diagnose", "diagnose --data " + good_recording() + " --holdout " + check +
                       " --json {}/d.json --predictions {}/p.csv --report {}/r.md"},
      {"cosim", "cosim --weights " + kWeights + " --duration 5 --out {}/c.csv --plot {}/c.png"},
  };
  for (const auto& [name, pattern] : commands) {
    const fs::path where = folder() / ("d6_sigint_" + name);
    fs::create_directories(where);
    std::string arguments = pattern;
    for (std::size_t at = arguments.find("{}"); at != std::string::npos; at = arguments.find("{}")) {
      arguments.replace(at, 2, where.string());
    }
    const std::string status_file = temp("d6_sigint_" + name + ".status");
    const std::string script = std::string(DELTACTL_PATH) + " " + arguments +
                               " >/dev/null 2>&1 & pid=$!; sleep 1; kill -INT $pid; wait $pid; echo $? > " +
                               status_file;
    ASSERT_EQ(std::system(("bash -c '" + script + "'").c_str()), 0) << name;
    const std::string status = read_text(status_file);
    EXPECT_NE(status, "0\n") << name << " finished within a second: the test did not interrupt it";
    EXPECT_TRUE(listing(where).empty()) << name << " left " << (listing(where).empty() ? "" : listing(where).front());
  }
}

// ---- An output that is an input (or another output) is refused.
TEST(SafeOutputs, AnOutputThatIsAnInputIsRefused) {
  const std::string data = temp("d7_data.csv");
  const std::string text = recording_text(30);
  write_text(data, text);
  const std::string alias = temp("d7_alias.csv");
  fs::create_symlink(data, alias);
  const std::string effects = temp("d7_effects.json");
  write_text(effects, "{\"joint_offset\": [0.1, 0, 0]}\n");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"train --data " + data + " --out " + data, data},
      {"ik --model nominal --in " + data + " --out " + alias, alias},
      {"simulate --effects " + effects + " --out " + effects, effects},
      {"diagnose --data " + good_recording() + " --holdout " + good_recording() + " --json " + temp("d7_same") +
           " --predictions " + temp("d7_same"),
       temp("d7_same")},
  };
  for (const auto& [command, name] : cases)
    expect_bad_input(run_deltactl(command), name + ": is the same file", command);
  EXPECT_EQ(read_text(data), text);
  EXPECT_EQ(read_text(effects), "{\"joint_offset\": [0.1, 0, 0]}\n");
  EXPECT_FALSE(fs::exists(temp("d7_same")));
}

// ---- Implausible rows are rejected by every recording reader.
TEST(RecordingRows, ImplausibleRowsAreRejectedNamingTheirLine) {
  const std::string far = temp("d8_far.csv"), huge = temp("d8_huge.csv"), out = temp("d8_out");
  write_text(far, recording_text(20) + "2.0,30,30,30,1e6,0,-0.072\n");
  write_text(huge, recording_text(20) + "2.0,1e300,30,30,0,0,-0.072\n");
  for (const std::string& command : {"train --data " + far + " --out " + out, "compare --data " + far}) {
    expect_bad_input(run_deltactl(command), far + ":22: column 'x_m'", command);
  }
  for (const std::string& command : {"train --data " + huge + " --out " + out, "compare --data " + huge}) {
    expect_bad_input(run_deltactl(command), huge + ":22: column 'alpha1_deg'", command);
  }
  EXPECT_FALSE(fs::exists(out));
}

// ---- Duplicates are errors.
TEST(RecordingRows, DuplicateColumnsAndKeysAreErrors) {
  const std::string csv = temp("d10.csv"), json = temp("d10.json"), out = temp("d10_out");
  write_text(csv, "x_m,y_m,z_m,x_m\n0,0,-0.07,1\n");
  write_text(json, "{\n\"joint_offset\": [0, 0, 0],\n\"joint_offset\": [1, 1, 1]\n}\n");
  expect_bad_input(run_deltactl("ik --model nominal --in " + csv + " --out " + out),
                   csv + ":1: column 'x_m' named twice", "csv");
  expect_bad_input(run_deltactl("simulate --effects " + json + " --out " + out),
                   json + ":3: duplicate key 'joint_offset'", "json");
  EXPECT_FALSE(fs::exists(out));
}

// ---- Import-matlab cannot write a weights file no reader accepts.
TEST(MatlabImportLimits, ImportRefusesMoreHiddenNeuronsThanTheWeightsFileAllows) {
  const int hidden = 20000;
  std::string text;
  auto variable = [&](const char* name, int rows, int columns, double value) {
    text += std::string(name) + "," + std::to_string(rows) + "," + std::to_string(columns);
    for (int i = 0; i < rows * columns; ++i) text += "," + std::to_string(value);
    text += "\n";
  };
  variable("IW", hidden, 3, 0.1);
  variable("b1", hidden, 1, 0.0);
  variable("LW", 3, hidden, 0.01);
  variable("b2", 3, 1, 0.0);
  variable("input_xmin", 3, 1, -0.1);
  variable("input_xmax", 3, 1, 0.1);
  variable("output_xmin", 3, 1, -10);
  variable("output_xmax", 3, 1, 90);
  const std::string in = temp("d11.csv"), out = temp("d11.json");
  write_text(in, text);
  expect_bad_input(run_deltactl("import-matlab --in " + in + " --out " + out),
                   in + ":1: IW: expected H x 3 with 1 <= H <= 10000", "import");
  EXPECT_FALSE(fs::exists(out));
}

// ---- A plate above the base is unreachable.
TEST(Reach, APlateAboveTheBaseIsUnreachable) {
  const std::string in = temp("d12.csv"), out = temp("d12_out.csv");
  write_text(in, "x_m,y_m,z_m\n0,0,-0.075\n0,0,0.05\n");
  expect_bad_input(run_deltactl("ik --model nominal --in " + in + " --out " + out), in + ":3: pose unreachable", "ik");
  EXPECT_FALSE(fs::exists(out));
}

// ---- Messages name the file and stay readable.
TEST(ErrorMessages, MessagesNameTheFileAndStayReadable) {
  const std::string few = temp("d13_few.csv"), out = temp("d13_out");
  write_text(few, recording_text(5));
  expect_bad_input(run_deltactl("train --data " + few + " --out " + out), few + ": training needs at least 10 samples",
                   "few");
  const std::string png = temp("no_such_folder/plot.png");
  const auto plot = run_deltactl("compare --data " + good_recording() + " --plot " + png);
  expect_bad_input(plot, png, "plot");
  EXPECT_EQ(plot.err.find("gnuplot"), std::string::npos) << plot.err;
  expect_bad_input(run_deltactl("compare --data " + folder().string()), folder().string() + ": is a folder", "folder");
  const std::string noisy = temp("d13_noisy.csv");
  write_text(noisy, kHeader + "0,\x1b[31m" + std::string(60000, 'x') + std::string(1, '\0') + ",30,30,0,0,-0.07\n");
  const auto loud = run_deltactl("compare --data " + noisy);
  expect_bad_input(loud, noisy + ":2: column 'alpha1_deg'", "noisy");
  EXPECT_EQ(loud.err.find('\x1b'), std::string::npos);
  const std::string impossible = temp("d13_impossible.json");
  write_text(impossible, "{\"lower_arm_length\": [-0.06, -0.06, -0.06]}\n");
  expect_bad_input(run_deltactl("cosim --weights " + kWeights + " --effects " + impossible, kBounded),
                   impossible + ": ", "impossible robot");
  const std::string long_name = temp(std::string(250, 'n'));
  const auto long_out = run_deltactl("ik --model nominal --in " + good_recording() + " --out " + long_name);
  EXPECT_EQ(long_out.exit_code, 0) << long_out.err;
}

// cosim checks the trajectory before any motion as `host run` does: a sample outside the weights'
// trained range is bad input (exit 2), the message naming its file and line, and no output file.
TEST(ErrorMessages, CosimRefusesATrajectoryBeyondItsLimitsAsBadInput) {
  const std::string file = temp("d13_untrained.csv");
  write_text(file, "t_s,x_m,y_m,z_m\n0,0,0,-0.075\n1,0,0,-0.075\n100,0.008,0,-0.075\n");
  const std::string out = temp("d13_cosim.csv");
  fs::remove(out);
  const auto result = run_deltactl(
      "cosim --fidelity model --weights " + kWeights + " --trajectory " + file + " --duration 120 --out " + out,
      kBounded);
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("deltactl: error: " + file + ":4:"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("trained range"), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(out));
}

// A bare --port NAME is looked up under /dev/serial/by-id/; where it is only a file in the working
// directory (a virtual board's --link tty), the message says how to name that file.
TEST(ErrorMessages, ABarePortNameThatIsAFileHereSaysHowToNameIt) {
  const fs::path here = folder() / "d13_port";
  fs::create_directories(here);
  write_text((here / "board_tty").string(), "");
  const auto result = run_deltactl("host status --port board_tty", "cd '" + here.string() + "' && " + kBounded);
  EXPECT_EQ(result.exit_code, 4) << result.err;
  EXPECT_NE(result.err.find("no /dev/serial/by-id/board_tty"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("write ./board_tty"), std::string::npos) << result.err;
  EXPECT_EQ(lines(result.err), 1u) << result.err;
}

// ---- The bad-input table: every command, one shared set of malformed inputs.
struct Malformed {
  std::string name;
  std::string text;  // written to the file; "<folder>" / "<missing>" make a folder / no file
};

std::string make_input(const Malformed& bad, const std::string& extension) {
  const std::string path = temp("table_" + bad.name + extension);
  if (bad.text == "<folder>")
    fs::create_directories(path);
  else if (bad.text != "<missing>")
    write_text(path, bad.text);
  return path;
}

TEST(BadInputTable, EveryCommandRejectsEveryMalformedInputAndTouchesNoOutput) {
  const std::vector<Malformed> csv_inputs = {
      {"empty", ""},
      {"folder", "<folder>"},
      {"missing", "<missing>"},
      {"header_only", kHeader},
      {"duplicate_column", "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m,z_m\n0,30,30,30,0,0,-0.07,0\n"},
      {"nul", kHeader + "0,30,30,30,0,0,-0.0" + std::string(1, '\0') + "7\n"},
      {"long_line", std::string(100000, '1') + "\n"},
      {"nan", kHeader + "0,30,30,30,nan,0,-0.07\n"},
      {"implausible", kHeader + "0,30,30,30,0,0,-1e9\n"},
      {"binary", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16)}};
  const std::vector<Malformed> json_inputs = {{"empty", ""},
                                              {"folder", "<folder>"},
                                              {"missing", "<missing>"},
                                              {"deep", std::string(10000, '[') + std::string(10000, ']')},
                                              {"duplicate", "{\"hidden\": 1, \"hidden\": 2}"},
                                              {"truncated", "{\"joint_offset\": [1, 2"},
                                              {"nul", std::string("{\"a\0\": 1}", 9)},
                                              {"array", "[1, 2, 3]"}};
  const std::string rec = good_recording();
  const std::string out = temp("table_out.csv"), out2 = temp("table_out2.csv");
  // {IN} is the malformed file; {OUT} and {OUT2} hold sentinel text that must survive.
  const std::vector<std::string> csv_commands = {
      "compare --data {IN}",
      "ik --model nominal --in {IN} --out {OUT}",
      "train --data {IN} --out {OUT}",
      "diagnose --data {IN} --holdout " + rec + " --json {OUT} --predictions {OUT2}",
      "diagnose --data " + rec + " --holdout {IN} --json {OUT} --predictions {OUT2}",
      "table1 --data {IN} --holdout " + rec + " --save-network {OUT}"};
  const std::vector<std::string> json_commands = {"simulate --effects {IN} --out {OUT}",
                                                  "ik --weights {IN} --in " + rec + " --out {OUT}",
                                                  "export-matlab --weights {IN} --out {OUT}",
                                                  "quantise --weights {IN} --out-dir " + folder().string() + "/table_q",
                                                  "accuracy --weights {IN}",
                                                  "cosim --weights {IN} --out {OUT}"};
  fs::create_directories(folder() / "table_q");
  auto run_table = [&](const std::vector<Malformed>& inputs, const std::vector<std::string>& commands,
                       const std::string& ext) {
    for (const Malformed& bad : inputs) {
      const std::string in = make_input(bad, ext);
      for (std::string command : commands) {
        write_text(out, "sentinel\n");
        write_text(out2, "sentinel 2\n");
        for (const auto& [key, value] :
             {std::pair<std::string, std::string>{"{IN}", in}, {"{OUT2}", out2}, {"{OUT}", out}}) {
          for (std::size_t at; (at = command.find(key)) != std::string::npos;) command.replace(at, key.size(), value);
        }
        expect_bad_input(run_deltactl(command), in, bad.name + ": " + command);
        EXPECT_EQ(read_text(out), "sentinel\n") << bad.name << ": " << command;
        EXPECT_EQ(read_text(out2), "sentinel 2\n") << bad.name << ": " << command;
      }
    }
  };
  run_table(csv_inputs, csv_commands, ".csv");
  run_table(json_inputs, json_commands, ".json");
  EXPECT_TRUE(listing(folder() / "table_q").empty());
}

}  // namespace
}  // namespace delta
