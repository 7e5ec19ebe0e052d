// Link v2 receiver (docs/board_link.md): finds, checks and delivers the host's frames.
//
// Every received byte goes into a ring of RingBytes (one block RAM). A parser reads the ring one
// byte every two cycles: it hunts for the sync byte, reads length, sequence and type, takes the
// frame only if the type is one the board receives (identify request, setpoint, command, model) and the
// length is that type's payload size, then runs the CRC-16 over length..payload and compares it
// with the two CRC bytes. A frame that fails any check is dropped (bad_o pulses) and the parser
// rescans from the byte after the dropped frame's sync, so a frame that began inside it is still
// found: the same rule as the host's FrameDecoder (host/include/delta/link/frame_codec.hpp), and
// BoardLink.* requires both to accept the same frames.
//
// Delivery: start_o pulses when a header passes (sequence_o holds from then to the end, type_o
// from the next cycle),
// payload_valid_o presents each payload byte once (tentatively: the frame is not checked yet),
// then ok_o pulses if the CRC matches (act on the frame) or bad_o if not. Consumers keep what the
// payload says and act only on ok_o. The parser is far faster than the line (2 cycles per byte
// against ClocksPerBit * 10), so the ring never fills. stall_i holds the parser (every register
// keeps its value, nothing is delivered) while the ring keeps receiving: the model loader's CRC
// takes ModelCrcClocks clocks after a model frame's ok_o, less than a byte's time on the line.
module link_rx #(
  parameter int unsigned RingBytes = delta_board_pkg::RxRingBytes
) (
  input  logic       clk_i,
  input  logic       rst_ni,
  input  logic [7:0] rx_data_i,        // from uart_rx
  input  logic       rx_valid_i,
  input  logic       stall_i,          // the parser waits (model_loader's CRC)
  output logic       start_o,          // a header passed: a frame of type_o begins
  output logic [7:0] type_o,
  output logic [7:0] sequence_o,
  output logic       payload_valid_o,  // payload byte payload_index_o (tentative)
  output logic [5:0] payload_index_o,
  output logic [7:0] payload_byte_o,
  output logic       ok_o,             // the frame's CRC matched: act on it
  output logic       bad_o             // a frame was dropped (type, length or CRC)
);
  localparam int unsigned PointerWidth = $clog2(RingBytes);
  localparam logic [7:0] Sync = 8'(delta_board_pkg::FrameSync);

  // ---- ring -------------------------------------------------------------------------------------
  // no_rw_check: no read-during-write logic; a byte is read only once written (read_q != write_q).
  // The RAM's ports are named once: the RAM below and the formal model of it read the same
  // signals.
  (* no_rw_check *) logic [7:0] ring_q [RingBytes];
  logic [7:0]              ring_data_q, ring_write_data;
  logic [PointerWidth-1:0] write_q, read_q, ring_write_addr, ring_read_addr;
  logic                    ring_write;
  assign ring_write      = rx_valid_i;
  assign ring_write_addr = write_q;
  assign ring_write_data = rx_data_i;
  assign ring_read_addr  = read_q;

  always_ff @(posedge clk_i) begin
    if (ring_write) ring_q[ring_write_addr] <= ring_write_data;
    ring_data_q <= ring_q[ring_read_addr];
  end
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) write_q <= '0;
    else if (rx_valid_i) write_q <= write_q + 1'b1;
  end

  // ---- parser -----------------------------------------------------------------------------------
  // index_q: position of the byte in the frame (0 sync, 1 length, 2 sequence, 3 type, 4.. payload,
  // then the two CRC bytes). end_q: index of the CRC's high byte (4 + length).
  logic                    fetched_d, fetched_q;  // ring_data_q holds the byte at read_q
  logic [PointerWidth-1:0] read_d, start_d, start_q;
  logic [5:0]              index_d, index_q, end_d, end_q;
  logic [7:0]              length_d, length_q, type_d, type_q, sequence_d, sequence_q;
  logic                    crc_high_ok_d, crc_high_ok_q;
  // The byte at read_q is the frame's CRC low byte (index_q == end_q + 1, index_q >= 5): a
  // register, so that ok_o is a short path from the ring (its consumers act on it in the same clock).
  logic                    crc_low_d, crc_low_q;
  logic                    crc_low_match;
  logic                    crc_clear, crc_valid;
  logic [15:0]             crc;

  link_crc16 u_crc (
    .clk_i,
    .rst_ni,
    .clear_i(crc_clear),
    .valid_i(crc_valid),
    .data_i (ring_data_q),
    .crc_o  (crc)
  );

  // The payload size of a type the board receives; known = 0 for any other type.
  logic       known;
  logic [7:0] size;
  always_comb begin
    known = 1'b1;
    unique case (ring_data_q)
      8'(delta_board_pkg::FrameTypeIdentifyRequest): size = 8'd0;
      8'(delta_board_pkg::FrameTypeSetpoint):        size = 8'(delta_board_pkg::SetpointPayloadBytes);
      8'(delta_board_pkg::FrameTypeCommand):         size = 8'(delta_board_pkg::CommandPayloadBytes);
      8'(delta_board_pkg::FrameTypeModel):           size = 8'(delta_board_pkg::ModelPayloadBytes);
      default: begin
        known = 1'b0;
        size  = 8'd0;
      end
    endcase
  end

  always_comb begin
    fetched_d       = 1'b0;
    read_d          = read_q;
    start_d         = start_q;
    index_d         = index_q;
    end_d           = end_q;
    length_d        = length_q;
    type_d          = type_q;
    sequence_d      = sequence_q;
    crc_high_ok_d   = crc_high_ok_q;
    crc_low_d       = crc_low_q;
    crc_clear       = 1'b0;
    crc_valid       = 1'b0;
    start_o         = 1'b0;
    payload_valid_o = 1'b0;
    bad_o           = 1'b0;
    if (stall_i) begin
      fetched_d = fetched_q;  // hold: the ring reads read_q again
    end else if (!fetched_q) begin
      // Wait for a byte: the ring reads read_q in this cycle, the byte is there in the next.
      fetched_d = read_q != write_q;
    end else begin
      read_d = read_q + 1'b1;
      if (index_q == 6'd0) begin
        if (ring_data_q == Sync) begin
          start_d   = read_q;
          index_d   = 6'd1;
          crc_clear = 1'b1;
        end
      end else if (index_q < 6'd4) begin
        crc_valid = 1'b1;
        index_d   = index_q + 1'b1;
        if (index_q == 6'd1) length_d = ring_data_q;
        if (index_q == 6'd2) sequence_d = ring_data_q;
        if (index_q == 6'd3) begin
          type_d = ring_data_q;
          end_d  = 6'(size) + 6'd4;
          if (known && length_q == size) begin
            start_o = 1'b1;
          end else begin
            bad_o   = 1'b1;
            index_d = 6'd0;
            read_d  = start_q + 1'b1;
          end
        end
      end else if (index_q < end_q) begin
        crc_valid       = 1'b1;
        payload_valid_o = 1'b1;
        index_d         = index_q + 1'b1;
      end else if (index_q == end_q) begin
        crc_high_ok_d = ring_data_q == crc[15:8];
        index_d       = index_q + 1'b1;
        crc_low_d     = 1'b1;
      end else begin
        index_d   = 6'd0;
        crc_low_d = 1'b0;
        if (!crc_low_match) begin  // ok_o otherwise (below)
          bad_o  = 1'b1;
          read_d = start_q + 1'b1;
        end
      end
    end
  end

  assign crc_low_match = crc_high_ok_q && ring_data_q == crc[7:0];
  assign ok_o          = !stall_i && fetched_q && crc_low_q && crc_low_match;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      crc_low_q     <= 1'b0;
      fetched_q     <= 1'b0;
      read_q        <= '0;
      start_q       <= '0;
      index_q       <= '0;
      end_q         <= '0;
      length_q      <= '0;
      type_q        <= '0;
      sequence_q    <= '0;
      crc_high_ok_q <= 1'b0;
    end else begin
      fetched_q     <= fetched_d;
      read_q        <= read_d;
      start_q       <= start_d;
      index_q       <= index_d;
      end_q         <= end_d;
      length_q      <= length_d;
      type_q        <= type_d;
      sequence_q    <= sequence_d;
      crc_high_ok_q <= crc_high_ok_d;
      crc_low_q     <= crc_low_d;
    end
  end

  assign type_o          = type_q;
  assign sequence_o      = sequence_q;
  assign payload_index_o = index_q - 6'd4;
  assign payload_byte_o  = ring_data_q;

`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // Environment: reset in the first cycle only; uart_rx delivers a byte at most once per
  // 9 bit times (a byte takes 10 on the line: start, 8 data bits, stop). scripts/formal.sh reaches
  // the covers (a whole frame is 7 to 22 bytes) with a shorter gap, FORMAL_LINK_RX_BYTE_GAP.
`ifdef FORMAL_LINK_RX_BYTE_GAP
  localparam int FByteGap = `FORMAL_LINK_RX_BYTE_GAP;
`else
  localparam int FByteGap = 9 * delta_board_pkg::LinkClocksPerBit;
`endif
  localparam int FMaxFrame = delta_board_pkg::FrameHeaderBytes + delta_board_pkg::SetpointPayloadBytes +
                             delta_board_pkg::FrameCrcBytes;  // the longest frame the board takes
  logic f_past_valid = 1'b0, f_past2_valid = 1'b0;  // $past(x) valid; $past(x, 2) valid
  always_ff @(posedge clk_i) begin
    f_past_valid  <= 1'b1;
    f_past2_valid <= f_past_valid;
  end
  logic [$clog2(FByteGap+1)-1:0] f_gap_q = '0;  // cycles since the last byte, saturating
  always_ff @(posedge clk_i) begin
    if (rx_valid_i) f_gap_q <= '0;
    else if (f_gap_q != $clog2(FByteGap+1)'(FByteGap)) f_gap_q <= f_gap_q + 1'b1;
  end
  // The model loader stalls the parser only in the ModelCrcClocks clocks after a model frame's ok_o.
  localparam int FStallClocks = delta_board_pkg::ModelCrcClocks;
  logic [$clog2(FStallClocks+1)-1:0] f_stall_left_q = '0;
  always_ff @(posedge clk_i) begin
    if (ok_o && type_q == 8'(delta_board_pkg::FrameTypeModel)) f_stall_left_q <= $clog2(FStallClocks+1)'(FStallClocks);
    else if (f_stall_left_q != '0) f_stall_left_q <= f_stall_left_q - 1'b1;
  end
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
    bytes_arrive_at_most_at_the_line_rate: assume (!rx_valid_i || (f_gap_q == $clog2(FByteGap+1)'(FByteGap) && rst_ni));
    the_parser_stalls_only_for_a_model_frames_crc: assume (!stall_i || f_stall_left_q != '0);
  end
  logic f_take;  // the parser consumes the byte it fetched
  assign f_take = fetched_q && !stall_i;

  // The specification of the frame rules (docs/board_link.md), written independently: a parser
  // of the bytes as this receiver consumes them (ring_data_q while fetched_q), and a bit-serial
  // CRC-16/CCITT-FALSE.
  function automatic logic [15:0] f_crc16(logic [15:0] crc, logic [7:0] data);
    logic [15:0] value;
    value = crc;
    for (int i = 7; i >= 0; i--) begin
      value = (value[15] ^ data[i]) ? ((value << 1) ^ 16'(delta_board_pkg::FrameCrcPolynomial)) : (value << 1);
    end
    f_crc16 = value;
  endfunction
  function automatic logic [7:0] f_size(logic [7:0] frame_type);
    f_size = 8'hFF;  // not a type the board receives
    if (frame_type == 8'(delta_board_pkg::FrameTypeIdentifyRequest)) f_size = 8'd0;
    if (frame_type == 8'(delta_board_pkg::FrameTypeSetpoint)) f_size = 8'(delta_board_pkg::SetpointPayloadBytes);
    if (frame_type == 8'(delta_board_pkg::FrameTypeCommand)) f_size = 8'(delta_board_pkg::CommandPayloadBytes);
    if (frame_type == 8'(delta_board_pkg::FrameTypeModel)) f_size = 8'(delta_board_pkg::ModelPayloadBytes);
  endfunction
  logic [7:0]  f_pos_q = '0, f_length_q = '0, f_type_q = '0, f_sequence_q = '0, f_high_q = '0;
  logic [15:0] f_crc_q = '0;
  logic [7:0]  f_byte;
  logic        f_header_ok, f_start, f_drop_header, f_payload, f_end, f_crc_ok;
  assign f_byte        = ring_data_q;
  assign f_header_ok   = f_size(f_byte) != 8'hFF && f_length_q == f_size(f_byte);
  assign f_start       = f_take && f_pos_q == 8'd3 && f_header_ok;
  assign f_drop_header = f_take && f_pos_q == 8'd3 && !f_header_ok;
  // Positions in 9 bits: a length byte up to 255 (dropped at the type, but the header's bytes are
  // read before that) must not wrap 5 + length onto a header position.
  logic [8:0]  f_pos9, f_payload_end;
  assign f_pos9        = 9'(f_pos_q);
  assign f_payload_end = 9'd4 + 9'(f_length_q);  // the CRC's high byte
  assign f_payload     = f_take && f_pos9 >= 9'd4 && f_pos9 < f_payload_end;
  assign f_end         = f_take && f_pos9 >= 9'd4 && f_pos9 == f_payload_end + 9'd1;
  assign f_crc_ok      = f_high_q == f_crc_q[15:8] && f_byte == f_crc_q[7:0];
  always_ff @(posedge clk_i) begin
    if (!rst_ni) begin
      f_pos_q <= '0;
    end else if (f_take) begin
      if (f_pos_q == 8'd0) begin
        if (f_byte == Sync) f_pos_q <= 8'd1;
        f_crc_q <= 16'(delta_board_pkg::FrameCrcInit);
      end else begin
        f_pos_q <= f_drop_header || f_end ? 8'd0 : f_pos_q + 8'd1;
        if (f_pos9 < 9'd4 || f_pos9 < f_payload_end) f_crc_q <= f_crc16(f_crc_q, f_byte);
        if (f_pos_q == 8'd1) f_length_q <= f_byte;
        if (f_pos_q == 8'd2) f_sequence_q <= f_byte;
        if (f_pos_q == 8'd3) f_type_q <= f_byte;
        if (f_pos9 >= 9'd4 && f_pos9 == f_payload_end) f_high_q <= f_byte;
      end
    end
  end

  always_comb begin
    // Delivery follows the frame rules exactly: a header with a known type and its length
    // starts a frame, its payload bytes are presented once in order, and only a matching CRC
    // (both bytes) gives ok_o; everything else is dropped and counted.
    start_only_for_a_valid_header: assert (start_o == f_start);
    start_only_for_a_valid_header_c: cover (start_o && f_type_q == 8'(delta_board_pkg::FrameTypeCommand));
    payload_bytes_presented_once_in_order: assert (payload_valid_o == f_payload && (!f_payload || payload_index_o == 6'(f_pos_q - 8'd4)));
    payload_bytes_presented_once_in_order_c: cover (payload_valid_o && payload_index_o == 6'(delta_board_pkg::SetpointPayloadBytes - 1));
    ok_only_with_a_matching_crc: assert (ok_o == (f_end && f_crc_ok));
    ok_only_with_a_matching_crc_c: cover (ok_o && f_length_q == 8'(delta_board_pkg::CommandPayloadBytes));
    bad_crc_or_header_drops_the_frame: assert (bad_o == (f_drop_header || (f_end && !f_crc_ok)));
    bad_crc_or_header_drops_the_frame_c: cover (bad_o && f_end);
    // The sequence is there with start_o; the type from the next cycle (type_o is registered at
    // the start) to the frame's end, so with every payload byte and with ok_o or bad_o.
    if (start_o || f_pos9 >= 9'd4) frame_fields_held_from_the_header: assert (sequence_o == f_sequence_q &&
        (start_o || type_o == f_type_q));
    frame_fields_held_from_the_header_c: cover (ok_o && type_o == 8'(delta_board_pkg::FrameTypeSetpoint));
    // Lemma (proved alone, then assumed by the proofs PDR does not finish without it): the parser's
    // registers are the specification's: position, the header's fields, the running CRC, the end
    // and the first CRC byte's verdict, and the read pointer is the frame's start plus the position.
    if (f_past_valid) the_parser_follows_the_specification: assert (f_pos_q == 8'(index_q) &&
        (f_pos_q == 8'd0 || (crc == f_crc_q && read_q == start_q + PointerWidth'(f_pos_q))) &&
        (f_pos_q < 8'd2 || length_q == f_length_q) && (f_pos_q < 8'd3 || sequence_q == f_sequence_q) &&
        (f_pos9 < 9'd4 || (type_q == f_type_q && f_payload_end < 9'd64 && end_q == 6'(f_payload_end) &&
                           f_pos9 <= f_payload_end + 9'd1)) &&
        (f_pos9 < 9'd4 || f_pos9 != f_payload_end + 9'd1 || crc_high_ok_q == (f_high_q == f_crc_q[15:8])) &&
        crc_low_q == (f_pos9 >= 9'd4 && f_pos9 == f_payload_end + 9'd1));
    the_parser_follows_the_specification_c: cover (f_past_valid && f_pos9 >= 9'd4 && f_pos9 == f_payload_end + 9'd1);
    // The ring: the parser reads only received bytes and never falls a ring behind the receiver
    // (a frame it may still rescan is never overwritten).
    the_parser_reads_only_received_bytes: assert (!fetched_d || read_q != write_q);
    the_parser_reads_only_received_bytes_c: cover (fetched_q && f_pos_q == 8'd5);
    backlog_stays_within_a_frame: assert (PointerWidth'(write_q - read_q) <= PointerWidth'(FMaxFrame + 1) &&
        (f_pos_q == 8'd0 || PointerWidth'(write_q - start_q) <= PointerWidth'(FMaxFrame + 1)));
    backlog_stays_within_a_frame_c: cover (f_pos_q != 8'd0 && PointerWidth'(write_q - start_q) == PointerWidth'(FMaxFrame));
  end
  // The ring, followed through one slot chosen freely (f_slot, any of them). The proofs cut the
  // block RAM out (a read returns a free byte), so the properties state a RAM's contract instead:
  // a read of the slot returns what the RAM's own write port last wrote there, unless nothing was
  // written yet or the slot is written in the same cycle (f_ram_*: the RAM's side). The
  // specification counts the bytes as they arrive and keeps the last one whose arrival falls on
  // the slot (f_slot_byte_q).
  (* anyconst *) logic [PointerWidth-1:0] f_slot;
  logic [7:0]              f_ram_slot_q = '0, f_slot_byte_q = '0;
  logic                    f_ram_slot_written_q = 1'b0, f_ram_read_slot_q = 1'b0, f_slot_received_q = 1'b0;
  logic [PointerWidth-1:0] f_arrivals_q = '0;  // bytes received since the reset, modulo the ring
  always_ff @(posedge clk_i) begin
    if (ring_write && ring_write_addr == f_slot) begin
      f_ram_slot_q         <= ring_write_data;
      f_ram_slot_written_q <= 1'b1;
    end
    f_ram_read_slot_q <= ring_read_addr == f_slot && f_ram_slot_written_q && !(ring_write && ring_write_addr == f_slot);
    if (rx_valid_i) begin
      if (f_arrivals_q == f_slot) begin
        f_slot_byte_q     <= rx_data_i;
        f_slot_received_q <= 1'b1;
      end
      f_arrivals_q <= f_arrivals_q + 1'b1;
    end
  end
  always_comb begin
    // Every received byte, and nothing else, is written at its arrival's slot.
    the_ring_is_written_in_arrival_order: assert (ring_write == rx_valid_i &&
        (!ring_write || (ring_write_addr == f_arrivals_q && ring_write_data == rx_data_i)));
    the_ring_is_written_in_arrival_order_c: cover (ring_write && ring_write_addr == f_slot && f_arrivals_q != '0);
    // A read whose byte the parser takes in the next clock (fetched_d) never reads the slot written in
    // the same clock (no_rw_check: the RAM gives no defined byte there).
    if (ring_write && fetched_d) the_ring_never_reads_the_slot_written: assert (ring_read_addr != ring_write_addr);
    the_ring_never_reads_the_slot_written_c: cover (ring_write && fetched_d && !fetched_q);
    // The byte the parser consumes from a slot (ring_data_q) is, by the RAM's contract, the last
    // byte received into it: the read was of a written slot, with no write to it in that cycle,
    // and the RAM holds that byte there (with the backlog bound below, a byte of the current
    // frame: the parser sees the bytes as they arrived).
    if (fetched_q && read_q == f_slot && f_slot_received_q) the_parser_reads_the_bytes_received: assert (
        f_ram_read_slot_q && f_ram_slot_q == f_slot_byte_q);
    the_parser_reads_the_bytes_received_c: cover (fetched_q && read_q == f_slot && f_slot_received_q && f_pos_q == 8'd3);
  end

  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      if (fetched_q) the_byte_read_is_at_the_read_pointer: assert ($past(fetched_d) && read_q == $past(read_q));
      the_byte_read_is_at_the_read_pointer_c: cover (fetched_q && $past(rx_valid_i));
      // After a drop the parser rescans from the byte after the dropped frame's sync.
      if ($past(bad_o)) rescan_after_a_drop: assert (read_q == $past(start_q) + 1'b1 && f_pos_q == 8'd0);
      rescan_after_a_drop_c: cover ($past(bad_o) && $past(f_pos_q) == 8'd3);
      if ($past(ok_o)) continue_after_a_frame: assert (read_q == $past(read_q) + 1'b1 && f_pos_q == 8'd0);
      continue_after_a_frame_c: cover ($past(ok_o));
    end
    if (f_past2_valid && $past(rst_ni, 2)) begin
      // A byte into an idle ring (nothing fetched, nothing unread) is fetched in the next clock and
      // processed in the one after, from its slot (the model board takes the three clocks at once).
      // (No stall meets it: a stall follows a frame's last byte by at most ModelCrcClocks + 2 clocks,
      // and the next byte comes at least 9 bit times after that one.)
      if ($past(rx_valid_i && !fetched_q && read_q == write_q, 2)) an_idle_ring_processes_a_byte_two_clocks_after_it: assert (
          fetched_q && read_q == $past(write_q, 2) && !stall_i && !$past(stall_i));
      an_idle_ring_processes_a_byte_two_clocks_after_it_c: cover ($past(rx_valid_i && !fetched_q && read_q == write_q, 2) && f_pos_q == 8'd1);
    end
  end
`endif
endmodule
