// The model loader (docs/board_link.md, "The model"): takes the host's model frames (type 0x04)
// one word at a time into the network's memories and the interpolator's play words, and checks
// the load with its own CRC-32/ISO-HDLC before the board may enable.
//
// A model frame's payload (u16 frame number n, a 48-bit word) is kept as link_rx presents it
// (tentatively: the frame is not checked yet); only frame_ok_i acts on it:
//   - drives on (drives_on_i): refused (refused_o), nothing changes;
//   - n = 0: a load starts: the model is void (loaded_o low) and word 0 is written (write_o);
//   - n = the next frame number of a load in progress, below the commit: the word is written;
//   - n = ModelCommitFrame as the next frame: the load ends; the model is loaded if and only if the
//     CRC-32 of the words taken (6 little-endian bytes each) equals the commit word's bits 0-31;
//   - anything else: refused, nothing changes.
// Every taken word (frames 0 .. ModelCommitFrame - 1) then runs bit-serially through the CRC, bit 0
// first (the CRC is reflected: byte 0 LSB first is word bit 0 first), one bit a clock for
// ModelCrcClocks clocks (the word register shifts into it); stall_o holds link_rx's parser
// meanwhile, so the next frame's bytes wait in its ring (a taken frame's CRC always ends before the
// next frame is parsed). The flag (loaded_o) and the CRC change in the clock after the commit's
// frame_ok_i (delta_board_pkg: ModelCrcClocks, the facts of the loader).
module model_loader #(
  // The commit's frame number (the package's; the formal covers shorten the load)
  parameter int unsigned CommitFrameNumber = delta_board_pkg::ModelCommitFrame
) (
  input  logic        clk_i,
  input  logic        rst_ni,
  // from link_rx
  input  logic        is_model_i,        // the frame in flight is a model frame
  input  logic        payload_valid_i,
  input  logic [2:0]  payload_index_i,   // a model frame's bytes 0 .. 7 (link_rx presents exactly 8)
  input  logic [7:0]  payload_byte_i,
  input  logic        frame_ok_i,
  output logic        stall_o,           // link_rx's parser waits: the CRC runs
  input  logic        drives_on_i,       // model frames are refused with the drives on
  output logic        refused_o,         // pulse: a checked model frame was refused
  // the word taken, into the memories (frame numbers below ModelCommitFrame)
  output logic        write_o,           // pulse: word_o is frame address_o's word
  output logic [7:0]  address_o,
  output logic [47:0] word_o,
  // the model
  output logic        loaded_o,          // a complete load whose CRC matched (flag 7)
  output logic [31:0] crc_o              // its CRC-32 (identify), 0 without a model
);
  localparam int unsigned WordBits   = delta_board_pkg::ModelWordBits;
  localparam logic [7:0]  CommitFrame = 8'(CommitFrameNumber);
  localparam logic [31:0] Polynomial  = 32'hEDB8_8320;  // CRC-32/ISO-HDLC, reflected
  localparam int unsigned CountWidth  = $clog2(delta_board_pkg::ModelCrcClocks + 1);

  logic [WordBits-1:0]   word_q;          // the frame's word; then shifted into the CRC
  logic [7:0]            number_q;        // frame number, low byte
  logic                  number_high_q;   // its high byte is not zero
  logic [7:0]            expected_q;      // the next frame number of the load in progress
  logic                  loading_q, loaded_q;
  logic [31:0]           crc_q;           // the running CRC register (not yet inverted)
  logic                  restart_q;       // the word shifting is frame 0's: the CRC starts from all ones
  logic [31:0]           crc_base;
  logic [CountWidth-1:0] shift_count_q;   // CRC bits still to shift
  logic                  stall_q;         // shift_count_q != 0, a register (link_rx's parser waits on it)

  logic take, start, commit;
  assign start     = !number_high_q && number_q == 8'd0;
  assign take      = frame_ok_i && is_model_i && !drives_on_i &&
                     (start || (loading_q && !number_high_q && number_q == expected_q));
  assign commit    = take && number_q == CommitFrame;
  assign refused_o = frame_ok_i && is_model_i && !take;
  assign write_o   = take && !commit;
  assign address_o = number_q;
  assign word_o    = word_q;
  assign stall_o   = stall_q;
  // The CRC's initial value enters at frame 0's first bit (a register of all ones then), so the
  // register itself only ever shifts.
  assign crc_base  = restart_q ? '1 : crc_q;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      word_q        <= '0;
      number_q      <= '0;
      number_high_q <= 1'b0;
      expected_q    <= '0;
      loading_q     <= 1'b0;
      loaded_q      <= 1'b0;
      crc_q         <= '0;
      restart_q     <= 1'b0;
      shift_count_q <= '0;
      stall_q       <= 1'b0;
    end else begin
      if (payload_valid_i && is_model_i && payload_index_i == 3'd0) number_q <= payload_byte_i;
      if (payload_valid_i && is_model_i && payload_index_i == 3'd1) number_high_q <= payload_byte_i != 8'd0;
      for (int b = 0; b < WordBits / 8; b++) begin  // byte b of the word is payload byte 2 + b
        if (payload_valid_i && is_model_i && payload_index_i == 3'(2 + b)) word_q[8 * b +: 8] <= payload_byte_i;
      end
      if (stall_o) begin
        crc_q         <= (crc_base >> 1) ^ ((crc_base[0] ^ word_q[0]) ? Polynomial : 32'd0);
        restart_q     <= 1'b0;
        word_q        <= word_q >> 1;
        shift_count_q <= shift_count_q - 1'b1;
        if (shift_count_q == CountWidth'(1)) stall_q <= 1'b0;
      end
      if (take) begin
        if (commit) begin
          loading_q <= 1'b0;
          loaded_q  <= ~crc_q == word_q[31:0];
        end else begin
          loading_q     <= 1'b1;
          loaded_q      <= 1'b0;
          expected_q    <= number_q + 8'd1;
          shift_count_q <= CountWidth'(delta_board_pkg::ModelCrcClocks);
          stall_q       <= 1'b1;
          restart_q     <= start;
        end
      end
    end
  end

  assign loaded_o = loaded_q;
  assign crc_o    = loaded_q ? ~crc_q : '0;
`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // Environment: reset in the first cycle only; link_rx delivers nothing while it is stalled (its
  // own job proves the stall holds it), and a model frame's ok only after its 8 payload bytes
  // (job link_rx: payload_bytes_presented_once_in_order, ok_only_with_a_matching_crc); every other
  // input free.
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  logic [7:0] f_seen_q = '0;  // the model payload bytes presented since the last frame's end
  always_ff @(posedge clk_i) begin
    if (frame_ok_i || !rst_ni) f_seen_q <= '0;
    else if (payload_valid_i && is_model_i) f_seen_q[payload_index_i] <= 1'b1;
  end
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
    nothing_is_delivered_while_stalled: assume (!stall_o || (!frame_ok_i && !payload_valid_i));
    a_model_frames_ok_follows_its_payload: assume (!(frame_ok_i && is_model_i) || f_seen_q == 8'hFF);
    // link_rx's parser presents a payload byte and decides a frame (ok) in different branches of
    // one step: never in the same clock.
    no_payload_byte_in_the_clock_of_an_ok: assume (!(frame_ok_i && payload_valid_i));
  end
  // The specification, written independently: the frame number and word as the payload presents
  // them, and the CRC-32/ISO-HDLC of a word's six little-endian bytes in one step.
  function automatic logic [31:0] f_crc32_word(logic [31:0] crc, logic [47:0] word);
    logic [31:0] value;
    value = crc;
    for (int i = 0; i < 48; i++) value = (value >> 1) ^ ((value[0] ^ word[i]) ? 32'hEDB8_8320 : 32'd0);
    f_crc32_word = value;
  endfunction
  logic [15:0] f_number_q = '0;
  logic [47:0] f_word_q = '0;
  always_ff @(posedge clk_i) begin
    if (rst_ni && payload_valid_i && is_model_i) begin
      if (payload_index_i == 3'd0) f_number_q[7:0] <= payload_byte_i;
      if (payload_index_i == 3'd1) f_number_q[15:8] <= payload_byte_i;
      if (payload_index_i >= 3'd2) f_word_q[8 * (payload_index_i - 3'd2) +: 8] <= payload_byte_i;
    end
  end
  // The CRC a taken word must leave once its clocks are over.
  logic [31:0] f_crc_expected_q = '0;
  always_ff @(posedge clk_i) begin
    if (take && !commit) f_crc_expected_q <= f_crc32_word(start ? 32'hFFFF_FFFF : crc_q, f_word_q);
  end
  logic f_model_frame, f_drives_on_frame;
  assign f_model_frame     = frame_ok_i && is_model_i;
  assign f_drives_on_frame = f_model_frame && drives_on_i;
  always_comb begin
    // The word written is the frame's, at its frame number, only for a frame taken with the drives off.
    if (write_o) a_word_is_written_only_from_a_frame_taken_with_the_drives_off: assert (
        f_model_frame && !drives_on_i && f_number_q < 16'(CommitFrame) &&
        address_o == f_number_q[7:0] && word_o == f_word_q);
    a_word_is_written_only_from_a_frame_taken_with_the_drives_off_c: cover (write_o && address_o == 8'd1);
    if (f_drives_on_frame) a_model_frame_with_the_drives_on_is_refused: assert (refused_o && !write_o);
    a_model_frame_with_the_drives_on_is_refused_c: cover (f_drives_on_frame);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      // The flag rises only at a commit, the frame after 0 .. ModelCommitFrame - 1 taken in order,
      // whose CRC-32 equals the board's CRC of the words taken.
      if (!$past(loaded_q) && loaded_q) the_model_flag_rises_only_at_a_commit_whose_crc_matched: assert (
          $past(f_model_frame) && !$past(drives_on_i) && $past(f_number_q) == 16'(CommitFrame) &&
          $past(loading_q) && $past(expected_q) == CommitFrame &&
          $past(word_q[31:0]) == ~$past(crc_q));
      the_model_flag_rises_only_at_a_commit_whose_crc_matched_c: cover (!$past(loaded_q) && loaded_q);
      // A model frame with the drives on changes nothing (the model, its CRC, the load in progress).
      if ($past(f_drives_on_frame)) a_model_frame_with_the_drives_on_changes_nothing: assert (
          loaded_q == $past(loaded_q) && crc_q == $past(crc_q) && loading_q == $past(loading_q) &&
          expected_q == $past(expected_q) && shift_count_q == $past(shift_count_q));
      a_model_frame_with_the_drives_on_changes_nothing_c: cover ($past(f_drives_on_frame) && loaded_q);
      // The stall is the count's: shift_count_q != 0 (a register, off link_rx's parser path).
      the_stall_is_a_nonzero_count: assert (stall_q == (shift_count_q != '0));
      the_stall_is_a_nonzero_count_c: cover (stall_q && shift_count_q == CountWidth'(1));
      // The bit-serial CRC: a taken word's ModelCrcClocks clocks leave the CRC-32 of its six bytes.
      if ($past(stall_o) && !stall_o) the_serial_crc_is_the_crc32_of_the_word: assert (crc_q == f_crc_expected_q);
      the_serial_crc_is_the_crc32_of_the_word_c: cover ($past(stall_o) && !stall_o);
    end
  end
`endif
endmodule
