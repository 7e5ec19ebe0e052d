// The Verilated board core's clocks: one board clock is two network clocks, rising together with
// it (the PLL's GENCLK and GENCLK_HALF). Shared by the co-simulation and the board tests.
#pragma once

namespace delta::rtl {

template <typename BoardCore>
void clock_board(BoardCore& core) {
  core.clk_i = 1;
  core.clk_network_i = 1;
  core.eval();
  core.clk_network_i = 0;
  core.eval();
  core.clk_i = 0;
  core.clk_network_i = 1;
  core.eval();
  core.clk_network_i = 0;
  core.eval();
}

}  // namespace delta::rtl
