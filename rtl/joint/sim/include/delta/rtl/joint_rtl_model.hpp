// The Verilated joint_controller behind a plain C++ interface: one control period per call.
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "delta/golden/joint_fixed.hpp"
#include "delta/rtl/joint_handshake.hpp"

namespace delta::rtl {

class JointRtlModel {
 public:
  JointRtlModel();  // holds the design in reset for a few cycles
  ~JointRtlModel();
  JointRtlModel(const JointRtlModel&) = delete;
  JointRtlModel& operator=(const JointRtlModel&) = delete;

  // Runs one ap_start..ap_done handshake. Throws std::runtime_error if ap_done never comes.
  JointRtlResult run(const std::array<golden::JointFixedInput, 3>& inputs);
  // States of joint `joint` after the last run, read from the state memory (new bank).
  golden::JointFixedState state(int joint) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace delta::rtl
