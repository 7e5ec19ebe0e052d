// The Verilated joint_controller behind a plain C++ interface: one control period per call.
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "delta/control/joint_fixed.hpp"

namespace delta::rtl {

struct JointRtlResult {
  std::array<std::int16_t, 3> current{};
  std::array<bool, 3> limited{};
  std::uint16_t overflow_count = 0;  // since reset, sticks at 0xFFFF
  long cycles = 0;                   // ap_start to ap_done
};

class JointRtlModel {
 public:
  JointRtlModel();  // holds the design in reset for a few cycles
  ~JointRtlModel();
  JointRtlModel(const JointRtlModel&) = delete;
  JointRtlModel& operator=(const JointRtlModel&) = delete;

  // Runs one ap_start..ap_done handshake. Throws std::runtime_error if ap_done never comes.
  JointRtlResult run(const std::array<control::JointFixedInput, 3>& inputs);
  // States of joint `joint` after the last run, read from the state memory (new bank).
  control::JointFixedState state(int joint) const;

 private:
  void tick();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace delta::rtl
