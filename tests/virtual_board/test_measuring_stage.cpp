// The measuring stage's start after homing (host/cosim/measuring_stage.hpp, after_home_s): the
// stage takes hold after_home_s after the identify request that follows the homing's last command,
// and never sooner than that after the board's drives were last on, whatever order the host's and
// the board's frames come in.
#include <gtest/gtest.h>

#include <filesystem>

#include "delta/cosim/measuring_stage.hpp"
#include "delta/link/payloads.hpp"

namespace delta::cosim {
namespace {

class StageAfterHome : public ::testing::Test {
 protected:
  void SetUp() override {
    StageOptions options;
    options.mode = "drag:sweep";
    options.log_path = (std::filesystem::temp_directory_path() / "stage_after_home.csv").string();
    options.after_home_s = 2.0;
    stage_.emplace(options, EffectSet{}, Geometry::nominal());
  }
  void TearDown() override { std::filesystem::remove(std::filesystem::temp_directory_path() / "stage_after_home.csv"); }

  void host(const link::Frame& frame, double t_s) {
    const std::vector<std::uint8_t> bytes = link::encode_frame(frame);
    stage_->host_bytes(bytes.data(), bytes.size(), t_s);
  }
  void command(link::Command c, double t_s) { host(link::make_frame(sequence_++, c), t_s); }
  void identify(double t_s) { host(link::make_identify_request(sequence_++), t_s); }
  // A telemetry frame: referenced or not, the drives on or off, homing or not.
  void board(bool referenced, bool drives_on, bool homing, double t_s) {
    link::TelemetryPayload t;
    t.set(link::TelemetryFlag::kReferenced, referenced);
    t.set(link::TelemetryFlag::kDriveEnable, drives_on);
    t.set(link::TelemetryFlag::kHoming, homing);
    const std::vector<std::uint8_t> bytes = link::encode_frame(link::make_frame(0, t));
    stage_->board_bytes(bytes.data(), bytes.size(), t_s);
  }

  std::optional<MeasuringStage> stage_;
  std::uint8_t sequence_ = 0;
};

// The lab's order: homing (drives on), its end (referenced, drives off), the homing's disable, then
// host record's identify: the drag's clock starts 2 s after that identify (the drag itself 1 s later).
TEST_F(StageAfterHome, TakesHoldAfterTheIdentifyThatFollowsTheHomingsLastCommand) {
  board(false, true, true, 0.5);
  identify(0.6);  // a keep-alive while homing: not yet
  board(true, false, false, 1.0);
  EXPECT_LT(stage_->drag_start_s(), 0.0);
  identify(1.01);  // before the homing's last command: not yet
  EXPECT_LT(stage_->drag_start_s(), 0.0);
  command(link::Command::kDisable, 1.02);
  identify(1.2);
  EXPECT_DOUBLE_EQ(stage_->drag_start_s(), 1.2 + 2.0 + 1.0);
  EXPECT_FALSE(stage_->drag(3.1).has_value());
}

// The homing went on after the board first showed every joint referenced with the drives off (a
// later phase, an identify in between): the drives on again before the stage holds re-arm it, so the
// stage takes hold only after_home_s after an identify that follows the real end.
TEST_F(StageAfterHome, DrivesOnBeforeTheStageHoldsWaitForTheHomingsEndAgain) {
  board(true, false, false, 1.0);
  command(link::Command::kEnable, 1.05);
  identify(1.26);                          // a keep-alive of the homing's last moves
  ASSERT_GT(stage_->drag_start_s(), 0.0);  // armed, as before the fix it would take hold at 3.26 s
  board(true, true, false, 1.3);           // ... but the drives are on again
  EXPECT_LT(stage_->drag_start_s(), 0.0);
  board(true, true, false, 2.2);
  identify(2.21);  // still moving: not armed
  EXPECT_LT(stage_->drag_start_s(), 0.0);
  board(true, false, false, 2.25);  // the homing's real end
  command(link::Command::kDisable, 2.26);
  identify(2.4);  // host record
  EXPECT_DOUBLE_EQ(stage_->drag_start_s(), 2.4 + 2.0 + 1.0);
  // Once the stage holds the plate, the board's frames no longer move its start.
  ASSERT_TRUE(stage_->holding(4.5));
  board(true, true, false, 4.5);
  EXPECT_DOUBLE_EQ(stage_->drag_start_s(), 5.4);
}

// Homing flagged (the board between CommandHomeStart and its end) with the drives off counts as not ended.
TEST_F(StageAfterHome, AHomingBoardWithTheDrivesOffIsNotTheHomingsEnd) {
  board(true, false, true, 1.0);
  command(link::Command::kDisable, 1.02);
  identify(1.2);
  EXPECT_LT(stage_->drag_start_s(), 0.0);
}

}  // namespace
}  // namespace delta::cosim
