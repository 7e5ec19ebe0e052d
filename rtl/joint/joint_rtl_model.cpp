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
  bool bank_written = false;  // the bank the last run wrote (mirrors bank_q before its flip)
};

JointRtlModel::JointRtlModel() : impl_(std::make_unique<Impl>()) {
  Vjoint_controller& top = impl_->top;
  top.clk_i = 0;
  top.rst_ni = 0;
  top.ap_start_i = 0;
  top.eval();
  for (int i = 0; i < 4; ++i) tick();
  top.rst_ni = 1;
  tick();
}

JointRtlModel::~JointRtlModel() { impl_->top.final(); }

void JointRtlModel::tick() {
  impl_->top.clk_i = 1;
  impl_->top.eval();
  impl_->top.clk_i = 0;
  impl_->top.eval();
}

JointRtlResult JointRtlModel::run(const std::array<control::JointFixedInput, 3>& inputs) {
  Vjoint_controller& top = impl_->top;
  for (int j = 0; j < 3; ++j) {
    top.reference_i[j] = static_cast<std::uint32_t>(inputs[j].reference);
  }
  top.encoder_i = 0;
  for (int j = 0; j < 3; ++j) {
    top.encoder_i |= static_cast<std::uint64_t>(static_cast<std::uint16_t>(inputs[j].encoder)) << (16 * j);
  }
  if (!top.ap_idle_o) throw std::runtime_error("joint_controller: not idle before ap_start");
  top.ap_start_i = 1;
  JointRtlResult result;
  for (;;) {
    tick();
    top.ap_start_i = 0;
    ++result.cycles;
    if (top.ap_done_o) break;
    if (result.cycles > 100000) throw std::runtime_error("joint_controller: no ap_done");
  }
  impl_->bank_written = !impl_->bank_written;
  for (int j = 0; j < 3; ++j) {
    result.current[j] = static_cast<std::int16_t>((top.current_o >> (16 * j)) & 0xFFFFu);
    result.limited[j] = (top.limited_o >> j) & 1u;
  }
  result.overflow_count = top.overflow_count_o;
  tick();  // StateDone -> idle, the bank flips
  return result;
}

control::JointFixedState JointRtlModel::state(int joint) const {
  const auto& memory = impl_->top.rootp->joint_controller__DOT__u_state_ram__DOT__memory_q;
  // The last run wrote bank 0 first (bank_q starts at 0 after reset).
  const int bank = impl_->bank_written ? 0 : 1;
  auto word = [&](int slot) { return static_cast<std::int32_t>(memory[(joint << 4) | (bank << 3) | slot]); };
  control::JointFixedState state;
  state.reference = word(0);
  state.reference_velocity = word(1);
  state.reference_acceleration = word(2);
  state.encoder = word(3);
  state.velocity = word(4);
  state.disturbance = word(5);
  state.current = word(6);
  return state;
}

}  // namespace delta::rtl
