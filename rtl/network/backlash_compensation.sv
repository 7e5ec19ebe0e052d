// The deployed model's backlash compensation of the network's answers (hls/README.md, step 7;
// golden model delta::golden::compensate, HLS hls/network/backlash_compensation.hpp): per joint a
// play of half-width h' on the answers s, in the order they come. First answer after reset or
// restart: r = s; then d = s - r: d > h' gives r = s - h', d < -h' gives r = s + h', else r holds.
// The new r always fits the output format (s - h' > r when d > h', s + h' < r when d < -h').
//
// One shared datapath serves the joints one per cycle: the references rotate through position 0,
// and the answer of the joint in turn is selected from answers_i. With lowered = s - h' and
// raised = s + h', d > h' is lowered > r and d < -h' is raised < r: two adders, two comparators.
// Handshake: answer_i pulses with answers_i valid; answers_i must hold until done_o (the board's
// network output register and the harness hold it). NumJoints cycles later done_o pulses;
// references_o is valid from then until the cycle after the next answer_i. restart_i (a pulse
// while idle) forgets the play: the next answer passes unchanged.
// Latency: NumJoints (3) cycles from answer_i to done_o. yosys synth_ice40 (gate-level netlist
// log): NumJoints x Width reference flip-flops and the 25-bit datapath.
module backlash_compensation #(
  parameter int unsigned NumJoints     = delta_network_pkg::NumOutputs,
  parameter int unsigned Width         = delta_network_pkg::OutputWidth,
  // golden::Formats::half_play_bits: h' in output LSBs, [0, 4) deg (the RTL test runs the widest)
  parameter int unsigned HalfPlayWidth = 16
) (
  input  logic                               clk_i,
  input  logic                               rst_ni,
  input  logic                               restart_i,     // pulse while idle: the next answer passes
  input  logic                               answer_i,      // pulse: answers_i holds new answers
  input  logic [NumJoints*Width-1:0]         answers_i,     // s_j at [Width j +: Width], Q10.14 deg, held
  input  logic [NumJoints*HalfPlayWidth-1:0] half_play_i,   // h'_j, unsigned output LSBs, constant
  output logic                               done_o,        // pulse: references_o valid
  output logic [NumJoints*Width-1:0]         references_o   // r_j at [Width j +: Width], Q10.14 degrees
);
  localparam int unsigned DifferenceWidth = Width + 1;  // s - r, s -/+ h' (compensation_difference_bits)
  localparam int unsigned JointWidth      = $clog2(NumJoints + 1);

  logic [Width-1:0]      reference_q [NumJoints];  // during an update, [0] is the joint computed
  logic [JointWidth-1:0] joint_q;
  logic                  busy_q, started_q, done_q;

  // ---- the shared datapath: joint joint_q, whose reference is at position 0 -----------------------
  logic signed [DifferenceWidth-1:0] answer_wide, reference_wide, half_play_wide, lowered, raised;
  logic [Width-1:0]                  next_reference;

  always_comb begin
    answer_wide    = DifferenceWidth'(signed'(answers_i[Width*joint_q +: Width]));
    reference_wide = DifferenceWidth'(signed'(reference_q[0]));
    half_play_wide = DifferenceWidth'(half_play_i[HalfPlayWidth*joint_q +: HalfPlayWidth]);
    lowered        = answer_wide - half_play_wide;
    raised         = answer_wide + half_play_wide;
    next_reference = reference_q[0];
    if (!started_q) begin
      next_reference = answer_wide[Width-1:0];
    end else if (lowered > reference_wide) begin  // s - r > h'
      next_reference = lowered[Width-1:0];
    end else if (raised < reference_wide) begin   // s - r < -h'
      next_reference = raised[Width-1:0];
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      for (int j = 0; j < NumJoints; j++) reference_q[j] <= '0;
      joint_q   <= '0;
      busy_q    <= 1'b0;
      started_q <= 1'b0;
      done_q    <= 1'b0;
    end else begin
      done_q <= 1'b0;
      if (restart_i && !busy_q) started_q <= 1'b0;
      if (answer_i && !busy_q) begin
        joint_q <= '0;
        busy_q  <= 1'b1;
      end else if (busy_q) begin
        for (int j = 0; j + 1 < NumJoints; j++) reference_q[j] <= reference_q[j + 1];
        reference_q[NumJoints-1] <= next_reference;
        if (joint_q == JointWidth'(NumJoints - 1)) begin
          busy_q    <= 1'b0;
          done_q    <= 1'b1;
          started_q <= 1'b1;
          joint_q   <= '0;
        end else begin
          joint_q <= joint_q + JointWidth'(1);
        end
      end
    end
  end

  assign done_o = done_q;
  for (genvar j = 0; j < NumJoints; j++) begin : g_references
    assign references_o[Width*j +: Width] = reference_q[j];
  end
endmodule
