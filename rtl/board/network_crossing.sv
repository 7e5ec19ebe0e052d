// The network's ap_ctrl_hs handshake across two clocks: a slave on the board's side (clk_i, the
// UART link and the joints) and a master to the network on its own faster clock (clk_network_i).
//
// Board side (ap_ctrl_hs as the network's): start_i is taken while no request is in flight;
// ready_o is high in that cycle (inputs_i captured). done_o pulses for one cycle with outputs_o
// valid; outputs_o holds until the next done_o.
//
// Crossing: two toggles, each with a two-flip-flop synchroniser on the receiving side. The board
// side captures the inputs and toggles request_q in the same edge; the network side sees the
// toggle two or three of its cycles later, when the captured inputs have long settled, and
// starts the network. At ap_done the network side captures the outputs and toggles answer_q in
// the same edge; the board side sees it two or three of its cycles later and copies them. Each
// captured word holds until the other side has acknowledged it (the next request waits for the
// answer), so no bit is ever sampled while it changes, whatever the phase between the clocks.
// Cost: 2-3 cycles of each clock per direction on top of the network's own latency.
//
// CaptureInputs = 0 (the board: setpoint_buffer holds its inputs until the answer) drops the
// input capture register: inputs_i must then hold from start_i until done_o. CaptureOutputs = 0
// (the board) drops both output registers: outputs_o is then the network's own output register,
// which holds from its ap_done until the next one, and the next request waits for this answer's
// done_o; the board reads it only between done_o and its next start_i.
module network_crossing #(
  parameter int unsigned InputBits     = 96,
  parameter int unsigned OutputBits    = 72,
  parameter bit          CaptureInputs  = 1'b1,
  parameter bit          CaptureOutputs = 1'b1
) (
  // board side
  input  logic                  clk_i,
  input  logic                  rst_ni,
  input  logic                  start_i,
  output logic                  ready_o,
  output logic                  done_o,
  input  logic [InputBits-1:0]  inputs_i,
  output logic [OutputBits-1:0] outputs_o,
  // network side
  input  logic                  clk_network_i,
  input  logic                  rst_network_ni,
  output logic                  net_start_o,
  input  logic                  net_ready_i,
  input  logic                  net_done_i,
  output logic [InputBits-1:0]  net_inputs_o,
  input  logic [OutputBits-1:0] net_outputs_i
);
  // ---- board side (clk_i) ---------------------------------------------------------------------
  logic [InputBits-1:0]  inputs_q;
  logic [OutputBits-1:0] outputs_q;
  logic                  busy_q, answer_seen_q, done_q;
  // Read by the simulation's idle skip (rtl/board/sim/include/delta/rtl/board_clock.hpp).
  logic                  request_q /*verilator public_flat_rd*/;
  logic [1:0]            answer_sync_q;
  logic [OutputBits-1:0] held_outputs_q;  // network side, below
  logic                  answer_q;

  logic ready /*verilator public_flat_rd*/;  // request_q toggles at the next edge
  assign ready   = start_i && !busy_q;
  assign ready_o = ready;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      inputs_q      <= '0;
      outputs_q     <= '0;
      request_q     <= 1'b0;
      busy_q        <= 1'b0;
      answer_sync_q <= 2'b00;
      answer_seen_q <= 1'b0;
      done_q        <= 1'b0;
    end else begin
      answer_sync_q <= {answer_sync_q[0], answer_q};
      done_q        <= 1'b0;
      if (ready_o) begin
        inputs_q  <= inputs_i;
        request_q <= !request_q;
        busy_q    <= 1'b1;
      end
      if (answer_sync_q[1] != answer_seen_q) begin
        answer_seen_q <= answer_sync_q[1];
        outputs_q     <= held_outputs_q;
        done_q        <= 1'b1;
        busy_q        <= 1'b0;
      end
    end
  end
  assign done_o    = done_q;
  assign outputs_o = CaptureOutputs ? outputs_q : net_outputs_i;

  // ---- network side (clk_network_i) -------------------------------------------------------------
  logic [1:0]            request_sync_q /*verilator public_flat_rd*/;
  logic                  request_seen_q /*verilator public_flat_rd*/;
  logic                  start_q /*verilator public_flat_rd*/;

  always_ff @(posedge clk_network_i or negedge rst_network_ni) begin
    if (!rst_network_ni) begin
      request_sync_q <= 2'b00;
      request_seen_q <= 1'b0;
      start_q        <= 1'b0;
      held_outputs_q <= '0;
      answer_q       <= 1'b0;
    end else begin
      request_sync_q <= {request_sync_q[0], request_q};
      if (request_sync_q[1] != request_seen_q) begin
        request_seen_q <= request_sync_q[1];
        start_q        <= 1'b1;
      end
      if (net_ready_i) start_q <= 1'b0;
      if (net_done_i) begin
        held_outputs_q <= net_outputs_i;
        answer_q       <= !answer_q;
      end
    end
  end
  assign net_start_o  = start_q;
  assign net_inputs_o = CaptureInputs ? inputs_q : inputs_i;
endmodule
