// Whole-robot co-simulation (host/cosim/board_cosim.cpp): a host streaming experiment 1 over the link v2 to the
// virtual board (the Verilated board core as built, three joint plants, the paper-like robot's effects).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "../support/run_command.hpp"
#include "delta/board_facts.hpp"
#include "delta/cosim/board_cosim.hpp"
#include "delta/effect_file.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/trajectory.hpp"
#include "rtl_fixture.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";
const std::string kEffects = std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json";

// Experiment 1 with the paper-like robot as `host run` streams it (the approach from the home pose,
// the rate ramped in and out), q's ROMs in mem_dir.
cosim::CosimOptions experiment_one(const golden::QuantisedNetwork& q, const std::string& mem_dir, double duration_s) {
  cosim::CosimOptions options;
  options.mem_dir = mem_dir;
  options.network = &q;
  options.effects = read_effect_file(kEffects);
  options.trajectory = "experiment1";
  options.duration_s = duration_s;
  return options;
}

// 0.6 s of experiment 1 (0.3 s smooth start from where the host finds the plate), the host
// speaking only link v2 to the virtual board at RTL fidelity: the board identifies itself with the
// host's weights, plays every setpoint without underrun once playing, the clean line drops no
// frame, the joints follow the network's answers due at each millisecond (which checks the
// latency the host compensates), and the plate follows the Cartesian reference far closer than
// the textbook model's 1 mm gap.
TEST(Cosim, PaperLikeRobotFollowsExperimentOneOverTheLink) {
  const golden::QuantisedNetwork q = golden::quantise(nn::read_weights_file(kWeights).network);
  const std::string mem_dir = fresh_directory("cosim_mem");
  golden::write_export(q, mem_dir);
  const cosim::CosimResult result = cosim::run_cosim(experiment_one(q, mem_dir, 0.6));
  const cosim::TrackingSummary summary = cosim::summarise(result, 0.4);
  const link::LinkStatistics& link = result.link;
  std::cout << "played " << result.stream.played << " of " << result.stream.planned << ", t0 " << result.t0_s * 1e3
            << " ms, telemetry " << link.telemetry_frames << "; plate rms " << summary.closed_loop.rms_distance_m * 1e6
            << " um, max " << summary.closed_loop.max_distance_m * 1e6 << " um; joint rms "
            << summary.joint_rms_deg.transpose() << " deg (telemetry " << summary.board_joint_rms_deg.transpose()
            << ")\n";

  // The link: identify matches the host's weights; every sample streamed was played, sent once.
  EXPECT_EQ(result.identify.protocol_version, board::kProtocolVersion);
  EXPECT_EQ(result.identify.weights_crc, weights_crc(q));
  EXPECT_EQ(result.stream.outcome, controller::StreamingResult::Outcome::kCompleted);
  EXPECT_GT(result.approach_samples, 0u);                            // the plate starts at home, the path elsewhere
  EXPECT_GT(result.stream.planned, result.approach_samples + 600u);  // the path and its ramps
  EXPECT_EQ(result.stream.played, result.stream.planned);            // round trips = setpoints played
  EXPECT_EQ(link.setpoints_sent, result.stream.planned);
  EXPECT_EQ(link.setpoints_resent, 0u);
  EXPECT_EQ(result.underruns_while_streaming, 0u);  // the lead went out while the board held
  // A clean line: nothing dropped either way, no telemetry lost or skipped, nothing refused.
  EXPECT_EQ(result.bad_frames, 0);
  EXPECT_EQ(result.rejected, 0);
  EXPECT_EQ(link.decoder.bad_crc + link.decoder.bad_length + link.decoder.unknown_type + link.decoder.skipped_bytes,
            0u);
  EXPECT_EQ(link.lost_telemetry, 0u);
  EXPECT_EQ(link.skipped_telemetry, 0u);
  EXPECT_GE(link.telemetry_frames, result.stream.planned);
  EXPECT_EQ(result.slew_limits, 0);
  // The board: no encoder error, no fault; drives off at the end (disable).
  EXPECT_EQ(result.pins.encoder_error_bits, 0);
  EXPECT_EQ(result.pins.fault_cause_bits, 0);
  EXPECT_FALSE(result.pins.drive_enable);
  // The plan starts near the nominal home (0, 0, -71.295 mm): the host's network inverted at the counts.
  EXPECT_LT((result.start_position_m - Vec3(0, 0, -71.295e-3)).norm(), 1e-3);
  ASSERT_GT(summary.samples, 150u);  // path time 0.4 .. 0.6 s, slower in the final ramp
  // Joints: within 0.05 deg RMS of the network answer due at each millisecond, and the telemetry's
  // count - reference tells the same. Measured 0.032 deg over 0.4 .. 0.6 s: the tail of the enable
  // transient (the board's controllers start enabled at the full -0.5 A and the joints drop 4 deg,
  // recovered in ~0.4 s; a board issue, not the link's); 0.004 deg after 1 s of experiment 1.
  for (int j = 0; j < 3; ++j) {
    EXPECT_LT(summary.joint_rms_deg[j], 0.05) << "joint " << j + 1;
    EXPECT_LT(std::abs(summary.board_joint_rms_deg[j] - summary.joint_rms_deg[j]), 0.005) << "joint " << j + 1;
  }
  // Plate: the network's inverse kinematics plus control (measured 71 um RMS, 105 um max, mostly
  // the backlash the network cannot know on this trajectory); the textbook model misses this robot
  // by up to 1 mm.
  EXPECT_LT(summary.closed_loop.rms_distance_m, 150e-6);
  EXPECT_LT(summary.closed_loop.max_distance_m, 250e-6);
  // The closed loop adds little to the network's own error (the plate if the encoders read the
  // answers exactly; measured 79 um RMS), and the network removes most of the textbook model's
  // (measured 691 um RMS).
  std::cout << "network answers with exact joints: rms " << summary.network_ideal.rms_distance_m * 1e6
            << " um; textbook IK with exact joints: rms " << summary.textbook_ideal.rms_distance_m * 1e6 << " um\n";
  EXPECT_LT(std::abs(summary.closed_loop.rms_distance_m - summary.network_ideal.rms_distance_m), 20e-6);
  EXPECT_GT(summary.textbook_ideal.rms_distance_m, 4.0 * summary.closed_loop.rms_distance_m);
  // The drives were on throughout and the plant moved along the ellipse (x span of experiment 1 is 9 mm).
  double x_min = 1, x_max = -1;
  for (const cosim::CosimSample& s : result.samples) {
    EXPECT_TRUE(s.drives_enabled) << "t " << s.t_s;
    x_min = std::min(x_min, s.position_m.x());
    x_max = std::max(x_max, s.position_m.x());
  }
  EXPECT_GT(x_max - x_min, 0.003);
  std::filesystem::remove_all(mem_dir);
}

