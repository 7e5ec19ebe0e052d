// `deltactl diagnose` of a closed-loop `host run` of a robot with play, through a stage that samples
// too slowly to see where the arm sits in the play (host/diagnosis/src/closed_loop.hpp): the model
// board kept to real time, homed, a fast path, the stage following at 250 Hz on its own clock,
// merged on the board's sync output, diagnosed with a sweep of the same robot held out.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "../support/followed_run.hpp"
#include "../support/run_command.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

// Play on joints 1 and 3 (joint 2 has none: its reading dithers by a count in closed loop).
const char* kRobotWithPlay = R"({
  "joint_offset": [0.3, -0.5, 0.2],
  "backlash": [0.12, 0.0, 0.2],
  "lower_arm_length": [0.0002, -0.0003, 0.0001],
  "frame_misalignment": {"rx": 0.2, "ry": -0.1, "rz": 2.0, "tx": 0.0002, "ty": -0.0001, "tz": 0.0003}
})";
constexpr double kPlayDeg[3] = {0.12, 0.0, 0.2};

std::string folder() {
  const std::string dir = ::testing::TempDir() + "closed_loop_diagnosis_" + std::to_string(::getpid()) + "/";
  std::system(("mkdir -p " + dir).c_str());
  return dir;
}

// A Lissajous path at 1 kHz (t_s,x_m,y_m,z_m) about the middle of what `weights` was trained on
// (its input range): +-2.5 / 2.5 / 1.2 mm at 0.15 / 0.19 / 0.11 Hz with +-0.3 mm at 0.53 / 0.91 /
// 0.67 Hz, the joints up to about 6 deg/s.
void write_fast_path(const std::string& path, const std::string& weights, double seconds) {
  const nlohmann::json w = nlohmann::json::parse(read_text(weights));
  double centre[3];
  for (int a = 0; a < 3; ++a) centre[a] = 0.5 * (w["input_min"][a].get<double>() + w["input_max"][a].get<double>());
  const double slow[3][3] = {{2.5e-3, 0.15, 0.0}, {2.5e-3, 0.19, 1.1}, {1.2e-3, 0.11, 0.4}};
  const double fast[3][3] = {{0.3e-3, 0.53, 0.7}, {0.3e-3, 0.91, 2.3}, {0.3e-3, 0.67, 1.9}};
  std::ostringstream out;
  out.precision(9);
  out << "t_s,x_m,y_m,z_m\n";
  const double two_pi = 2.0 * std::acos(-1.0);
  for (long k = 0; k <= std::lround(seconds * 1000.0); ++k) {
    const double t = k * 1e-3;
    out << t;
    for (int a = 0; a < 3; ++a) {
      // Both terms start at their phase's value: subtract it, so that the path starts at the centre.
      const double s = slow[a][0] * (std::sin(two_pi * slow[a][1] * t + slow[a][2]) - std::sin(slow[a][2]));
      const double f = fast[a][0] * (std::sin(two_pi * fast[a][1] * t + fast[a][2]) - std::sin(fast[a][2]));
      out << ',' << centre[a] + s + f;
    }
    out << '\n';
  }
  write_text(path, out.str());
}

// The robot with play on joints 1 and 3, 60 s of the fast path, the stage at 250 Hz. The diagnosis
// takes joints 1 and 3 where they move faster than 2.5 deg/s (joint 2 dithers: every row), then
// their slower rows back: their play within 0.0015 deg of the robot's and every joint within 1.2
// floors on the held-out sweep (this run fitted on every row as it is: the play 0.0022 deg narrow,
// joint 1 at 1.55 floors; the stage misses the arm's pushes to the end of the play). It never says
// `explained` with a joint above 1.5 floors. About 100 s, alone on the machine (the board is kept to
// real time).
TEST(ClosedLoopDiagnosis, APlayFittedThroughASlowStageIsTheRobots) {
  const std::string dir = folder();
  const std::string weights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
  write_text(dir + "robot.json", kRobotWithPlay);
  write_fast_path(dir + "path.csv", weights, 60.0);
  followed_run_and_merge(
      dir, weights,
      {"--effects", dir + "robot.json", "--stage-clock", "23.5,-120", "--stage-rate", "250", "--stage-seed", "7"},
      "--trajectory " + dir + "path.csv");
  if (::testing::Test::HasFatalFailure()) return;
  const CommandResult sweep =
      run_deltactl("simulate --experiment sweep --seed 3 --effects " + dir + "robot.json --out " + dir + "sweep.csv");
  ASSERT_EQ(sweep.exit_code, 0) << sweep.err;
  const CommandResult diagnose =
      run_deltactl("diagnose --data " + dir + "data.csv --holdout " + dir + "sweep.csv --json " + dir +
                   "diagnosis.json --predictions " + dir + "predictions.csv");
  std::cout << diagnose.out << diagnose.err;
  ASSERT_EQ(diagnose.exit_code, 0);

  const nlohmann::json d = nlohmann::json::parse(read_text(dir + "diagnosis.json"));
  ASSERT_TRUE(d.contains("closed_loop_fit")) << "the run was not taken for closed-loop telemetry";
  std::cout << "closed_loop_fit " << d["closed_loop_fit"].dump() << '\n';
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(d["closed_loop_fit"]["play_fitted_where_faster"][j].get<bool>(), kPlayDeg[j] > 0.0) << "joint " << j + 1;
  }
  const nlohmann::json* play = nullptr;
  for (const nlohmann::json& effect : d["effects"]) {
    if (effect["name"] == "backlash" && effect["significant"].get<bool>()) play = &effect;
  }
  ASSERT_NE(play, nullptr) << "backlash not named";
  for (int j = 0; j < 3; ++j) {
    const double fitted = (*play)["parameters"]["b_deg"][j].get<double>();
    std::cout << "joint " << j + 1 << ": play " << fitted << " deg (the robot's " << kPlayDeg[j] << ")\n";
    if (kPlayDeg[j] > 0.0) {
      EXPECT_NEAR(fitted, kPlayDeg[j], 0.0015) << "joint " << j + 1;
    }
  }
  const nlohmann::json& floors = d["floor_test"]["joint_rmse_floors"];
  const double worst = std::max({floors[0].get<double>(), floors[1].get<double>(), floors[2].get<double>()});
  std::cout << "held out " << floors.dump() << " floors, explained " << d["explained"] << '\n';
  EXPECT_LE(worst, 1.2);
  if (d["explained"].get<bool>()) {
    EXPECT_LE(worst, 1.5);
  }
  if (!::testing::Test::HasFailure()) std::system(("rm -rf " + dir).c_str());
}

}  // namespace
}  // namespace delta::test
