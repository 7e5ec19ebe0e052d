// The setpoint buffer (docs/board_link.md, "Setpoints"): Depth entries of three 16-bit scaled
// input codes in block RAM, addressed by sample index, and their playback into the network.
//
// Filling: link_rx presents a setpoint frame's payload byte by byte; the sample index (bytes 0..3)
// is compared with the next free index (sample_index_o + fill_o) as it passes, and the position
// codes (bytes 4..9) are written into the next free slot (not yet part of the buffer, so the
// reader never sees them). On frame_ok_i the entry is committed if the index matched, the
// buffer was not full when the frame began and accept_i (drives on) holds; otherwise refused_o
// pulses. flush_i empties the buffer (the sample index stays) and vetoes the commit of a frame in
// flight. With the drives off nothing is taken and every way off flushes, so the buffer is empty
// at each enable: the board never plays a setpoint from before it.
//
// Playback: play_i (the first period of a segment, drives on, not holding) pops the entry at
// sample_index_o: the RAM reads it into inputs_o (held until the next pop, long after done) and
// the network is started (start_o until ready_i); sample_index_o advances. With the buffer empty,
// underrun_o pulses instead and nothing is started.
module setpoint_buffer #(
  parameter int unsigned Depth = delta_board_pkg::SetpointDepth
) (
  input  logic        clk_i,
  input  logic        rst_ni,
  // from link_rx
  input  logic        frame_start_i,
  input  logic        is_setpoint_i,    // the frame in flight is a setpoint (valid with payload and ok)
  input  logic        payload_valid_i,
  input  logic [5:0]  payload_index_i,
  input  logic [7:0]  payload_byte_i,
  input  logic        frame_ok_i,
  output logic        refused_o,        // pulse: a checked setpoint frame was not taken
  input  logic        accept_i,         // drives on: setpoints are taken (refused while off)
  input  logic        flush_i,
  // playback into the network (ap_ctrl_hs through network_crossing)
  input  logic        play_i,
  output logic        underrun_o,       // pulse: play_i with the buffer empty
  output logic        start_o,
  input  logic        ready_i,
  output logic [47:0] inputs_o,         // u_x, u_y, u_z codes at [16k +: 16]
  output logic [31:0] sample_index_o,
  output logic [15:0] fill_o
);
  localparam int unsigned SlotWidth = $clog2(Depth);
  localparam int unsigned FillWidth = $clog2(Depth + 1);

  // ---- RAM: one 48-bit entry per slot (three block RAMs side by side), written a byte at a time;
  // its output register holds the popped entry for the network (no flip-flops of ours).
  logic [47:0]          entry_q;
  logic [SlotWidth-1:0] write_slot;
  logic [3:0]           write_lane;
  logic                 write_enable, pop;
  for (genvar w = 0; w < 3; w++) begin : g_ram  // bytes 2w and 2w+1 of every entry
    // no_rw_check: no read-during-write logic; the slot written (next free) is never the slot read
    // (the oldest entry) because a full buffer takes no write. One write port per RAM, the high or
    // the low byte (the block RAM's bit mask).
    (* no_rw_check *) logic [15:0] ram_q [Depth];
    always_ff @(posedge clk_i) begin
      if (write_enable && write_lane[3:1] == 3'(w)) begin
        if (write_lane[0]) ram_q[write_slot][15:8] <= payload_byte_i;
        else ram_q[write_slot][7:0] <= payload_byte_i;
      end
    end
    always_ff @(posedge clk_i) begin
      if (pop) entry_q[16 * w +: 16] <= ram_q[sample_index_q[SlotWidth-1:0]];
    end
  end

  logic [31:0]          sample_index_q, next_index;
  logic [FillWidth-1:0] fill_q;
  logic                 full_at_start_q, index_match_q, vetoed_q;
  assign next_index = sample_index_q + 32'(fill_q);

  // ---- filling ----------------------------------------------------------------------------------
  logic [1:0] index_byte;
  logic [7:0] expected_byte;
  assign index_byte    = payload_index_i[1:0];
  assign expected_byte = next_index[8 * index_byte +: 8];
  assign write_enable  = is_setpoint_i && payload_valid_i && payload_index_i >= 6'd4 && !full_at_start_q;
  assign write_slot    = next_index[SlotWidth-1:0];
  assign write_lane    = 4'(payload_index_i - 6'd4);

  logic commit;
  assign commit    = frame_ok_i && is_setpoint_i && accept_i && index_match_q && !full_at_start_q && !vetoed_q && !flush_i;
  assign refused_o = frame_ok_i && is_setpoint_i && !commit;

  // ---- playback ---------------------------------------------------------------------------------
  logic starting_q;
  assign pop        = play_i && !starting_q && fill_q != '0;
  assign underrun_o = play_i && fill_q == '0;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      sample_index_q  <= '0;
      fill_q          <= '0;
      full_at_start_q <= 1'b0;
      index_match_q   <= 1'b0;
      vetoed_q        <= 1'b0;
      starting_q      <= 1'b0;
    end else begin
      if (frame_start_i) begin
        full_at_start_q <= fill_q == FillWidth'(Depth);
        index_match_q   <= 1'b1;
        vetoed_q        <= 1'b0;
      end
      if (flush_i) vetoed_q <= 1'b1;
      if (is_setpoint_i && payload_valid_i && payload_index_i < 6'd4 && payload_byte_i != expected_byte) begin
        index_match_q <= 1'b0;
      end
      // fill: +1 on a commit, -1 on a pop, 0 on a flush (a pop and a flush together: the pop wins
      // the entry, the rest goes).
      if (flush_i) fill_q <= '0;
      else if (commit && !pop) fill_q <= fill_q + 1'b1;
      else if (pop && !commit) fill_q <= fill_q - 1'b1;
      if (pop) begin
        sample_index_q <= sample_index_q + 1'b1;
        starting_q     <= 1'b1;
      end
      if (ready_i) starting_q <= 1'b0;
    end
  end

  assign inputs_o       = entry_q;
  assign start_o        = starting_q;
  assign sample_index_o = sample_index_q;
  assign fill_o         = 16'(fill_q);

`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // Environment: reset in the first cycle only, and link_rx's delivery protocol (link_rx.sv's
  // header): a frame starts (frame_start_i; at any time, so a frame dropped after its start is
  // simply followed by the next), presents its payload bytes in order from index 0, at most its
  // type's payload size, and ends with frame_ok_i after all of them or with a drop (no ok); the
  // type holds from the cycle after the start to the end; the network's ready only while it is
  // started (ap_ctrl_hs).
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  logic       f_in_frame_q = 1'b0, f_setpoint_q = 1'b0, f_flushed_q = 1'b0, f_full_q = 1'b0;
  // The frame's type: link_rx's type_o is registered at the start, so it is the frame's from the
  // first cycle after frame_start_i (f_typed_q low: taken from is_setpoint_i then, held after).
  logic       f_typed_q = 1'b0, f_setpoint;
  assign f_setpoint = f_typed_q ? f_setpoint_q : is_setpoint_i;
  logic [5:0] f_bytes_q = '0;
  logic [31:0] f_index_q = '0;  // the frame's sample index, bytes 0..3 little-endian
  always_ff @(posedge clk_i) begin
    if (!rst_ni || frame_ok_i) f_in_frame_q <= 1'b0;
    else if (frame_start_i) f_in_frame_q <= 1'b1;
    if (frame_start_i) begin
      f_bytes_q   <= '0;
      f_typed_q   <= 1'b0;
      f_flushed_q <= flush_i;
      f_full_q    <= fill_q == FillWidth'(Depth);
    end else begin
      if (f_in_frame_q && !f_typed_q) begin
        f_typed_q    <= 1'b1;
        f_setpoint_q <= is_setpoint_i;
      end
      if (payload_valid_i) f_bytes_q <= f_bytes_q + 6'd1;
      if (flush_i) f_flushed_q <= 1'b1;
    end
    if (payload_valid_i && payload_index_i < 6'd4) f_index_q[8 * payload_index_i[1:0] +: 8] <= payload_byte_i;
  end
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
    payload_bytes_come_in_order_inside_a_frame: assume (!payload_valid_i || (f_in_frame_q && !frame_start_i && payload_index_i == f_bytes_q));
    a_frame_ends_ok_after_its_whole_payload: assume (!frame_ok_i || (f_in_frame_q && !frame_start_i &&
        f_bytes_q == (is_setpoint_i ? 6'(delta_board_pkg::SetpointPayloadBytes) : f_bytes_q)));
    the_type_holds_through_the_frame: assume (!f_in_frame_q || frame_start_i || is_setpoint_i == f_setpoint);
    // A setpoint frame presents at most its payload size (link_rx starts a frame only when its
    // length is its type's payload size: link_rx's start_only_for_a_valid_header).
    a_setpoint_has_its_payload_size: assume (!payload_valid_i || !is_setpoint_i || payload_index_i < 6'(delta_board_pkg::SetpointPayloadBytes));
    // ap_ctrl_hs: ready only while started (network_crossing's ready_o is start_i && !busy_q).
    ready_only_while_started: assume (!ready_i || start_o);
  end

  logic [31:0] f_next_index, f_seen_bytes;  // f_seen_bytes: the index bytes the frame has presented
  assign f_next_index = sample_index_q + 32'(fill_q);
  assign f_seen_bytes = f_bytes_q >= 6'd4 ? 32'hFFFF_FFFF : f_bytes_q == 6'd3 ? 32'h00FF_FFFF :
                        f_bytes_q == 6'd2 ? 32'h0000_FFFF : f_bytes_q == 6'd1 ? 32'h0000_00FF : 32'h0;
  always_comb begin
    // Playback: only an entry the buffer holds is played; an empty buffer underruns instead.
    plays_only_an_entry_it_holds: assert (!pop || fill_q != '0);
    plays_only_an_entry_it_holds_c: cover (pop && fill_q == FillWidth'(1));
    underrun_exactly_when_empty: assert (underrun_o == (play_i && fill_q == '0));
    underrun_exactly_when_empty_c: cover (underrun_o);
    fill_never_exceeds_the_depth: assert (fill_q <= FillWidth'(Depth));
    fill_never_exceeds_the_depth_c: cover (fill_q == FillWidth'(Depth));
    // Filling: an entry is taken only from a CRC-valid setpoint frame that carries the next free
    // sample index, began with room and met no flush; the bytes go into the next free slot.
    if (commit) commits_only_the_next_index_with_room_and_no_flush: assert (frame_ok_i && f_setpoint &&
        f_index_q == f_next_index && !f_full_q && !f_flushed_q && !flush_i);
    commits_only_the_next_index_with_room_and_no_flush_c: cover (commit && fill_q == '0 && sample_index_q != '0);
    if (frame_ok_i && is_setpoint_i && accept_i && f_index_q == f_next_index && !f_full_q && !f_flushed_q && !flush_i) begin
      a_valid_setpoint_is_taken: assert (commit);
    end
    a_valid_setpoint_is_taken_c: cover (commit && fill_q == FillWidth'(Depth - 1));
    refused_exactly_when_not_taken: assert (refused_o == (frame_ok_i && is_setpoint_i && !commit));
    refused_exactly_when_not_taken_c: cover (refused_o && f_index_q == f_next_index);
    if (write_enable) writes_only_a_free_slot: assert (fill_q < FillWidth'(Depth) && write_slot == f_next_index[SlotWidth-1:0] &&
        f_setpoint && payload_index_i >= 6'd4 && payload_index_i < 6'(delta_board_pkg::SetpointPayloadBytes));
    writes_only_a_free_slot_c: cover (write_enable && fill_q == FillWidth'(Depth - 1));
    // Lemmas (each proved alone, then assumed by the proofs that PDR does not finish without them):
    // the frame's registers follow the specification's, and the sample index bytes that have
    // passed match the next free index while the frame is not vetoed.
    if (f_in_frame_q && rst_ni) frame_state_follows_the_specification: assert (full_at_start_q == f_full_q && vetoed_q == f_flushed_q);
    frame_state_follows_the_specification_c: cover (f_in_frame_q && rst_ni && vetoed_q && f_bytes_q == 6'd2);
    if (f_in_frame_q && f_setpoint && rst_ni && index_match_q && !vetoed_q) begin
      index_bytes_match_the_next_free_index: assert ((f_index_q & f_seen_bytes) == (f_next_index & f_seen_bytes));
    end
    index_bytes_match_the_next_free_index_c: cover (f_in_frame_q && f_setpoint && index_match_q && f_bytes_q == 6'd4 && sample_index_q != '0);
    if (write_enable && pop) never_writes_the_slot_it_plays: assert (write_slot != sample_index_q[SlotWidth-1:0]);
    never_writes_the_slot_it_plays_c: cover (write_enable && pop);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      // Bookkeeping: a flush empties, a take adds one, a play removes one; the index counts plays.
      fill_counts_takes_and_plays: assert (fill_q == ($past(flush_i) ? '0 : $past(fill_q) + FillWidth'($past(commit)) - FillWidth'($past(pop))));
      fill_counts_takes_and_plays_c: cover ($past(commit) && $past(pop));
      sample_index_counts_plays: assert (sample_index_q == $past(sample_index_q) + 32'($past(pop)));
      sample_index_counts_plays_c: cover (sample_index_q == 32'd2);
      // The network is started once per play and held until it is ready.
      if ($past(pop)) a_play_starts_the_network: assert (start_o);
      if ($past(start_o) && !$past(ready_i) && !$past(pop)) start_holds_until_ready: assert (start_o);
      if (!$past(pop) && !$past(start_o)) start_only_after_a_play: assert (!start_o);
      if ($past(ready_i) && !$past(pop)) start_drops_at_ready: assert (!start_o);
      a_play_starts_the_network_c: cover ($past(pop) && start_o);
      start_holds_until_ready_c: cover ($past(start_o, 1) && start_o && !$past(pop));
      start_only_after_a_play_c: cover ($past(start_o) && !start_o);
      start_drops_at_ready_c: cover ($past(ready_i) && $past(start_o) && !start_o);
    end
  end
`endif
endmodule