// Experiment 1 (5.3 s, the README's co-simulation) on the model board, the plain
// network against the deployed model (static network + the board's backlash compensation in the
// interpolator, and the play shift that lets the controller see the motor while the answer
// crosses the play). Measured: plate 89.9 um RMS plain, 14.5 um deployed (16.0 without the play
// shift: the encoder sees the arm through joint 1's 0.15 deg play, so while the reference held
// inside the play nothing drove the arm); joint tracking (count - reference) unchanged.
TEST(Cosim, TheDeployedModelPlacesThePlateFiveTimesCloserOnExperimentOne) {
  auto run = [](const std::string& weights, const std::string& name) {
    const golden::QuantisedNetwork q = golden::quantise_file(weights, nn::read_weights_file(weights));
    const std::string mem_dir = fresh_directory(name);
    golden::write_export(q, mem_dir);
    cosim::CosimOptions options = experiment_one(q, mem_dir, 5.3);
    options.fidelity = cosim::BoardFidelity::kModel;
    const cosim::CosimResult result = cosim::run_cosim(options);
    EXPECT_EQ(result.stream.outcome, controller::StreamingResult::Outcome::kCompleted) << name;
    EXPECT_EQ(result.stream.played, result.stream.planned) << name;
    EXPECT_EQ(result.identify.weights_crc, weights_crc(q)) << name;
    EXPECT_EQ(result.slew_limits, 0) << name;
    EXPECT_EQ(result.pins.fault_cause_bits, 0) << name;
    std::filesystem::remove_all(mem_dir);
    return cosim::summarise(result, 0.4);
  };
  const cosim::TrackingSummary plain = run(kWeights, "cosim_plain_mem");
  const cosim::TrackingSummary deployed =
      run(std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json", "cosim_deployed_mem");
  std::cout << "plate rms: plain " << plain.closed_loop.rms_distance_m * 1e6 << " um, deployed "
            << deployed.closed_loop.rms_distance_m * 1e6 << " um (compensated answers, exact joints "
            << deployed.network_ideal.rms_distance_m * 1e6 << " um); count - reference rms plain "
            << plain.board_joint_rms_deg.transpose() << ", deployed " << deployed.board_joint_rms_deg.transpose()
            << " deg\n";
  EXPECT_GT(plain.closed_loop.rms_distance_m, 80e-6);
  EXPECT_LT(deployed.closed_loop.rms_distance_m, 15e-6);  // the deployed model's bound
  EXPECT_LT(deployed.closed_loop.rms_distance_m, plain.closed_loop.rms_distance_m / 5.0);
  for (int j = 0; j < 3; ++j) {
    EXPECT_LT(deployed.board_joint_rms_deg[j], 0.005) << "joint " << j + 1;
    EXPECT_LT(deployed.board_joint_rms_deg[j], plain.board_joint_rms_deg[j] + 0.0005) << "joint " << j + 1;
    // The encoders follow the compensated answers as closely as the plain network's answers.
    EXPECT_LT(deployed.joint_rms_deg[j], plain.joint_rms_deg[j] + 0.0005) << "joint " << j + 1;
  }
}

// The lab loop's model (weights/paper_like_calibration_deployed.json: trained on the calibration
// drag, whose wide box turns each joint through several of the robot's 7.5 deg ripples, so it
// carries a joint ripple table) streamed by the host's loop, which shapes every setpoint: against
// the same network and play with the table taken out (the positions sent as they are), the plate
// is closer to where it was asked, with the joints exact (the model's own error) and in closed
// loop. Measured: 12.9 against 19.3 um exact, 15.0 against 20.4 um in closed loop.
TEST(Cosim, AJointRippleTableShapesTheSetpointsAndPlacesThePlateCloser) {
  const std::string path = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_calibration_deployed.json";
  const nn::WeightsFile with_table = nn::read_weights_file(path);
  ASSERT_FALSE(with_table.joint_ripple.empty());
  nn::WeightsFile without_table = with_table;
  without_table.joint_ripple = {};
  const golden::QuantisedNetwork q = golden::quantise_file(path, with_table);
  const std::string mem_dir = fresh_directory("cosim_ripple_mem");
  golden::write_export(q, mem_dir);
  auto run = [&](const nn::WeightsFile& model) {
    cosim::CosimOptions options = experiment_one(q, mem_dir, 5.3);
    options.fidelity = cosim::BoardFidelity::kModel;
    options.model = &model;
    const cosim::CosimResult result = cosim::run_cosim(options);
    EXPECT_EQ(result.stream.outcome, controller::StreamingResult::Outcome::kCompleted);
    EXPECT_EQ(result.pins.fault_cause_bits, 0);
    return cosim::summarise(result, 0.4);
  };
  const cosim::TrackingSummary shaped = run(with_table), unshaped = run(without_table);
  std::filesystem::remove_all(mem_dir);
  std::cout << "plate rms with the table " << shaped.closed_loop.rms_distance_m * 1e6 << " um (joints exact "
            << shaped.network_ideal.rms_distance_m * 1e6 << "), without it "
            << unshaped.closed_loop.rms_distance_m * 1e6 << " um (" << unshaped.network_ideal.rms_distance_m * 1e6
            << ")\n";
  EXPECT_LT(shaped.network_ideal.rms_distance_m, 0.8 * unshaped.network_ideal.rms_distance_m);
  EXPECT_LT(shaped.closed_loop.rms_distance_m, 0.9 * unshaped.closed_loop.rms_distance_m);
  for (int j = 0; j < 3; ++j) EXPECT_LT(shaped.board_joint_rms_deg[j], 0.005) << "joint " << j + 1;
}

// A second model as data: `deltactl cosim` builds the same gateware (the tanh tables and
// identify.mem) whatever the model and loads the W.json over the link as `host load` does, then
// runs the host's streaming loop in board time. With the lab loop's model (not the board's default:
// another network, CRC and input shifts, a joint ripple table) the RTL board and the model board
// write byte-identical recordings of 0.3 s of experiment 1 (and its approach), and the model's
// recording is not the default model's.
TEST(Cosim, ASecondModelLoadedAsDataGivesByteIdenticalRecordingsOnTheRtlAndModelBoards) {
  const std::string first = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
  const std::string second = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_calibration_deployed.json";
  const std::uint32_t first_crc = weights_crc(golden::read_board_weights(first).network);
  const std::uint32_t second_crc = weights_crc(golden::read_board_weights(second).network);
  ASSERT_NE(first_crc, second_crc);
  const std::string dir = fresh_directory("cosim_second_model");
  auto record = [&](const std::string& weights, const std::string& fidelity) {
    const std::string out = dir + "/" + fidelity + (weights == first ? "_first" : "_second") + ".csv";
    const CommandResult cosim = run_deltactl("cosim --fidelity " + fidelity + " --weights " + weights + " --effects " +
                                             kEffects + " --duration 0.3 --out " + out);
    EXPECT_EQ(cosim.exit_code, 0) << fidelity << ": " << cosim.err;
    return read_text(out);
  };
  const std::string rtl = record(second, "rtl"), model = record(second, "model");
  const std::size_t rows = static_cast<std::size_t>(std::count(rtl.begin(), rtl.end(), '\n'));
  std::cout << "CRC " << golden::hex_word(second_crc, 32) << " (default " << golden::hex_word(first_crc, 32)
            << "): " << rows << " lines, " << rtl.size() << " bytes from the RTL board\n";
  EXPECT_GT(rows, 900u);
  if (rtl != model) {
    std::size_t at = 0;
    while (at < rtl.size() && at < model.size() && rtl[at] == model[at]) ++at;
    ADD_FAILURE() << "the recordings differ at byte " << at << ": RTL '" << rtl.substr(at, 80) << "', model '"
                  << model.substr(at, 80) << "'";
  }
  EXPECT_NE(record(first, "model"), model) << "the second model's recording is the default model's";
  std::filesystem::remove_all(dir);
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
