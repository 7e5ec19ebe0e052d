// Whole-robot co-simulation (host/codesign/board_cosim.cpp): the Verilated board core in closed loop with three
// joint plants and the paper-like robot's effects, the host streaming experiment 1 over the UART.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>

#include "../support/run_command.hpp"
#include "delta/cosim/board_cosim.hpp"
#include "delta/effect_file.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/trajectory.hpp"
#include "rtl_fixture.hpp"

namespace delta::test {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";
const std::string kEffects = std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json";

// 0.6 s of experiment 1 (0.3 s smooth start from the home pose): the link, the crossing, the
// joint controllers and the encoders work together, the joints follow the network's references,
// and the plate follows the Cartesian reference far closer than the textbook model's 1 mm gap.
TEST(Cosim, PaperLikeRobotFollowsExperimentOneThroughTheBoardRtl) {
  const golden::QuantisedNetwork q = golden::quantise(nn::read_weights_file(kWeights).network);
  const std::string mem_dir = fresh_directory("cosim_mem");
  golden::write_export(q, mem_dir);
  cosim::CosimOptions options;
  options.mem_dir = mem_dir;
  options.effects = read_effect_file(kEffects);
  options.trajectory = make_trajectory("experiment1").position_m;
  options.duration_s = 0.6;
  options.blend_s = 0.3;
  options.encode_position = [&q](const Vec3& p, bool* clamped) {
    return golden::encode_position(q.formats, p, clamped);
  };
  options.decode_angle_deg = [&q](std::int64_t raw) { return golden::decode_angle_deg(q.formats, raw); };
  const cosim::CosimResult result = cosim::run_cosim(options);
  const cosim::TrackingSummary summary = cosim::summarise(result, 0.4);
  std::cout << "round trips " << result.round_trips << ", first answer at " << result.first_answer_s * 1e3
            << " ms; plate rms " << summary.closed_loop.rms_distance_m * 1e6 << " um, max "
            << summary.closed_loop.max_distance_m * 1e6 << " um; joint rms " << summary.joint_rms_deg.transpose()
            << " deg\n";

  EXPECT_EQ(result.naks, 0u);
  EXPECT_EQ(result.clamped_positions, 0u);
  EXPECT_EQ(result.encoder_error_bits, 0);
  EXPECT_FALSE(result.joint_limited);
  EXPECT_EQ(result.fault_cause_bits, 0);
  EXPECT_GT(result.round_trips, 5000u);  // a reference every ~55 us
  EXPECT_GT(result.first_answer_s, 0.0);
  EXPECT_LT(result.first_answer_s, 0.001);
  ASSERT_EQ(summary.samples, 200u);
  // Joints: within 0.02 deg (two encoder counts) RMS of the network's references (measured
  // 0.003-0.006 deg).
  for (int j = 0; j < 3; ++j) EXPECT_LT(summary.joint_rms_deg[j], 0.02) << "joint " << j + 1;
  // Plate: the network's inverse kinematics plus control (measured 79 um RMS, 116 um max, mostly
  // the backlash the network cannot know on this trajectory); the textbook model misses this robot
  // by up to 1 mm.
  EXPECT_LT(summary.closed_loop.rms_distance_m, 150e-6);
  EXPECT_LT(summary.closed_loop.max_distance_m, 250e-6);
  // The closed loop adds little to the network's own error (the plate if the encoders read the
  // answers exactly; measured 79.4 um RMS), and the network removes most of the textbook model's
  // (measured 690 um RMS).
  std::cout << "network answers with exact joints: rms " << summary.network_ideal.rms_distance_m * 1e6
            << " um; textbook IK with exact joints: rms " << summary.textbook_ideal.rms_distance_m * 1e6 << " um\n";
  EXPECT_LT(std::abs(summary.closed_loop.rms_distance_m - summary.network_ideal.rms_distance_m), 20e-6);
  EXPECT_GT(summary.textbook_ideal.rms_distance_m, 4.0 * summary.closed_loop.rms_distance_m);
  // The drives were enabled and the plant moved along the ellipse (x span of experiment 1 is 9 mm).
  double x_min = 1, x_max = -1;
  for (const cosim::CosimSample& s : result.samples) {
    EXPECT_EQ(s.drives_enabled, s.t_s > result.first_answer_s + 1e-4) << "t " << s.t_s;
    x_min = std::min(x_min, s.position_m.x());
    x_max = std::max(x_max, s.position_m.x());
  }
  EXPECT_GT(x_max - x_min, 0.003);
  std::filesystem::remove_all(mem_dir);
}

TEST(Cosim, CommandRefusesHybridWeightsAndUnknownTrajectories) {
  const std::string hybrid = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_hybrid.json";
  const CommandResult refused = run_deltactl("cosim --weights " + hybrid + " --duration 0.01");
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_NE(refused.err.find("paper_like_hybrid.json"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("hybrid"), std::string::npos) << refused.err;
  const CommandResult unknown = run_deltactl("cosim --weights " + kWeights + " --trajectory circle --duration 0.01");
  EXPECT_EQ(unknown.exit_code, 2) << unknown.err;
  EXPECT_NE(unknown.err.find("circle"), std::string::npos) << unknown.err;
}

}  // namespace
}  // namespace delta::test
