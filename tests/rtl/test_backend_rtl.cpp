// `deltactl ik --backend rtl` (SPEC): the raw output codes equal those of `--backend fixed` row by
// row, on the shipped weights, for poses inside and beyond the trained range; and for both shipped
// deployed models in row order, compensation (and a joint ripple table) included.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "../support/run_command.hpp"
#include "support/tree_paths.hpp"

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

// The deployed models on a recording of the paper-like robot (experiment 1, in time order): the
// raw codes of rtl (network + backlash_compensation.sv), fixed and hls are the same, row by row.
// Both shipped deployed models: the board's default and the lab loop's (another network, input
// shifts and CRC, with a joint ripple table that shapes the setpoints: the model a board loads
// as data in place of the first).
TEST(BackendRtl, DeployedModelsInRowOrderEqualFixedAndHls) {
  const std::string dir = ::testing::TempDir() + "backend_rtl_deployed_" + std::to_string(::getpid());
  const CommandResult simulate =
      run_deltactl("simulate --experiment experiment1 --samples 1500 --seed 3 --effects " +
                   std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json --out " + dir + "_exp1.csv");
  ASSERT_EQ(simulate.exit_code, 0) << simulate.err;
  std::vector<std::string> first_model_rtl;
  for (const char* name : {"paper_like_deployed", "paper_like_calibration_deployed"}) {
    SCOPED_TRACE(name);
    const std::string weights = std::string(DELTA_SOURCE_DIR) + "/weights/" + name + ".json";
    std::vector<std::vector<std::string>> raw;
    for (const char* backend : {"rtl", "fixed", "hls"}) {
      const CommandResult ik = run_deltactl("ik --weights " + weights + " --backend " + backend + " --in " + dir +
                                            "_exp1.csv --out " + dir + "_" + backend + ".csv");
      ASSERT_EQ(ik.exit_code, 0) << ik.err;
      EXPECT_NE(ik.err.find("applied in row order"), std::string::npos) << ik.err;
      raw.push_back(raw_columns(read_text(dir + "_" + backend + ".csv")));
    }
    ASSERT_EQ(raw[0].size(), 1501u);
    EXPECT_EQ(raw[0], raw[1]);
    EXPECT_EQ(raw[0], raw[2]);
    // The compensation acts: the pose-wise raw codes differ on most rows of this back-and-forth path.
    const CommandResult alone = run_deltactl("ik --weights " + weights + " --backend rtl --pose-wise --in " + dir +
                                             "_exp1.csv --out " + dir + "_alone.csv");
    ASSERT_EQ(alone.exit_code, 0) << alone.err;
    const std::vector<std::string> pose_wise = raw_columns(read_text(dir + "_alone.csv"));
    std::size_t differ = 0;
    for (std::size_t i = 1; i < pose_wise.size(); ++i) differ += pose_wise[i] != raw[0][i];
    EXPECT_GT(differ, pose_wise.size() / 2);
    // The second model's codes are its own, not the first's.
    if (first_model_rtl.empty()) {
      first_model_rtl = raw[0];
    } else {
      std::size_t other = 0;
      for (std::size_t i = 1; i < raw[0].size(); ++i) other += raw[0][i] != first_model_rtl[i];
      EXPECT_GT(other, raw[0].size() / 2);
    }
  }
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
