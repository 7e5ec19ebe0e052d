// Link v2 transmitter (docs/board_link.md): the identify reply and the 1 kHz telemetry frames.
//
// One block RAM of 256 x 16-bit words holds both payloads: words 0..11 the identify payload,
// filled by $readmemh from MemDir/MemFile (identify.mem, written by `deltactl quantise` beside the
// weights: protocol version, build id, clocks; its weights CRC words are 0) and never written:
// the identify frame carries weights_crc_i (the loaded model's CRC-32, 0 without one) in their
// place, at payload bytes IdentifyWeightsCrcOffset .. + 3; words 16..37 the
// telemetry snapshot. snapshot_i starts a snapshot: for TelemetryWords cycles word_index_o names a
// telemetry word, and the caller answers each on word_i one cycle later (it may read a RAM), which
// is written to the RAM; then a telemetry frame is queued. The snapshot is what makes the frame consistent: the fields change
// while its 50 bytes take 500 us on the line. A snapshot while the previous telemetry frame is
// still being sent is skipped (the host sees the gap in the sequence numbers).
//
// Frames leave byte by byte to uart_tx: sync, length, sequence, type, payload (little-endian words,
// low byte first), CRC-16 high and low (link_crc16 over length..payload). The identify reply
// carries the request's sequence number (identify_sequence_i); telemetry counts its own.
module link_tx #(
  parameter MemDir  = ".",
  parameter MemFile = "identify.mem"
) (
  input  logic       clk_i,
  input  logic       rst_ni,
  input  logic       snapshot_i,           // pulse: capture the telemetry and send it
  output logic [4:0] word_index_o,         // telemetry word being captured (payload bytes 2w, 2w+1)
  input  logic [15:0] word_i,              // that word, from the caller
  input  logic       identify_i,           // pulse: send the identify reply
  input  logic [7:0] identify_sequence_i,  // its sequence number (held with identify_i)
  input  logic [31:0] weights_crc_i,       // the loaded model's CRC-32 (0: none), for identify
  output logic [7:0] tx_data_o,            // to uart_tx
  output logic       tx_valid_o,
  input  logic       tx_ready_i
);
  localparam int unsigned TelemetryWords = delta_board_pkg::TelemetryPayloadBytes / 2;
  localparam logic [7:0]  TelemetryBase  = 8'(delta_board_pkg::LinkTxTelemetryWord);
  localparam logic [7:0]  Sync           = 8'(delta_board_pkg::FrameSync);

  // ---- payload RAM ------------------------------------------------------------------------------
  // no_rw_check: no read-during-write logic; the snapshot never writes while telemetry is sent and
  // the identify words are never written.
  (* no_rw_check *) logic [15:0] words [delta_board_pkg::LinkTxWords];
