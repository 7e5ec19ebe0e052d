// The ap_ctrl_hs handshake of joint_controller, for any Verilated model with its ports (RTL or
// gate-level netlist): one control period per call.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>

#include "delta/golden/joint_fixed.hpp"

namespace delta::rtl {

struct JointRtlResult {
  std::array<std::int16_t, 3> current{};
  std::array<bool, 3> limited{};
  std::uint16_t overflow_count = 0;  // since reset, sticks at 0xFFFF
  long cycles = 0;                   // ap_start to ap_done
};

template <typename Model>
void clock_cycle(Model& top) {
  top.ap_clk = 1;
  top.eval();
  top.ap_clk = 0;
  top.eval();
}

// Holds ap_rst for a few cycles.
template <typename Model>
void reset_model(Model& top) {
  top.ap_clk = 0;
  top.ap_rst = 1;
  top.ap_start = 0;
  top.eval();
  for (int i = 0; i < 4; ++i) clock_cycle(top);
  top.ap_rst = 0;
  clock_cycle(top);
}

// The shifts written while idle (one cycle each), then ap_start held until ap_ready; every
// current_j_ap_vld must pulse once before ap_done. Throws
// std::runtime_error on a protocol fault. Leaves the model idle again.
template <typename Model>
JointRtlResult run_period(Model& top, const std::array<golden::JointFixedInput, 3>& inputs) {
  top.reference_0 = static_cast<std::uint32_t>(inputs[0].reference);
  top.reference_1 = static_cast<std::uint32_t>(inputs[1].reference);
  top.reference_2 = static_cast<std::uint32_t>(inputs[2].reference);
  top.encoder_0 = static_cast<std::uint16_t>(inputs[0].encoder);
  top.encoder_1 = static_cast<std::uint16_t>(inputs[1].encoder);
  top.encoder_2 = static_cast<std::uint16_t>(inputs[2].encoder);
  if (!top.ap_idle) throw std::runtime_error("joint_controller: not idle before ap_start");
  for (int j = 0; j < 3; ++j) {  // the play shifts, through the idle-time write port
    top.shift_write = 1;
    top.shift_joint = static_cast<std::uint8_t>(j);
    top.shift_value = static_cast<std::uint16_t>(inputs[j].shift) & ((1u << golden::kShiftBits) - 1);
    clock_cycle(top);
  }
  top.shift_write = 0;
  top.ap_start = 1;
  JointRtlResult result;
  std::array<int, 3> valid_pulses{};
  for (;;) {
    const bool ready = top.ap_ready;
    clock_cycle(top);
    if (ready) top.ap_start = 0;
    ++result.cycles;
    valid_pulses[0] += top.current_0_ap_vld;
    valid_pulses[1] += top.current_1_ap_vld;
    valid_pulses[2] += top.current_2_ap_vld;
    if (top.ap_done) break;
    if (result.cycles > 100000) throw std::runtime_error("joint_controller: no ap_done");
  }
  if (valid_pulses != std::array<int, 3>{1, 1, 1}) throw std::runtime_error("joint_controller: current_j_ap_vld");
  const std::array<std::uint16_t, 3> currents{top.current_0, top.current_1, top.current_2};
  for (int j = 0; j < 3; ++j) {
    result.current[j] = static_cast<std::int16_t>(currents[j]);
    result.limited[j] = (top.limited >> j) & 1u;
  }
  result.overflow_count = top.overflow_count;
  clock_cycle(top);  // done -> idle
  return result;
}

}  // namespace delta::rtl
