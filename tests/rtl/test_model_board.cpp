// The model board (host/codesign/model_board.hpp) against the RTL board: the same host session
// (experiment 1 with the paper-like robot over link v2) through both virtual boards must give the
// same board: every telemetry frame equal in every field, and at every 10 kHz control period the
// same drive currents the world applies, encoder lines, plant angles and status pins.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <iostream>
#include <string>
#include <vector>

#include "delta/cosim/board_cosim.hpp"
#include "delta/effect_file.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/link/payloads.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/trajectory.hpp"
#include "rtl_fixture.hpp"

namespace delta::test {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";
const std::string kEffects = std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json";

struct PeriodRecord {
  std::uint64_t clocks = 0;
  Vec3 current_a = Vec3::Zero();
  Vec3 encoder_deg = Vec3::Zero();
  Vec3 true_alpha_deg = Vec3::Zero();
  cosim::BoardPins pins;
};

struct BoardRun {
  cosim::CosimResult result;
  std::vector<PeriodRecord> periods;
};

BoardRun run_board(cosim::BoardFidelity fidelity, const golden::QuantisedNetwork& q, const std::string& mem_dir) {
  BoardRun out;
  cosim::CosimOptions options;
  options.fidelity = fidelity;
  options.mem_dir = mem_dir;
  options.network = &q;
  options.effects = read_effect_file(kEffects);
  options.trajectory = make_trajectory("experiment1").position_m;
  options.duration_s = 2.0;
  options.blend_s = 0.3;
  options.period_observer = [&out](std::uint64_t clocks, const cosim::BoardPins& pins, const RobotWorld& world) {
    out.periods.push_back({clocks, world.current_a(), world.encoder_deg(), world.true_alpha_deg(), pins});
  };
  out.result = cosim::run_cosim(options);
  return out;
}

TEST(ModelBoard, EqualsTheRtlBoardFrameForFrameAndPeriodForPeriodOverExperimentOne) {
  const golden::QuantisedNetwork q = golden::quantise(nn::read_weights_file(kWeights).network);
  const std::string mem_dir = fresh_directory("model_board_mem");
  golden::write_export(q, mem_dir);
  auto seconds_since = [](std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  auto start = std::chrono::steady_clock::now();
  const BoardRun rtl = run_board(cosim::BoardFidelity::kRtl, q, mem_dir);
  const double rtl_s = seconds_since(start);
  start = std::chrono::steady_clock::now();
  const BoardRun model = run_board(cosim::BoardFidelity::kModel, q, mem_dir);
  const double model_s = seconds_since(start);
  std::cout << "RTL: " << rtl.result.telemetry.size() << " telemetry frames, " << rtl.periods.size() << " periods in "
            << rtl_s << " s; model: " << model.result.telemetry.size() << ", " << model.periods.size() << " in "
            << model_s << " s\n";

  // The session completed on both (a real trajectory: it moved the joints, drew current).
  ASSERT_EQ(rtl.result.stream.outcome, link::StreamReport::Outcome::kCompleted);
  ASSERT_GT(rtl.result.telemetry.size(), 2000u);
  EXPECT_EQ(model.result.identify.weights_crc, rtl.result.identify.weights_crc);
  EXPECT_EQ(model.result.identify.build_id, rtl.result.identify.build_id);

  ASSERT_EQ(model.result.telemetry.size(), rtl.result.telemetry.size());
  std::size_t moving = 0;
  for (std::size_t i = 0; i < rtl.result.telemetry.size(); ++i) {
    const link::TelemetryPayload& a = rtl.result.telemetry[i];
    const link::TelemetryPayload& b = model.result.telemetry[i];
    ASSERT_EQ(link::encode(b), link::encode(a))
        << "telemetry frame " << i << " (tick " << a.tick << " vs " << b.tick << "): sample " << a.sample_index << "/"
        << b.sample_index << " counts " << a.counts[0] << "/" << b.counts[0] << " currents " << a.currents[0] << "/"
        << b.currents[0] << " references " << a.references[0] << "/" << b.references[0] << " flags " << int(a.flags)
        << "/" << int(b.flags) << " fill " << a.fill << "/" << b.fill;
    if (a.currents[0] != 0 || a.currents[1] != 0 || a.currents[2] != 0) ++moving;
  }
  EXPECT_GT(moving, 1000u);

  ASSERT_EQ(model.periods.size(), rtl.periods.size());
  for (std::size_t i = 0; i < rtl.periods.size(); ++i) {
    const PeriodRecord& a = rtl.periods[i];
    const PeriodRecord& b = model.periods[i];
    ASSERT_EQ(b.clocks, a.clocks);
    ASSERT_EQ(b.current_a, a.current_a) << "period " << i;  // the PWM the world averaged, exactly
    ASSERT_EQ(b.encoder_deg, a.encoder_deg) << "period " << i;
    ASSERT_EQ(b.true_alpha_deg, a.true_alpha_deg) << "period " << i;
    ASSERT_EQ(b.pins.drive_enable, a.pins.drive_enable) << "period " << i;
    ASSERT_EQ(b.pins.fault_cause_bits, a.pins.fault_cause_bits) << "period " << i;
    ASSERT_EQ(b.pins.encoder_error_bits, a.pins.encoder_error_bits) << "period " << i;
    ASSERT_EQ(b.pins.joint_limited, a.pins.joint_limited) << "period " << i;
  }
}

}  // namespace
}  // namespace delta::test
