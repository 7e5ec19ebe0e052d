// The drive interface between the host controller and the three joint drives, with its safety
// layer: explicit states (unconfigured, configured, active, fault), one update() per control cycle
// that reads feedback, checks limits and watchdogs, then writes a clamped current or stops torque.
//
// Modelled on ros2_control hardware interfaces (read() then write() each cycle, explicit
// lifecycle) and ruckig (value-type structs, result codes, no exceptions or allocation in update()).
// Units: angles deg (shaft side), velocities deg/s, currents A (motor), time s.
#pragma once

#include <cstdint>

#include "delta/geometry.hpp"

namespace delta {

enum class DriveState { unconfigured, configured, active, fault };

// Fault causes, as bits: several can latch in the same cycle.
enum DriveFault : std::uint32_t {
  kFaultNone = 0,
  kFaultAngleLimit = 1u << 0,         // a joint left [min_angle, max_angle]
  kFaultVelocityLimit = 1u << 1,      // a joint moved faster than max_velocity
  kFaultCommandTimeout = 1u << 2,     // the host sent no command within command_timeout (watchdog)
  kFaultFeedbackTimeout = 1u << 3,    // the drive delivered no fresh feedback within feedback_timeout
  kFaultEncoderJump = 1u << 4,        // one cycle moved more than max_encoder_step: glitch or slip
  kFaultCommandNotFinite = 1u << 5,   // the host commanded NaN or infinity
  kFaultFeedbackNotFinite = 1u << 6,  // the drive reported NaN or infinity
  kFaultHardware = 1u << 7,           // the drive itself reported a fault
};

const char* describe_state(DriveState state);
// Names of the set fault bits, comma separated, into a caller buffer (no allocation).
const char* describe_faults(std::uint32_t faults, char* buffer, std::size_t size);

struct DriveLimits {
  Vec3 min_angle_deg = Vec3::Constant(-10.0);
  Vec3 max_angle_deg = Vec3::Constant(75.0);
  double max_velocity_deg_per_s = 360.0;
  double max_current_a = 1.0;         // clamp of every current command
  double command_timeout_s = 0.005;   // 50 cycles at 10 kHz
  double feedback_timeout_s = 0.001;  // 10 cycles at 10 kHz
  double max_encoder_step_deg = 2.0;  // per update
};

struct DriveFeedback {
  double t_s = 0.0;  // time stamp of the measurement
  Vec3 angle_deg = Vec3::Zero();
  bool hardware_fault = false;  // the drive's own fault line
};

// What a drive (real, simulated or a test double) must offer. read() returns false when no new
// feedback arrived this cycle.
class DriveHardware {
 public:
  virtual ~DriveHardware() = default;
  virtual bool read(DriveFeedback& feedback) = 0;
  virtual void write(const Vec3& current_a) = 0;
  virtual void disable_torque() = 0;  // power stage off: must be safe to call in any state
};

enum class DriveResult {
  ok,         // the command was written as given
  saturated,  // the command was written, clamped to max_current on at least one joint
  inactive,   // not active: zero current written / torque off
  fault,      // a fault latched (this or an earlier cycle): torque off
};

class SafeDrive {
 public:
  explicit SafeDrive(DriveHardware& hardware) : hardware_(hardware) {}

  // unconfigured|configured -> configured. Rejects (returns false) non-finite or inverted limits.
  bool configure(const DriveLimits& limits);
  // configured -> active, only with fresh, finite feedback inside the angle limits.
  bool activate(double now_s);
  // active -> configured, torque off.
  void deactivate();
  // fault -> configured (never straight back to active), only once feedback is inside the limits.
  bool reset_fault(double now_s);

  // The host's latest current command; also feeds the command watchdog.
  void set_command(const Vec3& current_a, double now_s);

  // One control cycle: read(), checks, then write() or disable_torque(). Allocation-free.
  DriveResult update(double now_s);

  DriveState state() const { return state_; }
  std::uint32_t faults() const { return faults_; }
  const DriveFeedback& last_feedback() const { return feedback_; }
  const Vec3& last_written_current_a() const { return written_; }
  std::uint64_t saturated_cycles() const { return saturated_cycles_; }

 private:
  void latch(std::uint32_t faults);
  std::uint32_t check_feedback(const DriveFeedback& feedback, bool have_previous) const;

  DriveHardware& hardware_;
  DriveLimits limits_;
  DriveState state_ = DriveState::unconfigured;
  std::uint32_t faults_ = kFaultNone;
  DriveFeedback feedback_;
  bool have_feedback_ = false;
  double last_feedback_time_s_ = 0.0;
  Vec3 command_ = Vec3::Zero();
  double last_command_time_s_ = 0.0;
  Vec3 written_ = Vec3::Zero();
  std::uint64_t saturated_cycles_ = 0;
};

}  // namespace delta
