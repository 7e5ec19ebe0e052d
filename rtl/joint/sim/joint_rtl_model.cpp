// Drives the Verilated joint_controller through its ap_ctrl_hs handshake.
#include "delta/rtl/joint_rtl_model.hpp"

#include <stdexcept>

#include "Vjoint_controller.h"
#include "Vjoint_controller___024root.h"
#include "verilated.h"

namespace delta::rtl {

struct JointRtlModel::Impl {
  VerilatedContext context;
  Vjoint_controller top{&context};
  long runs = 0;  // the n-th run after reset writes bank (n - 1) % 2
};

JointRtlModel::JointRtlModel() : impl_(std::make_unique<Impl>()) { reset_model(impl_->top); }

JointRtlModel::~JointRtlModel() { impl_->top.final(); }

JointRtlResult JointRtlModel::run(const std::array<golden::JointFixedInput, 3>& inputs) {
  const JointRtlResult result = run_period(impl_->top, inputs);
  ++impl_->runs;
  return result;
}

golden::JointFixedState JointRtlModel::state(int joint) const {
  const auto& memory = impl_->top.rootp->joint_controller__DOT__u_state_ram__DOT__memory_q;
  const int bank = static_cast<int>((impl_->runs - 1) % 2);
  auto word = [&](int slot) { return static_cast<std::int32_t>(memory[(joint << 4) | (bank << 3) | slot]); };
  golden::JointFixedState state;
  state.reference = word(0);
  state.reference_velocity = word(1);
  state.reference_acceleration = word(2);
  state.encoder = word(3);
  state.velocity = word(4);
  state.disturbance = word(5);
  state.current = word(6);
  state.shift = word(7) - (1 << (golden::kShiftBits - 1));  // stored offset by half the range
  return state;
}

}  // namespace delta::rtl
