// The drive safety layer: lifecycle, current clamp, and every fault stopping torque.
#include "delta/drive.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace delta {
namespace {

// A test double of the three drives: feedback from a simple rigid joint (current -> acceleration),
// with hooks to drop feedback, inject glitches and raise the hardware fault line.
class SimulatedDrives : public DriveHardware {
 public:
  Vec3 angle_deg = Vec3::Constant(30.0);
  Vec3 velocity_deg_per_s = Vec3::Zero();
  Vec3 current_a = Vec3::Zero();
  bool torque_enabled = false;
  bool deliver_feedback = true;
  bool hardware_fault = false;
  Vec3 glitch_deg = Vec3::Zero();  // added to the next reported angle only
  double t_s = 0.0;
  int torque_off_calls = 0;
  static constexpr double kDegPerS2PerAmp = 20000.0;  // rigid joint: 1 A -> 20000 deg/s^2

  void step(double dt) {
    const Vec3 acceleration = torque_enabled ? Vec3(current_a * kDegPerS2PerAmp) : Vec3(-velocity_deg_per_s / dt);
    velocity_deg_per_s += acceleration * dt;  // without torque the joint is held by friction
    angle_deg += velocity_deg_per_s * dt;
    t_s += dt;
  }
  bool read(DriveFeedback& feedback) override {
    if (!deliver_feedback) return false;
    feedback.t_s = t_s;
    feedback.angle_deg = angle_deg + glitch_deg;
    feedback.hardware_fault = hardware_fault;
    glitch_deg.setZero();
    return true;
  }
  void write(const Vec3& current) override {
    current_a = current;
    torque_enabled = true;
  }
  void disable_torque() override {
    current_a.setZero();
    torque_enabled = false;
    ++torque_off_calls;
  }
};

constexpr double kCycle = 1e-4;  // 10 kHz

struct DriveFixture : ::testing::Test {
  SimulatedDrives drives;
  SafeDrive drive{drives};
  double now = 0.0;
  void start() {
    ASSERT_TRUE(drive.configure(DriveLimits{}));
    ASSERT_TRUE(drive.activate(now));
  }
  DriveResult cycle(const Vec3* command = nullptr) {
    if (command) drive.set_command(*command, now);
    const DriveResult result = drive.update(now);
    drives.step(kCycle);
    now += kCycle;
    return result;
  }
  void expect_fault(std::uint32_t bit) {
    EXPECT_EQ(drive.state(), DriveState::fault);
    EXPECT_TRUE(drive.faults() & bit) << "faults: " << drive.faults();
    EXPECT_FALSE(drives.torque_enabled);
    EXPECT_EQ(drives.current_a, Vec3::Zero());
    // Commands after a fault never reach the power stage.
    const Vec3 push(0.5, 0.5, 0.5);
    for (int i = 0; i < 10; ++i) EXPECT_EQ(cycle(&push), DriveResult::fault);
    EXPECT_FALSE(drives.torque_enabled);
  }
};

TEST_F(DriveFixture, LifecycleNeedsConfigureThenActivate) {
  EXPECT_FALSE(drive.activate(now)) << "unconfigured";
  EXPECT_EQ(cycle(), DriveResult::inactive);
  EXPECT_FALSE(drives.torque_enabled);
  DriveLimits inverted;
  inverted.min_angle_deg[1] = 80.0;
  EXPECT_FALSE(drive.configure(inverted));
  DriveLimits not_finite;
  not_finite.max_current_a = std::nan("");
  EXPECT_FALSE(drive.configure(not_finite));
  EXPECT_EQ(drive.state(), DriveState::unconfigured);
  start();
  EXPECT_EQ(drive.state(), DriveState::active);
  drive.deactivate();
  EXPECT_EQ(drive.state(), DriveState::configured);
  EXPECT_FALSE(drives.torque_enabled);
}

TEST_F(DriveFixture, ActivationRefusedOutsideTheAngleLimits) {
  drives.angle_deg[2] = 80.0;
  ASSERT_TRUE(drive.configure(DriveLimits{}));
  EXPECT_FALSE(drive.activate(now));
  EXPECT_EQ(drive.state(), DriveState::configured);
}

TEST_F(DriveFixture, CommandsAreClampedAndCounted) {
  start();
  const Vec3 small(0.01, -0.02, 0.0);
  EXPECT_EQ(cycle(&small), DriveResult::ok);
  EXPECT_EQ(drives.current_a, small);
  const Vec3 large(3.0, -0.2, -5.0);
  EXPECT_EQ(cycle(&large), DriveResult::saturated);
  EXPECT_EQ(drives.current_a, Vec3(1.0, -0.2, -1.0));
  EXPECT_EQ(drive.saturated_cycles(), 1u);
}

TEST_F(DriveFixture, RunawayHitsTheVelocityOrAngleLimitAndStopsTorque) {
  start();
  const Vec3 runaway(0.0, 1.0, 0.0);  // full current on joint 2 every cycle
  DriveResult result = DriveResult::ok;
  int cycles = 0;
  while (result != DriveResult::fault && cycles < 100000) {
    result = cycle(&runaway);
    ++cycles;
  }
  ASSERT_EQ(result, DriveResult::fault) << "the runaway must be caught";
  EXPECT_TRUE(drive.faults() & (kFaultVelocityLimit | kFaultAngleLimit));
  EXPECT_LT(drives.angle_deg[1], DriveLimits{}.max_angle_deg[1] + 1.0) << "caught before leaving the range by 1 deg";
  expect_fault(kFaultVelocityLimit | kFaultAngleLimit);
}

TEST_F(DriveFixture, CommandWatchdogStopsTorqueWhenTheHostFallsSilent) {
  start();
  const Vec3 hold(0.0, 0.0, 0.0);
  EXPECT_EQ(cycle(&hold), DriveResult::ok);
  // 5 ms of silence is allowed (50 cycles), the next cycle is not.
  DriveResult result = DriveResult::ok;
  int silent = 0;
  while (result != DriveResult::fault && silent < 1000) {
    result = cycle();
    ++silent;
  }
  EXPECT_GE(silent, 50);
  EXPECT_LE(silent, 52);
  expect_fault(kFaultCommandTimeout);
}

TEST_F(DriveFixture, FeedbackLossStopsTorque) {
  start();
  const Vec3 hold = Vec3::Zero();
  drives.deliver_feedback = false;
  int cycles = 0;
  while (cycle(&hold) != DriveResult::fault && cycles < 1000) ++cycles;
  EXPECT_GE(cycles, 10);
  EXPECT_LE(cycles, 12);
  expect_fault(kFaultFeedbackTimeout);
}

TEST_F(DriveFixture, EncoderGlitchStopsTorque) {
  start();
  const Vec3 hold = Vec3::Zero();
  cycle(&hold);
  drives.glitch_deg = Vec3(0.0, 0.0, 4.0);
  EXPECT_EQ(cycle(&hold), DriveResult::fault);
  expect_fault(kFaultEncoderJump);
}

TEST_F(DriveFixture, NonFiniteCommandOrFeedbackStopsTorque) {
  start();
  const Vec3 bad(0.0, std::nan(""), 0.0);
  EXPECT_EQ(cycle(&bad), DriveResult::fault);
  expect_fault(kFaultCommandNotFinite);

  SimulatedDrives other;
  SafeDrive second(other);
  ASSERT_TRUE(second.configure(DriveLimits{}));
  ASSERT_TRUE(second.activate(0.0));
  second.set_command(Vec3::Zero(), 0.0);
  other.glitch_deg = Vec3(std::nan(""), 0.0, 0.0);
  EXPECT_EQ(second.update(0.0), DriveResult::fault);
  EXPECT_TRUE(second.faults() & kFaultFeedbackNotFinite);
}

TEST_F(DriveFixture, HardwareFaultLineStopsTorque) {
  start();
  const Vec3 hold = Vec3::Zero();
  cycle(&hold);
  drives.hardware_fault = true;
  EXPECT_EQ(cycle(&hold), DriveResult::fault);
  expect_fault(kFaultHardware);
}

TEST_F(DriveFixture, ResetNeedsClearConditionsAndReturnsToConfiguredNotActive) {
  start();
  const Vec3 hold = Vec3::Zero();
  drives.hardware_fault = true;
  cycle(&hold);
  ASSERT_EQ(drive.state(), DriveState::fault);
  EXPECT_FALSE(drive.reset_fault(now)) << "the cause is still there";
  drives.hardware_fault = false;
  EXPECT_TRUE(drive.reset_fault(now));
  EXPECT_EQ(drive.state(), DriveState::configured);
  EXPECT_EQ(cycle(&hold), DriveResult::inactive);
  EXPECT_FALSE(drives.torque_enabled);
  EXPECT_TRUE(drive.activate(now));
  char text[128];
  EXPECT_STREQ(describe_faults(kFaultAngleLimit | kFaultHardware, text, sizeof(text)), "angle limit, hardware");
}

}  // namespace
}  // namespace delta
