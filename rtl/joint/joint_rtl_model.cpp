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

JointRtlModel::JointRtlModel() : impl_(std::make_unique<Impl>()) {
  Vjoint_controller& top = impl_->top;
  top.ap_clk = 0;
  top.ap_rst = 1;
  top.ap_start = 0;
  top.eval();
  for (int i = 0; i < 4; ++i) tick();
  top.ap_rst = 0;
  tick();
}

JointRtlModel::~JointRtlModel() { impl_->top.final(); }

void JointRtlModel::tick() {
  impl_->top.ap_clk = 1;
  impl_->top.eval();
  impl_->top.ap_clk = 0;
  impl_->top.eval();
}

JointRtlResult JointRtlModel::run(const std::array<control::JointFixedInput, 3>& inputs) {
  Vjoint_controller& top = impl_->top;
  top.reference_0 = static_cast<std::uint32_t>(inputs[0].reference);
  top.reference_1 = static_cast<std::uint32_t>(inputs[1].reference);
  top.reference_2 = static_cast<std::uint32_t>(inputs[2].reference);
  top.encoder_0 = static_cast<std::uint16_t>(inputs[0].encoder);
  top.encoder_1 = static_cast<std::uint16_t>(inputs[1].encoder);
  top.encoder_2 = static_cast<std::uint16_t>(inputs[2].encoder);
  if (!top.ap_idle) throw std::runtime_error("joint_controller: not idle before ap_start");
  // ap_start stays high until ap_ready; every current_j_ap_vld must pulse once before ap_done.
  top.ap_start = 1;
  JointRtlResult result;
  std::array<int, 3> valid_pulses{};
  for (;;) {
    const bool ready = top.ap_ready;
    tick();
    if (ready) top.ap_start = 0;
    ++result.cycles;
    valid_pulses[0] += top.current_0_ap_vld;
    valid_pulses[1] += top.current_1_ap_vld;
    valid_pulses[2] += top.current_2_ap_vld;
    if (top.ap_done) break;
    if (result.cycles > 100000) throw std::runtime_error("joint_controller: no ap_done");
  }
  if (valid_pulses != std::array<int, 3>{1, 1, 1}) throw std::runtime_error("joint_controller: current_j_ap_vld");
  ++impl_->runs;
  const std::array<std::uint16_t, 3> currents{top.current_0, top.current_1, top.current_2};
  for (int j = 0; j < 3; ++j) {
    result.current[j] = static_cast<std::int16_t>(currents[j]);
    result.limited[j] = (top.limited >> j) & 1u;
  }
  result.overflow_count = top.overflow_count;
  tick();  // StateDone -> idle, the bank flips
  return result;
}

control::JointFixedState JointRtlModel::state(int joint) const {
  const auto& memory = impl_->top.rootp->joint_controller__DOT__u_state_ram__DOT__memory_q;
  const int bank = static_cast<int>((impl_->runs - 1) % 2);
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
