// `deltactl ik --backend rtl` (SPEC): the raw output codes equal those of `--backend fixed` row by
// row, on the shipped weights, for poses inside and beyond the trained range.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "../support/run_command.hpp"

namespace delta::test {
namespace {

std::vector<std::string> raw_columns(const std::string& csv_text) {
  std::vector<std::string> rows;
  std::istringstream lines(csv_text);
  std::string line;
  while (std::getline(lines, line)) {
    std::size_t comma = 0;
    for (int field = 0; field < 3; ++field) comma = line.find(',', comma) + 1;
    rows.push_back(line.substr(comma));  // alpha1_raw,alpha2_raw,alpha3_raw
  }
  return rows;
}

TEST(BackendRtl, RawCodesEqualFixedBackend) {
  const std::string dir = ::testing::TempDir() + "backend_rtl_" + std::to_string(::getpid());
  const std::string poses = dir + "_poses.csv";
  std::string text = "x_m,y_m,z_m\n";
  // A 5 x 5 x 5 grid over the 10 mm cube plus 40 % margin (beyond the trained range too).
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      for (int k = 0; k < 5; ++k) {
        text += std::to_string(-0.007 + 0.0035 * i) + "," + std::to_string(-0.007 + 0.0035 * j) + "," +
                std::to_string(-0.08284 + 0.0035 * k) + "\n";
      }
  write_text(poses, text);
  const std::string weights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";
  const CommandResult rtl =
      run_deltactl("ik --weights " + weights + " --backend rtl --in " + poses + " --out " + dir + "_rtl.csv");
  ASSERT_EQ(rtl.exit_code, 0) << rtl.err;
  const CommandResult fixed =
      run_deltactl("ik --weights " + weights + " --backend fixed --in " + poses + " --out " + dir + "_fixed.csv");
  ASSERT_EQ(fixed.exit_code, 0) << fixed.err;
  const std::string rtl_text = read_text(dir + "_rtl.csv");
  EXPECT_EQ(rtl_text.substr(0, rtl_text.find('\n')),
            "alpha1_deg,alpha2_deg,alpha3_deg,alpha1_raw,alpha2_raw,alpha3_raw");
  const std::vector<std::string> rtl_rows = raw_columns(rtl_text),
                                 fixed_rows = raw_columns(read_text(dir + "_fixed.csv"));
  ASSERT_EQ(rtl_rows.size(), 126u);
  EXPECT_EQ(rtl_rows, fixed_rows);
  EXPECT_NE(rtl.err.find("latency 92 cycles"), std::string::npos) << rtl.err;
}

TEST(BackendRtl, BadWeightsFileIsAnInputError) {
  const std::string path = ::testing::TempDir() + "backend_rtl_bad_" + std::to_string(::getpid());
  write_text(path + ".json", "{ not json");
  write_text(path + "_poses.csv", "x_m,y_m,z_m\n0,0,-0.075\n");
  const CommandResult result = run_deltactl("ik --weights " + path + ".json --backend rtl --in " + path +
                                            "_poses.csv --out " + path + "_out.csv");
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_FALSE(file_exists(path + "_out.csv"));
}

}  // namespace
}  // namespace delta::test
