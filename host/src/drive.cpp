// Safety layer of the drive interface: lifecycle, limit and watchdog checks, torque-off faults.
#include "delta/drive.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace delta {

const char* describe_state(DriveState state) {
  switch (state) {
    case DriveState::unconfigured:
      return "unconfigured";
    case DriveState::configured:
      return "configured";
    case DriveState::active:
      return "active";
    case DriveState::fault:
      return "fault";
  }
  return "unknown";
}

const char* describe_faults(std::uint32_t faults, char* buffer, std::size_t size) {
  static const char* const names[] = {"angle limit",  "velocity limit",     "command timeout",     "feedback timeout",
                                      "encoder jump", "command not finite", "feedback not finite", "hardware"};
  if (size == 0) return buffer;
  buffer[0] = '\0';
  for (unsigned bit = 0; bit < sizeof(names) / sizeof(names[0]); ++bit) {
    if (faults & (1u << bit)) {
      const std::size_t used = std::strlen(buffer);
      std::snprintf(buffer + used, size - used, "%s%s", used ? ", " : "", names[bit]);
    }
  }
  if (buffer[0] == '\0') std::snprintf(buffer, size, "none");
  return buffer;
}

bool SafeDrive::configure(const DriveLimits& limits) {
  if (state_ == DriveState::active || state_ == DriveState::fault) return false;
  const bool finite = limits.min_angle_deg.allFinite() && limits.max_angle_deg.allFinite() &&
                      std::isfinite(limits.max_velocity_deg_per_s) && std::isfinite(limits.max_current_a) &&
                      std::isfinite(limits.command_timeout_s) && std::isfinite(limits.feedback_timeout_s) &&
                      std::isfinite(limits.max_encoder_step_deg);
  if (!finite || (limits.min_angle_deg.array() >= limits.max_angle_deg.array()).any() ||
      !(limits.max_velocity_deg_per_s > 0) || !(limits.max_current_a > 0) || !(limits.command_timeout_s > 0) ||
      !(limits.feedback_timeout_s > 0) || !(limits.max_encoder_step_deg > 0)) {
    return false;
  }
  limits_ = limits;
  state_ = DriveState::configured;
  return true;
}

std::uint32_t SafeDrive::check_feedback(const DriveFeedback& feedback, bool have_previous) const {
  std::uint32_t faults = kFaultNone;
  if (feedback.hardware_fault) faults |= kFaultHardware;
  if (!feedback.angle_deg.allFinite() || !std::isfinite(feedback.t_s)) return faults | kFaultFeedbackNotFinite;
  if ((feedback.angle_deg.array() < limits_.min_angle_deg.array()).any() ||
      (feedback.angle_deg.array() > limits_.max_angle_deg.array()).any()) {
    faults |= kFaultAngleLimit;
  }
  if (have_previous) {
    const double step = (feedback.angle_deg - feedback_.angle_deg).cwiseAbs().maxCoeff();
    const double dt = feedback.t_s - feedback_.t_s;
    if (step > limits_.max_encoder_step_deg)
      faults |= kFaultEncoderJump;
    else if (dt > 0 && step / dt > limits_.max_velocity_deg_per_s)
      faults |= kFaultVelocityLimit;
  }
  return faults;
}

bool SafeDrive::activate(double now_s) {
  if (state_ != DriveState::configured) return false;
  DriveFeedback feedback;
  if (!hardware_.read(feedback)) return false;
  if (check_feedback(feedback, false) != kFaultNone) return false;
  feedback_ = feedback;
  have_feedback_ = true;
  last_feedback_time_s_ = now_s;
  // A fresh activation starts from zero current and needs a fresh command within the timeout.
  command_ = Vec3::Zero();
  last_command_time_s_ = now_s;
  state_ = DriveState::active;
  return true;
}

void SafeDrive::deactivate() {
  hardware_.disable_torque();
  written_.setZero();
  if (state_ == DriveState::active) state_ = DriveState::configured;
}

bool SafeDrive::reset_fault(double now_s) {
  if (state_ != DriveState::fault) return false;
  DriveFeedback feedback;
  if (!hardware_.read(feedback) || check_feedback(feedback, false) != kFaultNone) return false;
  feedback_ = feedback;
  last_feedback_time_s_ = now_s;
  faults_ = kFaultNone;
  state_ = DriveState::configured;
  return true;
}

void SafeDrive::set_command(const Vec3& current_a, double now_s) {
  command_ = current_a;
  last_command_time_s_ = now_s;
}

void SafeDrive::latch(std::uint32_t faults) {
  faults_ |= faults;
  state_ = DriveState::fault;
  hardware_.disable_torque();
  written_.setZero();
}

DriveResult SafeDrive::update(double now_s) {
  if (state_ == DriveState::fault) {
    hardware_.disable_torque();  // every cycle: a fault keeps the power stage off
    return DriveResult::fault;
  }
  if (state_ != DriveState::active) {
    hardware_.disable_torque();
    written_.setZero();
    return DriveResult::inactive;
  }
  std::uint32_t faults = kFaultNone;
  DriveFeedback feedback;
  if (hardware_.read(feedback)) {
    faults |= check_feedback(feedback, have_feedback_);
    feedback_ = feedback;
    have_feedback_ = true;
    last_feedback_time_s_ = now_s;
  } else if (now_s - last_feedback_time_s_ > limits_.feedback_timeout_s) {
    faults |= kFaultFeedbackTimeout;
  }
  if (now_s - last_command_time_s_ > limits_.command_timeout_s) faults |= kFaultCommandTimeout;
  if (!command_.allFinite()) faults |= kFaultCommandNotFinite;
  if (faults != kFaultNone) {
    latch(faults);
    return DriveResult::fault;
  }
  const Vec3 clamped = command_.cwiseMax(-limits_.max_current_a).cwiseMin(limits_.max_current_a);
  const bool saturated = clamped != command_;
  if (saturated) ++saturated_cycles_;
  written_ = clamped;
  hardware_.write(clamped);
  return saturated ? DriveResult::saturated : DriveResult::ok;
}

}  // namespace delta
