// The Verilated board core's clocks: one board clock is two network clocks, rising together with
// it (the PLL's GENCLK and GENCLK_HALF). Shared by the co-simulation and the board tests.
#pragma once

#include <cstdint>
#include <type_traits>

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

// The board core out of reset: the pins idle (the UART line high, the encoder lines and home
// switches low), both resets held for four board clocks, then released.
template <typename BoardCore>
void reset_board(BoardCore& core) {
  core.uart_rx_i = 1;
  core.encoder_a_i = 0;
  core.encoder_b_i = 0;
  core.home_switch_i = 0;
  core.rst_ni = 0;
  core.rst_network_ni = 0;
  for (int i = 0; i < 4; ++i) clock_board(core);
  core.rst_ni = 1;
  core.rst_network_ni = 1;
}

// clock_board, without the network clock's two edges where they provably change nothing (none of
// the network's logic evaluated) and with one evaluation per rising edge (below): the same state
// after every board clock (RtlBoard.SkippingAnIdleNetworksClockEdgesChangesNothing in
// tests/rtl/test_model_board.cpp runs a session both ways and compares them). Constructed
// disabled, it is clock_board: every edge, four evaluations.
//
// Why an idle network's edges change nothing (rtl/network/delta_network.sv, network_crossing.sv):
// with busy_q low and no start (the crossing's start_q low), accept and issue are low, so the
// counters (step, neuron, group) hold, group_q is 0 (every inference ends on its last group and
// accept clears it), the token pipeline shifts in constants and no valid bit, and every other
// register is either enabled by accept or a valid bit (offset_q, activation_q, both accumulators
// of layer 2, resolved_q, y_q) and holds, or a function of constant registers and ROM words at
// constant addresses one stage down: after the pipeline's depth (14 stages behind the token
// registers' 12) each one has reached its fixed point. accum1_q too: its feedback is taken only
// when first_group_s3_q is low, which needs a token of group > 0. The crossing's network side
// holds when its request synchroniser already shows request_q, request_seen_q matches it and
// start_q is low; request_q toggles only at a board edge where ready is high (then the second
// network edge of that board clock would see it). The memories the pipeline reads are the
// model's, which the loader writes in the board clock (model_write): a write changes the words at
// those constant addresses, so a board clock that writes one is not quiet, and the pipeline's
// fixed point is reached again only kFlushEdges network edges later. kFlushEdges network edges of
// idle, a margin over the 26 stages, before the first skip.
//
// One evaluation per rising edge: Verilator 5 finds a rising edge of a clock against the level the
// last eval() saw, which it keeps in the model (__Vtrigrprev__TOP__<clock>). board_core acts on
// rising clock edges only (its resets are the only other triggers, and no logic reads a clock's
// level), so an evaluation at a falling edge recomputes the same values from the same registers and
// inputs. Where the model keeps those levels, the falling edges are recorded there instead of
// evaluated: a board clock is one evaluation, two with the network's edges; the clocks stay high
// between board clocks. Another Verilator: every falling edge evaluated (same results).
template <typename Root, typename = void>
struct RecordsClockLevels : std::false_type {};
template <typename Root>
struct RecordsClockLevels<
    Root, std::void_t<decltype(Root::__Vtrigrprev__TOP__clk_i), decltype(Root::__Vtrigrprev__TOP__clk_network_i)>>
    : std::true_type {};

class IdleNetworkSkip {
 public:
  static constexpr std::uint32_t kFlushEdges = 64;

  explicit IdleNetworkSkip(bool enabled = true) : enabled_(enabled) {}

  template <typename BoardCore>
  void clock(BoardCore& core) {
    if (!enabled_) {
      clock_board(core);
      return;
    }
    auto& root = *core.rootp;
    using Root = std::remove_reference_t<decltype(root)>;
    const bool request = root.board_core__DOT__u_crossing__DOT__request_q;
    const bool quiet = !root.board_core__DOT__u_network__DOT__busy_q &&
                       !root.board_core__DOT__u_crossing__DOT__start_q &&
                       root.board_core__DOT__u_crossing__DOT__request_sync_q == (request ? 3u : 0u) &&
                       root.board_core__DOT__u_crossing__DOT__request_seen_q == request &&
                       !root.board_core__DOT__u_crossing__DOT__ready && !root.board_core__DOT__model_write;
    const bool skip = quiet && idle_edges_ >= kFlushEdges;
    if (!quiet) {
      idle_edges_ = 0;
    } else if (!skip) {
      idle_edges_ += 2;
    }
    if (skip) ++skipped_;
    if constexpr (RecordsClockLevels<Root>::value) {
      root.__Vtrigrprev__TOP__clk_i = 0;  // the falling edge of the last board clock
      core.clk_i = 1;
      if (!skip) {
        root.__Vtrigrprev__TOP__clk_network_i = 0;
        core.clk_network_i = 1;
      }
      core.eval();
      if (skip) return;
      root.__Vtrigrprev__TOP__clk_network_i = 0;  // the network's second rising edge
      core.eval();
    } else if (skip) {
      core.clk_i = 1;
      core.eval();
      core.clk_i = 0;
      core.eval();
    } else {
      clock_board(core);
    }
  }
  std::uint64_t skipped() const { return skipped_; }  // board clocks without network edges

 private:
  bool enabled_;
  std::uint32_t idle_edges_ = 0;  // network edges clocked with the network quiet before them
  std::uint64_t skipped_ = 0;
};

}  // namespace delta::rtl
