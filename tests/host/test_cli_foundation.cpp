// deltactl simulate / compare / ik and the SPEC readers: results, and the error contract on bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>

#include "../support/run_command.hpp"
#include "delta/csv.hpp"
#include "delta/effect_file.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "delta/recording.hpp"
#include "support/tree_paths.hpp"

namespace delta {
namespace {

using test::file_exists;
using test::run_deltactl;
using test::write_text;

// Unique per process: several build trees may run this suite at once on one machine.
std::string temp(const std::string& name) {
  return ::testing::TempDir() + "foundation_" + std::to_string(::getpid()) + "_" + name;
}

const std::string kHeader = "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m\n";
const std::string kRow1 = "0,30,30,30,0,0,-0.071295\n";
const std::string kRow2 = "0.1,30.01,30,29.99,0.0001,0,-0.0713\n";

struct BadRecording {
  std::string name, text, expected_location, expected_reason;
  bool concerns_positions = false;  // ik reads only x_m, y_m, z_m and ignores the other columns (SPEC)
};

// Each SPEC rejection: the message names file and line, the exit code is 2, no output is left.
TEST(FoundationCli, MalformedRecordingsAreRejectedWithFileLineAndReason) {
  const std::vector<BadRecording> cases = {
      {"missing_column", "t_s,alpha1_deg,alpha2_deg,x_m,y_m,z_m\n0,30,30,0,0,-0.07\n",
       ":1:", "missing column 'alpha3_deg'"},
      {"nan", kHeader + kRow1 + "0.1,nan,30,30,0,0,-0.0713\n", ":3:", "not finite"},
      {"text", kHeader + kRow1 + kRow2 + "0.2,30,thirty,30,0,0,-0.0713\n", ":4:", "'thirty' is not a number"},
      {"time_back", kHeader + kRow2 + kRow1, ":3:", "time goes backwards"},
      {"field_count", kHeader + "# a comment line\n" + kRow1 + "0.1,30,30,30,0,0\n", ":4:", "wrong field count", true},
      {"empty", "", ": ", "empty file", true},
      {"header_only", kHeader, ": ", "empty file", true},
      {"infinite", kHeader + "0,30,30,30,inf,0,-0.07\n", ":2:", "not finite", true},
      {"no_z", "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m\n0,30,30,30,0,0\n", ":1:", "missing column 'z_m'", true},
  };
  for (const BadRecording& bad : cases) {
    const std::string data = temp(bad.name + ".csv");
    write_text(data, bad.text);
    std::vector<std::string> commands = {"compare --data " + data};
    if (bad.concerns_positions)
      commands.push_back("ik --model nominal --in " + data + " --out " + temp(bad.name + "_ik.csv"));
    for (const std::string& command : commands) {
      const auto result = run_deltactl(command);
      EXPECT_EQ(result.exit_code, 2) << bad.name << ": " << command;
      EXPECT_NE(result.err.find(data + bad.expected_location), std::string::npos) << bad.name << ": " << result.err;
      EXPECT_NE(result.err.find(bad.expected_reason), std::string::npos) << bad.name << ": " << result.err;
      EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << "one line: " << result.err;
    }
    if (bad.concerns_positions) {
      EXPECT_FALSE(file_exists(temp(bad.name + "_ik.csv"))) << bad.name;
    }
  }
}

TEST(FoundationCli, MalformedEffectFilesAreRejectedWithFileLineAndReason) {
  const std::vector<BadRecording> cases = {
      {"unknown", "{\n  \"joint_offset\": [0.5, -0.3, 0.8],\n  \"gear_wear\": [1, 2, 3]\n}\n",
       ":3:", "unknown effect 'gear_wear'"},
      {"json", "{\n  \"backlash\": [0.3, 0, 0],\n  oops\n}\n", ":3:", "invalid JSON"},
      {"shape", "{\"backlash\": [0.3, 0]}", ":1:", "array of 3 numbers"},
      {"text", "{\n\"encoder_scale\": [0.01, \"x\", 0]\n}", ":2:", "must be a number"},
      {"empty", "  \n", ": ", "empty file"},
      {"not_object", "[1, 2, 3]", ":1:", "JSON object"},
      {"overflow", "{\n\"joint_offset\": [0, 1e999, 0]\n}", ":2:", "not finite"},
  };
  for (const BadRecording& bad : cases) {
    const std::string effects = temp(bad.name + ".json");
    const std::string out = temp(bad.name + "_rec.csv");
    write_text(effects, bad.text);
    const auto result = run_deltactl("simulate --experiment validation --effects " + effects + " --out " + out);
    EXPECT_EQ(result.exit_code, 2) << bad.name;
    EXPECT_NE(result.err.find(effects + bad.expected_location), std::string::npos) << bad.name << ": " << result.err;
    EXPECT_NE(result.err.find(bad.expected_reason), std::string::npos) << bad.name << ": " << result.err;
    EXPECT_FALSE(file_exists(out)) << bad.name;
  }
}

TEST(FoundationCli, EffectFileRoundTripsThroughJson) {
  const EffectSet effects = read_effect_file(std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json");
  EXPECT_EQ(effects.names().size(), 9u);
  const EffectSet again = parse_effects(effects_to_json(effects).dump(), "round trip");
  EXPECT_EQ(effects_to_json(again), effects_to_json(effects));
  EXPECT_DOUBLE_EQ(again.frame_misalignment->rotation_deg.z(), 11.76);
  // The per-joint triple form of transmission_error and the array form of frame_misalignment.
  const EffectSet alternative = parse_effects(
      R"({"transmission_error": [[0.1, 7.5, 0.3], [0, 360, 0], [0.2, 5, 1]], "frame_misalignment": [0, 0, 1, 0.001, 0, 0]})",
      "alt");
  EXPECT_DOUBLE_EQ(alternative.transmission_error->period_deg[2], 5.0);
  EXPECT_DOUBLE_EQ(alternative.frame_misalignment->translation_m.x(), 0.001);
}

TEST(FoundationCli, SimulateWritesASpecRecordingThatReadsBack) {
  const std::string out = temp("validation.csv");
  const auto result = run_deltactl("simulate --experiment validation --out " + out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const Recording recording = read_recording(out);
  ASSERT_EQ(recording.samples.size(), 13333u);
  EXPECT_DOUBLE_EQ(recording.samples[10].t_s, 1.0);
  EXPECT_NEAR(recording.samples.back().t_s, 1333.2, 1e-9);
  EXPECT_NEAR(recording.samples.back().position_m.z(), -0.07084 - 1333.2 * 0.01 / 1333.3, 1e-8);
  // Nominal robot: the measured angles are the nominal IK to half an encoder count (0.005 deg),
  // plus what half a stage count (3.4 nm) of position quantisation moves the IK (< 1e-5 deg).
  for (const Sample& s : recording.samples) {
    const Vec3 ik = inverse_kinematics(Geometry::nominal(), s.position_m).alpha_deg;
    ASSERT_LE((s.alpha_deg - ik).cwiseAbs().maxCoeff(), 0.005 + 1e-5);
  }
}

TEST(FoundationCli, IkNominalMatchesTheLibraryAndKeepsRowOrder) {
  const std::string in = temp("poses.csv");
  write_text(in, "# poses\nlabel,z_m,x_m,y_m\na,-0.075,0.001,0.002\nb,-0.08,-0.004,0.0\nc,-0.07,0.0,-0.005\n");
  const std::string out = temp("angles.csv");
  const auto result = run_deltactl("ik --model nominal --in " + in + " --out " + out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const CsvTable table = read_csv(out, {"alpha1_deg", "alpha2_deg", "alpha3_deg"});
  const std::vector<Vec3> poses = {{0.001, 0.002, -0.075}, {-0.004, 0.0, -0.08}, {0.0, -0.005, -0.07}};
  ASSERT_EQ(table.rows.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const Vec3 expected = inverse_kinematics(Geometry::nominal(), poses[i]).alpha_deg;
    for (int j = 0; j < 3; ++j) EXPECT_EQ(table.rows[i][j], expected[j]) << "exact text round trip";
  }
}

TEST(FoundationCli, IkRejectsAnUnreachablePoseNamingItsLine) {
  const std::string in = temp("far.csv");
  write_text(in, "x_m,y_m,z_m\n0,0,-0.075\n0,0,-0.2\n");
  const std::string out = temp("far_out.csv");
  const auto result = run_deltactl("ik --model nominal --in " + in + " --out " + out);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find(in + ":3: pose unreachable"), std::string::npos) << result.err;
  EXPECT_FALSE(file_exists(out));
}

// Table 1 of the paper, math-model column; the shipped paper-like robot must be within 25 %.
TEST(FoundationCli, PaperLikeRobotMatchesTableOneWithinTwentyFivePercent) {
  const std::string out = temp("paper_like.csv");
  ASSERT_EQ(run_deltactl("simulate --experiment validation --effects " + std::string(DELTA_SOURCE_DIR) +
                         "/sim/paper_like_effects.json --out " + out)
                .exit_code,
            0);
  const auto result = run_deltactl("compare --data " + out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const double paper_rmse[3] = {0.8270, 0.8845, 0.8083}, paper_mae[3] = {0.6593, 0.7142, 0.6255};
  const std::regex row(R"(\| alpha_(\d)\s*\| ([0-9.]+)\s*\| ([0-9.]+))");
  int rows = 0;
  for (std::sregex_iterator it(result.out.begin(), result.out.end(), row), end; it != end; ++it, ++rows) {
    const int j = std::stoi((*it)[1]) - 1;
    EXPECT_NEAR(std::stod((*it)[2]) / paper_rmse[j], 1.0, 0.25) << "RMSE joint " << j + 1;
    EXPECT_NEAR(std::stod((*it)[3]) / paper_mae[j], 1.0, 0.25) << "MAE joint " << j + 1;
  }
  EXPECT_EQ(rows, 3);
  // Forward-kinematics errors of the paper's order: hundreds of micrometres, under 2 mm.
  const std::regex axis(R"(\| ([xyz])\s*\| (-?[0-9.]+)\s*\| (-?[0-9.]+))");
  int axes = 0;
  for (std::sregex_iterator it(result.out.begin(), result.out.end(), axis), end; it != end; ++it, ++axes) {
    const double span = std::max(std::fabs(std::stod((*it)[2])), std::fabs(std::stod((*it)[3])));
    EXPECT_GT(span, 100.0);
    EXPECT_LT(span, 2000.0);
  }
  EXPECT_EQ(axes, 3);
}

TEST(FoundationCli, EveryCommandHasHelp) {
  for (const std::string command : {"", "simulate ", "compare ", "ik "}) {
    const auto result = run_deltactl(command + "--help");
    EXPECT_EQ(result.exit_code, 0) << command;
    EXPECT_NE(result.out.find("Usage"), std::string::npos) << command;
  }
  const auto wrong = run_deltactl("simulate --experiment nowhere --out " + temp("nowhere.csv"));
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.err.find("unknown trajectory 'nowhere'"), std::string::npos) << wrong.err;
}

}  // namespace
}  // namespace delta
