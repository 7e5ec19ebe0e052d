// network_crossing (rtl/board): the network's ap_ctrl_hs handshake across two clocks. A board-side
// master sends random requests, a network-side slave with random latency answers each with a
// function of the inputs it captured; every answer must come back exactly once, in order, with
// the right value, whatever the two clocks' periods and phase. The master scrambles its inputs
// as soon as a request is taken and the slave drives garbage outputs except at done, so a
// crossing that sampled either side at the wrong time would fail.
#include <gtest/gtest.h>

#include <cstdint>
#include <deque>
#include <iostream>
#include <random>

#include "Vnetwork_crossing.h"
#include "verilated.h"

namespace delta::test {
namespace {

struct Wide {  // 96 request bits, 72 answer bits, as Verilator's word arrays
  std::uint32_t w[3] = {0, 0, 0};
  bool operator==(const Wide& o) const { return w[0] == o.w[0] && w[1] == o.w[1] && w[2] == o.w[2]; }
};

Wide random_wide(std::mt19937_64& random, int bits) {
  Wide x;
  for (int i = 0; i < 3; ++i) x.w[i] = static_cast<std::uint32_t>(random());
  if (bits < 96) x.w[2] &= (1u << (bits - 64)) - 1;
  return x;
}

// The "network": 72 bits from 96, every input bit matters.
Wide answer_of(const Wide& in) {
  Wide out;
  std::uint64_t h = 0x9E3779B97F4A7C15ull;
  for (std::uint32_t word : in.w) h = (h ^ word) * 0xBF58476D1CE4E5B9ull;
  out.w[0] = static_cast<std::uint32_t>(h);
  out.w[1] = static_cast<std::uint32_t>(h >> 32);
  out.w[2] = (in.w[0] ^ in.w[2]) & 0xFF;
  return out;
}

struct ClockSetup {
  int board_half;     // half period of clk_i, time units
  int network_half;   // half period of clk_network_i
  int network_phase;  // offset of clk_network_i
};

// Runs `requests` handshakes; returns the answers checked.
int run_crossing(const ClockSetup& clocks, std::uint64_t seed, int requests) {
  std::mt19937_64 random(seed);
  VerilatedContext context;
  Vnetwork_crossing dut(&context);
  dut.clk_i = 0;
  dut.clk_network_i = 0;
  dut.rst_ni = 0;
  dut.rst_network_ni = 0;
  dut.start_i = 0;
  dut.net_ready_i = 0;
  dut.net_done_i = 0;
  dut.eval();
  dut.rst_ni = 1;
  dut.rst_network_ni = 1;
  dut.eval();

  // Board-side master.
  bool requesting = false;
  Wide request;
  std::deque<Wide> expected;
  int answered = 0, sent = 0;
  // Network-side slave (ap_ctrl_hs like delta_network: ready = start while idle).
  bool busy = false;
  int countdown = 0;
  Wide captured;

  auto set_inputs = [&](const Wide& x) {
    for (int i = 0; i < 3; ++i) dut.inputs_i[i] = x.w[i];
  };
  auto set_outputs = [&](const Wide& x) {
    for (int i = 0; i < 3; ++i) dut.net_outputs_i[i] = x.w[i];
  };
  set_inputs(random_wide(random, 96));
  set_outputs(random_wide(random, 72));

  bool board_clock = false, network_clock = false;
  for (std::int64_t t = 0; answered < requests; ++t) {
    if (t > std::int64_t{requests} * 4000 * (clocks.board_half + clocks.network_half)) {
      ADD_FAILURE() << "no progress: " << answered << " of " << requests << " answered";
      return answered;
    }
    const bool board_next = (t / clocks.board_half) % 2 == 1;
    const bool network_next = ((t + clocks.network_phase) / clocks.network_half) % 2 == 1;
    const bool board_rises = board_next && !board_clock;
    const bool network_rises = network_next && !network_clock;
    board_clock = board_next;
    network_clock = network_next;
    // Values before the edges (what the synchronous models sample).
    const bool ready_before = dut.ready_o, done_before = dut.done_o;
    Wide outputs_before;
    for (int i = 0; i < 3; ++i) outputs_before.w[i] = dut.outputs_o[i];
    const bool net_ready_before = dut.net_ready_i, net_done_before = dut.net_done_i;
    Wide net_inputs_before;
    for (int i = 0; i < 3; ++i) net_inputs_before.w[i] = dut.net_inputs_o[i];

    dut.clk_i = board_clock;
    dut.clk_network_i = network_clock;
    dut.eval();

    if (board_rises) {
      if (requesting && ready_before) {  // taken at this edge: scramble the inputs at once
        expected.push_back(answer_of(request));
        requesting = false;
        ++sent;
        set_inputs(random_wide(random, 96));
      }
      if (done_before) {
        if (expected.empty()) {
          ADD_FAILURE() << "answer without a request at t " << t;
          return answered;
        }
        EXPECT_TRUE(outputs_before == expected.front()) << "answer " << answered << " at t " << t;
        expected.pop_front();
        ++answered;
      }
      if (!requesting && sent < requests && random() % 4 == 0) {
        requesting = true;
        request = random_wide(random, 96);
        set_inputs(request);
      }
      dut.start_i = requesting;
    }
    if (network_rises) {
      dut.net_done_i = 0;
      set_outputs(random_wide(random, 72));  // garbage except in the done cycle
      if (net_done_before) busy = false;
      if (net_ready_before) {
        captured = net_inputs_before;
        busy = true;
        countdown = 1 + static_cast<int>(random() % 20);
      } else if (busy && countdown > 0 && --countdown == 0) {
        dut.net_done_i = 1;
        set_outputs(answer_of(captured));
      }
    }
    dut.eval();
    dut.net_ready_i = dut.net_start_o && !busy;  // combinational, like the network's accept
    dut.eval();
  }
  EXPECT_TRUE(expected.empty());
  return answered;
}

TEST(NetworkCrossing, EveryAnswerArrivesOnceAndRightWhateverTheClocks) {
  constexpr std::uint64_t kSeed = 20261121;
  std::cout << "seed " << kSeed << "\n";
  const ClockSetup setups[] = {
      {2, 1, 0},  // the board: network clock twice the board's, edges aligned (PLL GENCLK_HALF)
      {7, 3, 1},  // unrelated, network faster
      {3, 5, 2},  // network slower than the board
      {5, 5, 3},  // same frequency, shifted phase
  };
  for (const ClockSetup& clocks : setups) {
    const int answered = run_crossing(clocks, kSeed + clocks.board_half * 10 + clocks.network_half, 2000);
    EXPECT_EQ(answered, 2000) << "board half period " << clocks.board_half << ", network " << clocks.network_half;
  }
}

}  // namespace
}  // namespace delta::test
