// The joint references between network answers: 10 kHz references interpolated between 1 kHz
// answers, in Q24.8 encoder counts (docs/board_link.md; golden model
// host/golden/include/delta/golden/setpoint_interpolation.hpp, bit-exact).
//
// Segment s (10 control periods, k = 0..9): r_k = B + round_shift(D * K_k, 14), K_k = round(k
// 2^14 / 10), B' = B + D. Only r and D are stored; an update moves r from period k to k + 1 as
//   r' = r - round_shift(D * K_k, 14) + round_shift(D * K_(k+1), 14),   K_10 = 2^14,
// so after k = 9 it lands exactly on B + D. A network answer y (answer_i, in the first period of a
// segment) sets D = saturate_16(play(round_shift(25 y, 4) - r, H)) at the next update (r = B
// then); slew_limited_o pulses when it saturates. A new segment starts with D = 0: without an
// answer (underrun, hold) the reference holds. With enabled_i low the reference is the encoder
// count. With homing_i high a segment's change D is kept for the next segment (a jog: the
// reference moves D per setpoint period until an answer changes it). Each joint's update also works out its play shift for the next period (below)
// and hands it to the joint controllers (shift_write_o, shift_joint_o, shift_o).
//
// Backlash compensation (the deployed model): play(d, H) = d - H for d > H, d + H for
// d < -H, else 0: the segment's target moves only when the answer leaves the play of half-width
// H_j (Q.8 counts) around the reference the joint holds, and then trails it by H_j. The play words
// (H_j and the play shift's ends, docs/board_link.md "The model", frames 178 .. 180) are data: the
// model loader writes joint j's (play_write_i) into a small block RAM, read by joint (a register's
// read: the word of the joint being computed is there from its step 1 on; zero until written).
// With H = 25 h / 16 (h: the model's half-play in output LSBs, a whole number of 16) the target
// is exactly round_shift(25 r, 4) of the golden compensation r of the answers (golden
// SetpointInterpolator). H = 0 (the plain network) passes d unchanged. d = C - r: 33 bits;
// d -/+ H: one adder; the result is d -/+ H when its sign is d's, else 0 (at |d| = H both are 0).
//
// update_i (once per period, after the controller has copied its inputs and well before the next
// period starts) runs the three joints through one shared datapath, one after the other (8 cycles
// each); r and D rotate through it, so no joint needs a multiplexer. One multiplier (an iCE40
// DSP), used twice per joint.
module reference_interpolator #(
  parameter int unsigned HalfPlayBits = delta_board_pkg::HalfPlayBits,
  localparam int unsigned PlayWordBits = HalfPlayBits + 21
) (
  input  logic        clk_i,
  input  logic        rst_ni,
  input  logic        update_i,       // pulse: compute the references of the next period
  input  logic [3:0]  phase_i,        // k of the period now running (0..9)
  input  logic        enabled_i,      // drives on: interpolate; off: follow the encoders
  input  logic        homing_i,       // keep D from segment to segment (board_core's homing)
  input  logic        answer_i,       // pulse: outputs_i holds a new network answer
  input  logic [71:0] outputs_i,      // y_j at [24j +: 24], Q10.14 degrees, held
  input  logic [47:0] counts_i,       // encoder counts, joint j at [16j +: 16]
  input  logic [2:0]  rising_i,       // bit j: joint j's count last stepped up (quadrature_counter)
  input  logic        play_write_i,   // pulse: play_word_i is joint play_joint_i's play word
  input  logic [1:0]  play_joint_i,
  input  logic [PlayWordBits-1:0] play_word_i,  // H (bits 0-16), above (17-26), below (27-36), rounds (37)
  output logic [95:0] references_o,   // r_j at [32j +: 32], Q24.8 counts, stable between updates
  output logic        shift_write_o,  // pulse: shift_o is joint shift_joint_o's play shift for the next period
  output logic [1:0]  shift_joint_o,
  output logic [delta_joint_pkg::ShiftBits-1:0] shift_o,  // s, whole counts (the resting shift until an answer)
  output logic        slew_limited_o  // pulse: a segment's change was saturated
);
  localparam int unsigned Shift = delta_board_pkg::InterpolationShift;
  localparam int unsigned DeltaBits = delta_board_pkg::SegmentDeltaBits;

  // K_k = round(k 2^14 / 10) for k = 0..10, a table (a divider would cost hundreds of cells).
  function automatic logic [15:0] k_weight(logic [3:0] k);
    unique case (k)
      4'd0: k_weight = 16'd0;
      4'd1: k_weight = 16'd1638;
      4'd2: k_weight = 16'd3277;
      4'd3: k_weight = 16'd4915;
      4'd4: k_weight = 16'd6554;
      4'd5: k_weight = 16'd8192;
      4'd6: k_weight = 16'd9830;
      4'd7: k_weight = 16'd11469;
      4'd8: k_weight = 16'd13107;
      4'd9: k_weight = 16'd14746;
      default: k_weight = 16'd16384;
    endcase
  endfunction

  logic [31:0]          r_q [3];
  logic [DeltaBits-1:0] d_q [3];
  logic                 answer_pending_q;

  // ---- one joint per 7 steps; position 0 of the rotation is the joint being computed ----------
  logic        busy_q;
  logic [3:0]  step_q;
  logic [1:0]  joint_q;
  logic [3:0]  k_next;
  logic signed [28:0] y25_q;   // 9 y
  logic signed [32:0] diff_q;  // c - r
  logic signed [32:0] played_q;  // c - r -/+ H
  logic signed [DeltaBits-1:0] delta_q;
  logic signed [31:0] product_q;
  logic signed [16:0] rounded_now_q;
  logic signed [23:0] y;
  logic [15:0]        count;
  logic [HalfPlayBits-1:0] half_play;

  // The play words: one block RAM (no_rw_check: a word written in the clock it is read is taken
  // only with the drives off, where the next update reads it again).
  (* ram_style = "block", no_rw_check *) logic [PlayWordBits-1:0] play_words [4];
  logic [PlayWordBits-1:0] play_q;  // the word of joint_q (read a clock before)
  initial begin
    for (int j = 0; j < 4; j++) play_words[j] = '0;
  end
  always_ff @(posedge clk_i) begin
    if (play_write_i) play_words[play_joint_i] <= play_word_i;
    play_q <= play_words[joint_q];
  end

  assign k_next = (phase_i == 4'(delta_board_pkg::PeriodsPerSetpoint - 1)) ? 4'(delta_board_pkg::PeriodsPerSetpoint)
                                                                         : phase_i + 4'd1;
  always_comb begin
    unique case (joint_q)
      2'd1: begin
        y     = outputs_i[24 +: 24];
        count = counts_i[16 +: 16];
      end
      2'd2: begin
        y     = outputs_i[48 +: 24];
        count = counts_i[32 +: 16];
      end
      default: begin
        y     = outputs_i[0 +: 24];
        count = counts_i[0 +: 16];
      end
    endcase
  end

  // play(c - r, H): d - H for d >= 0, d + H for d < 0, kept when the sign stays d's, else 0.
  logic signed [32:0] played;
  assign played = (played_q[32] == diff_q[32]) ? played_q : '0;

  // saturate_16(play): the value fits when its bits 32..15 all equal the sign.
  logic signed [DeltaBits-1:0] delta_saturated;
  logic                        saturated;
  always_comb begin
    saturated       = played[32:DeltaBits-1] != '0 && played[32:DeltaBits-1] != '1;
    delta_saturated = !saturated ? DeltaBits'(played)
                    : played[32] ? {1'b1, {(DeltaBits - 1){1'b0}}} : {1'b0, {(DeltaBits - 1){1'b1}}};
  end

  // The play shift of the next period (golden interpolation::play_shift): s = floor((clamp(d,
  // -H, H) + g) / 256), d = C - r, g = 0 when H mod 256 is in [64, 192), else 128: inside the play
  // (-H <= d < H: the signs of d and d -/+ H differ) (d >> 8) + (d[7] if g), above it the constant
  // floor((H + g) / 256), below it floor((g - H) / 256), per joint (folded by synthesis). Written
  // into the controller's state memory at step 7 of each joint. HalfPlayBits = 17: 10 bits.
  // Until the first answer since the drives came on (answered_q), and with the drives off, s is the
  // resting shift (golden interpolation::resting_shift): the end of the play on the side the
  // joint's count last stepped to, where the play was last taken up. So the controller's previous
  // shift at the enable is the one it starts with, and a first answer the host aims at the count
  // plus that end (the telemetry reports the side) keeps it: the enable moves no joint.
  logic answered_q;
  logic pick_end, end_up;
  logic       in_play, half_up, rising;
  logic [9:0] shift_new, shift_above, shift_below;
  // The ends floor((H + g) / 256) and floor((g - H) / 256) and g's choice come with H in the play
  // word (the host works them out: golden model_words).
  assign {half_up, shift_below, shift_above, half_play} = play_q;
  always_comb begin
    unique case (joint_q)
      2'd1:    rising = rising_i[1];
      2'd2:    rising = rising_i[2];
      default: rising = rising_i[0];
    endcase
  end
  assign in_play   = played_q[32] != diff_q[32];
  logic round_bit;
  assign round_bit = half_up && diff_q[7];
  assign pick_end  = !answered_q || !in_play;
  assign end_up    = answered_q ? !diff_q[32] : rising;
  assign shift_new = pick_end ? (end_up ? shift_above : shift_below) : diff_q[17:8] + {9'd0, round_bit};

  // round_shift(p, 14) = (p >> 14) + p[13]; |D K| < 2^29, so 17 bits above the shift suffice.
  logic        take_answer;
  logic [15:0] k_multiplier;
  logic signed [16:0] rounded, step;
  logic signed [31:0] r_new;
  assign take_answer  = answer_pending_q && phase_i == 4'd0;
  assign k_multiplier = (step_q == 4'd5) ? k_weight(phase_i) : k_weight(k_next);
  assign rounded      = 17'(product_q[31:Shift]) + 17'(product_q[Shift-1]);
  assign step         = rounded - rounded_now_q;
  assign r_new        = enabled_i ? $signed(r_q[0]) + 32'(step) : {{8{count[15]}}, count, 8'd0};

  // c - r -/+ H in one adder: d + H for d < 0, d + ~H + 1 for d >= 0 (the + 1 enters as the
  // carry out of a low bit that is 1 + 1).
  logic        add_half_play;
  logic [32:0] half_play_wide;
  logic [33:0] played_sum;
  assign add_half_play  = diff_q[32];
  assign half_play_wide = 33'(half_play);
  assign played_sum     = {diff_q, 1'b1} + {add_half_play ? half_play_wide : ~half_play_wide, !add_half_play};
  logic unused_played_sum;
  assign unused_played_sum = played_sum[0];

  // 25 y + 8 = y + 8 y + (16 y | 8): the rounding constant fills bit 3 of 16 y for free.
  logic signed [28:0] y25_rounded;
  logic signed [24:0] c;  // round_shift(25 y, 4)
  assign c = y25_rounded[28:4];
  logic unused_bits;
  assign unused_bits = ^{y25_rounded[3:0], product_q[Shift-2:0]};

  always_ff @(posedge clk_i) begin  // datapath pipeline (read only under busy_q's schedule)
    y25_q       <= 29'(y) + (29'(y) <<< 3);
    y25_rounded <= y25_q + ((29'(y) <<< 4) | 29'sd8);
    diff_q      <= 33'(c) - 33'($signed(r_q[0]));
    played_q    <= played_sum[33:1];
    delta_q     <= take_answer ? delta_saturated : $signed(d_q[0]);
    product_q   <= $signed(delta_q) * $signed(k_multiplier);
    if (step_q == 4'd6) rounded_now_q <= rounded;
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      busy_q           <= 1'b0;
      step_q           <= '0;
      joint_q          <= '0;
      answer_pending_q <= 1'b0;
      answered_q       <= 1'b0;
      slew_limited_o   <= 1'b0;
      for (int j = 0; j < 3; j++) begin
        r_q[j] <= '0;
        d_q[j] <= '0;
      end
    end else begin
      slew_limited_o <= 1'b0;
      if (answer_i) answer_pending_q <= 1'b1;
      if (!enabled_i) answered_q <= 1'b0;
      else if (answer_i) answered_q <= 1'b1;
      if (update_i && !busy_q) begin
        busy_q  <= 1'b1;
        step_q  <= '0;
        joint_q <= '0;
      end else if (busy_q) begin
        // step 0: 9 y; 1: 25 y + 8; 2: c - r; 3: c - r -/+ H; 4: D; 5: D K_k; 6: its rounding
        // held, D K_(k+1); 7: r' and rotate.
        step_q <= step_q + 1'b1;
        if (step_q == 4'(delta_board_pkg::InterpolatorDeltaStep) && take_answer && saturated && enabled_i) slew_limited_o <= 1'b1;
        if (step_q == 4'(delta_board_pkg::InterpolatorReferenceStep)) begin
          step_q  <= '0;
          joint_q <= joint_q + 1'b1;
          r_q[0]  <= r_q[1];
          r_q[1]  <= r_q[2];
          r_q[2]  <= r_new;
          d_q[0]  <= d_q[1];
          d_q[1]  <= d_q[2];
          d_q[2]  <= (!enabled_i || (k_next == 4'(delta_board_pkg::PeriodsPerSetpoint) && !homing_i)) ? '0 : delta_q;
          if (joint_q == 2'd2) begin
            busy_q <= 1'b0;
            if (take_answer) answer_pending_q <= 1'b0;
          end
        end
      end
    end
  end

  assign references_o = {r_q[2], r_q[1], r_q[0]};
  assign shift_write_o = busy_q && step_q == 4'(delta_board_pkg::InterpolatorReferenceStep);
  assign shift_joint_o = joint_q;
  assign shift_o       = shift_new;
`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // What the model board (host/cosim/model_board.cpp) relies on: an update is 8 clocks a joint,
  // three joints, and only its steps InterpolatorDeltaStep and InterpolatorReferenceStep act; the
  // steps between only count. Environment: reset in the first cycle only; every other input free.
  localparam logic [3:0] FDeltaStep     = 4'(delta_board_pkg::InterpolatorDeltaStep);
  localparam logic [3:0] FReferenceStep = 4'(delta_board_pkg::InterpolatorReferenceStep);
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
  end
  // Clocks since the update started (the clock after update_i found the interpolator idle).
  logic [5:0] f_update_clock_q = '0;
  always_ff @(posedge clk_i) begin
    if (update_i && !busy_q) f_update_clock_q <= '0;
    else if (busy_q && f_update_clock_q != '1) f_update_clock_q <= f_update_clock_q + 6'd1;
  end
  always_comb begin
    if (busy_q && rst_ni) an_update_is_its_steps_per_joint_for_three_joints: assert (joint_q <= 2'd2 &&
        step_q <= FReferenceStep && f_update_clock_q == 6'(joint_q) * 6'(FReferenceStep + 4'd1) + 6'(step_q));
    an_update_is_its_steps_per_joint_for_three_joints_c: cover (busy_q && joint_q == 2'd2 && step_q == FReferenceStep);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      if ($past(busy_q) && !busy_q) an_update_ends_after_three_joints: assert (
          $past(f_update_clock_q) == 6'(3 * (delta_board_pkg::InterpolatorReferenceStep + 1) - 1));
      an_update_ends_after_three_joints_c: cover ($past(busy_q) && !busy_q);
      // The references (and the segment changes) move only in a joint's reference step.
      if (references_o != $past(references_o) || d_q[0] != $past(d_q[0]) || d_q[1] != $past(d_q[1]) ||
          d_q[2] != $past(d_q[2])) begin
        references_change_only_in_a_reference_step: assert ($past(busy_q) && $past(step_q) == FReferenceStep);
      end
      references_change_only_in_a_reference_step_c: cover (references_o != $past(references_o));
      // A slew limit is flagged only in the clock after a joint's delta step.
      if (slew_limited_o) slew_limit_only_after_a_delta_step: assert ($past(busy_q) && $past(step_q) == FDeltaStep);
      slew_limit_only_after_a_delta_step_c: cover (slew_limited_o);
      // The pending answer is taken only at the update's end.
      if (!answer_pending_q && $past(answer_pending_q)) the_answer_is_taken_only_at_the_updates_end: assert (
          $past(busy_q) && $past(step_q) == FReferenceStep && $past(joint_q) == 2'd2 && $past(phase_i) == 4'd0);
      the_answer_is_taken_only_at_the_updates_end_c: cover (!answer_pending_q && $past(answer_pending_q));
    end
  end
`endif
endmodule