`include "readmemh_load.svh"
  logic [7:0]  read_address, write_address;
  logic [15:0] read_data_q;
  logic        write_enable;
  always_ff @(posedge clk_i) begin
    if (write_enable) words[write_address] <= word_i;
    read_data_q <= words[read_address];
  end

  // ---- snapshot ---------------------------------------------------------------------------------
  // capture_q names the word asked for; the word arriving on word_i is written one cycle later at
  // written_q.
  logic       capturing_q, writing_q, telemetry_pending_q, sending_telemetry;
  logic [4:0] capture_q, written_q;
  assign write_enable  = writing_q;
  assign write_address = TelemetryBase + 8'(written_q);
  assign word_index_o  = capture_q;

  // ---- sender -----------------------------------------------------------------------------------
  typedef enum logic [1:0] {
    Idle,
    Fetch,  // the RAM reads the next payload word
    Send    // a byte waits for uart_tx
  } tx_state_e;

  tx_state_e  state_d, state_q;
  logic [5:0] index_d, index_q;    // byte of the frame being sent
  logic [5:0] length_d, length_q;  // payload bytes of the frame being sent
  logic       is_identify_d, is_identify_q;
  logic [7:0] telemetry_sequence_q, sequence_d, sequence_q;
  logic       identify_pending_q;
  logic [7:0] identify_sequence_q;
  logic       crc_clear, crc_valid, start_identify, start_telemetry;
  logic [15:0] crc;
  logic [5:0] payload_byte;  // index_q - 4

  assign payload_byte = index_q - 6'd4;
  assign read_address = (is_identify_q ? 8'd0 : TelemetryBase) + 8'(payload_byte[5:1]);

  always_comb begin
    unique case (index_q)
      6'd0: tx_data_o = Sync;
      6'd1: tx_data_o = 8'(length_q);
      6'd2: tx_data_o = sequence_q;
      6'd3: tx_data_o = is_identify_q ? 8'(delta_board_pkg::FrameTypeIdentify) : 8'(delta_board_pkg::FrameTypeTelemetry);
      default: begin
        if (index_q == length_q + 6'd4) tx_data_o = crc[15:8];
        else if (index_q == length_q + 6'd5) tx_data_o = crc[7:0];
        else if (is_identify_q && payload_byte[5:2] == 4'(delta_board_pkg::IdentifyWeightsCrcOffset / 4))
          tx_data_o = weights_crc_i[8 * payload_byte[1:0] +: 8];
        else tx_data_o = payload_byte[0] ? read_data_q[15:8] : read_data_q[7:0];
      end
    endcase
  end

  link_crc16 u_crc (
    .clk_i,
    .rst_ni,
    .clear_i(crc_clear),
    .valid_i(crc_valid),
    .data_i (tx_data_o),
    .crc_o  (crc)
  );

  assign sending_telemetry = state_q != Idle && !is_identify_q;

  always_comb begin
    state_d         = state_q;
    index_d         = index_q;
    length_d        = length_q;
    is_identify_d   = is_identify_q;
    sequence_d      = sequence_q;
    tx_valid_o      = 1'b0;
    crc_clear       = 1'b0;
    crc_valid       = 1'b0;
    start_identify  = 1'b0;
    start_telemetry = 1'b0;
    unique case (state_q)
      Idle: begin
        if (telemetry_pending_q) begin
          start_telemetry = 1'b1;
          is_identify_d   = 1'b0;
          length_d        = 6'(delta_board_pkg::TelemetryPayloadBytes);
          sequence_d      = telemetry_sequence_q;
        end else if (identify_pending_q) begin
          start_identify = 1'b1;
          is_identify_d  = 1'b1;
          length_d       = 6'(delta_board_pkg::IdentifyPayloadBytes);
          sequence_d     = identify_sequence_q;
        end
        if (start_telemetry || start_identify) begin
          state_d   = Send;
          index_d   = 6'd0;
          crc_clear = 1'b1;
        end
      end
      Fetch: state_d = Send;
      Send: begin
        tx_valid_o = 1'b1;
        if (tx_ready_i) begin
          crc_valid = index_q != 6'd0 && index_q < length_q + 6'd4;
          index_d   = index_q + 1'b1;
          if (index_q == length_q + 6'd5) state_d = Idle;
          else if (index_q >= 6'd3) state_d = Fetch;  // the next byte may be a new payload word
        end
      end
      default: state_d = Idle;
    endcase
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      state_q              <= Idle;
      index_q              <= '0;
      length_q             <= '0;
      is_identify_q        <= 1'b0;
      sequence_q           <= '0;
      telemetry_sequence_q <= '0;
      identify_pending_q   <= 1'b0;
      identify_sequence_q  <= '0;
      telemetry_pending_q  <= 1'b0;
      capturing_q          <= 1'b0;
      capture_q            <= '0;
      writing_q            <= 1'b0;
      written_q            <= '0;
    end else begin
      writing_q <= capturing_q;
      written_q <= capture_q;
      if (writing_q && !capturing_q) telemetry_pending_q <= 1'b1;
      state_q       <= state_d;
      index_q       <= index_d;
      length_q      <= length_d;
      is_identify_q <= is_identify_d;
      sequence_q    <= sequence_d;
      if (identify_i) begin
        identify_pending_q  <= 1'b1;
        identify_sequence_q <= identify_sequence_i;
      end else if (start_identify) begin
        identify_pending_q <= 1'b0;
      end
      if (start_telemetry) begin
        telemetry_pending_q  <= 1'b0;
        telemetry_sequence_q <= telemetry_sequence_q + 1'b1;
      end
      if (snapshot_i && !capturing_q && !writing_q && !telemetry_pending_q && !sending_telemetry) begin
        capturing_q <= 1'b1;
        capture_q   <= '0;
      end else if (capturing_q) begin
        capture_q <= capture_q + 1'b1;
        if (capture_q == 5'(TelemetryWords - 1)) capturing_q <= 1'b0;
      end
    end
  end
`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // What the model board (host/cosim/model_board.cpp) relies on: it reads a frame's words when the
  // frame starts and keeps its RAM in place, and follows the capture's word index only while it
  // captures. Environment: reset in the first cycle only; every other input is free.
  localparam int unsigned FIdentifyWords = delta_board_pkg::IdentifyPayloadBytes / 2;
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
  end
  always_comb begin
    // A snapshot is written only while no telemetry frame is queued or sent: a telemetry frame's
    // words hold still from its start to its last byte.
    if (telemetry_pending_q || sending_telemetry) no_capture_while_telemetry_is_queued_or_sent: assert (
        !capturing_q && !writing_q && !write_enable);
    no_capture_while_telemetry_is_queued_or_sent_c: cover (sending_telemetry && snapshot_i);
    // The identify words are never written (an identify frame reads words no capture writes): every
    // write is a telemetry word, above the identify payload.
    if (write_enable) the_identify_words_are_never_written: assert (write_address >= TelemetryBase &&
        write_address < TelemetryBase + 8'(TelemetryWords) && TelemetryBase >= 8'(FIdentifyWords));
    the_identify_words_are_never_written_c: cover (write_enable && state_q != Idle && is_identify_q);
    // The RAM is never read for a payload byte in the clock that writes the same word.
    if (write_enable && state_q != Idle && index_q >= 6'd4 && index_q < length_q + 6'd4) begin
      the_ram_never_reads_the_word_written: assert (read_address != write_address);
    end
    the_ram_never_reads_the_word_written_c: cover (write_enable && state_q == Fetch && index_q >= 6'd4 && index_q < length_q + 6'd4);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      // The word index asked of board_core moves only while capturing or at a snapshot's start.
      if (capture_q != $past(capture_q)) the_word_index_moves_only_while_capturing: assert (
          $past(capturing_q) || ($past(snapshot_i) && capture_q == '0));
      the_word_index_moves_only_while_capturing_c: cover ($past(capturing_q) && capture_q == 5'(TelemetryWords - 1));
    end
  end
`endif
endmodule
