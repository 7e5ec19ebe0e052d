// The deployed model's acceptance on the paper-like robot, through deltactl: the deployed model that `train`
// makes by default from the 13333-sample validation run, held out on the paper's three kinds of
// trajectory (a sweep of the cube, experiments 1 and 2) through `ik --backend fixed` in row order,
// against the encoder's noise floor; with the time-ordered parts off (--pose-wise) against the best
// any static map can do there (the same recording without the backlash); fixed and hls raw codes
// identical, compensation included.
#include <gtest/gtest.h>

#include <cmath>

#include "delta/csv.hpp"
#include "delta/effect_file.hpp"
#include "delta/model_error.hpp"
#include "delta/nn/weights_file.hpp"
#include "support/run_command.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

const std::string kEffects = std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json";
const double kNoiseFloorDeg = 0.01 / std::sqrt(12.0);  // 0.01 deg encoder counts

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "deployed_" + std::to_string(::getpid()) + "_" + name;
}

std::vector<Vec3> angles(const std::string& path, const std::string& suffix = "_deg") {
  const CsvTable table = read_csv(path, {"alpha1" + suffix, "alpha2" + suffix, "alpha3" + suffix});
  std::vector<Vec3> rows;
  for (const auto& row : table.rows) rows.emplace_back(row[0], row[1], row[2]);
  return rows;
}

void simulate(const std::string& experiment, int seed, const std::string& effects, const std::string& out) {
  const CommandResult result = run_deltactl("simulate --experiment " + experiment + " --effects " + effects +
                                            " --seed " + std::to_string(seed) + " --out " + out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
}

TEST(DeployedModel, PaperLikeRobotHeldOutAtTheNoiseFloorThroughTheFixedBackendInRowOrder) {
  const std::string fit = temp_path("fit.csv"), weights = temp_path("W.json");
  simulate("validation", 1, kEffects, fit);
  const CommandResult train = run_deltactl("train --data " + fit + " --out " + weights);
  ASSERT_EQ(train.exit_code, 0) << train.err;
  std::printf("%s", train.err.substr(train.err.rfind("train: math")).c_str());
  ASSERT_TRUE(nn::read_weights_file(weights).deployed()) << "train makes the deployed model by default";
  // The same robot without its backlash: what the best static map reaches on each recording.
  EffectSet no_backlash = read_effect_file(kEffects);
  no_backlash.backlash_deg.reset();
  const std::string static_effects = temp_path("no_backlash.json");
  write_text(static_effects, effects_to_json(no_backlash).dump());
  for (const auto& [experiment, seed] :
       std::vector<std::pair<std::string, int>>{{"sweep", 7}, {"experiment1", 1}, {"experiment2", 1}}) {
    SCOPED_TRACE(experiment);
    const std::string check = temp_path(experiment + ".csv"), ideal = temp_path(experiment + "_static.csv");
    simulate(experiment, seed, kEffects, check);
    simulate(experiment, seed, static_effects, ideal);
    const std::string fixed = temp_path("fixed.csv"), hls = temp_path("hls.csv"), alone = temp_path("alone.csv");
    for (const auto& [backend, out, option] : std::vector<std::array<std::string, 3>>{
             {"fixed", fixed, ""}, {"hls", hls, ""}, {"fixed", alone, " --pose-wise"}}) {
      const CommandResult ik = run_deltactl("ik --weights " + weights + " --backend " + backend + " --in " + check +
                                            " --out " + out + option);
      ASSERT_EQ(ik.exit_code, 0) << ik.err;
      EXPECT_NE(ik.err.find(option.empty() ? "applied in row order" : "off (--pose-wise)"), std::string::npos)
          << ik.err;
    }
    EXPECT_EQ(angles(fixed, "_raw"), angles(hls, "_raw")) << "fixed and hls raw codes differ";
    const std::vector<Vec3> measured = angles(check);
    const Vec3 ordered = joint_error_stats(measured, angles(fixed)).rmse_deg;
    const Vec3 pose_wise = joint_error_stats(measured, angles(alone)).rmse_deg;
    const Vec3 best_static = joint_error_stats(measured, angles(ideal)).rmse_deg;
    std::printf(
        "%s: in row order %.5f %.5f %.5f deg (%.2f floors); pose-wise %.5f %.5f %.5f, best static map "
        "%.5f %.5f %.5f deg\n",
        experiment.c_str(), ordered[0], ordered[1], ordered[2], ordered.maxCoeff() / kNoiseFloorDeg, pose_wise[0],
        pose_wise[1], pose_wise[2], best_static[0], best_static[1], best_static[2]);
    for (int j = 0; j < 3; ++j) {
      EXPECT_LE(ordered[j], 1.5 * kNoiseFloorDeg) << "joint " << j + 1;
      EXPECT_LE(pose_wise[j], 1.1 * best_static[j]) << "joint " << j + 1;
    }
  }
}

}  // namespace
}  // namespace delta::test
