// UART receiver: 8 data bits, no parity, 1 stop bit (8N1), LSB first, idle high.
//
// Latency: data_valid_o pulses for one clk_i cycle half a bit after the middle of the stop bit
// (about 9.5 bit times after the start edge). A frame whose stop bit reads low is dropped and
// reported by a one-cycle frame_error_o pulse. rx_i is asynchronous: two flip-flops synchronise it.
module uart_rx #(
  parameter int unsigned ClocksPerBit = delta_board_pkg::LinkClocksPerBit  // clk_i frequency / baud rate
) (
  input  logic       clk_i,
  input  logic       rst_ni,
  input  logic       rx_i,
  output logic [7:0] data_o,
  output logic       data_valid_o,
  output logic       frame_error_o
);
  localparam int unsigned CountWidth = $clog2(ClocksPerBit + 1);
  localparam logic [CountWidth-1:0] FullBit = CountWidth'(ClocksPerBit - 1);
  localparam logic [CountWidth-1:0] HalfBit = CountWidth'(ClocksPerBit / 2);

  typedef enum logic [1:0] {
    Idle,
    Start,
    Data,
    Stop
  } rx_state_e;

  logic [1:0]            sync_q;
  rx_state_e             state_d, state_q;
  logic [CountWidth-1:0] count_d, count_q;
  logic [2:0]            bit_index_d, bit_index_q;
  logic [7:0]            shift_d, shift_q;
  logic                  valid_d, valid_q;
  logic                  error_d, error_q;

  wire rx_sync = sync_q[1];

  always_comb begin
    state_d     = state_q;
    count_d     = count_q;
    bit_index_d = bit_index_q;
    shift_d     = shift_q;
    valid_d     = 1'b0;
    error_d     = 1'b0;
    unique case (state_q)
      Idle: begin
        count_d = HalfBit;
        if (!rx_sync) state_d = Start;
      end
      Start: begin  // wait half a bit, then confirm the start bit is still low
        if (count_q != '0) begin
          count_d = count_q - 1'b1;
        end else if (rx_sync) begin
          state_d = Idle;  // a glitch, not a start bit
        end else begin
          state_d     = Data;
          count_d     = FullBit;
          bit_index_d = 3'd0;
        end
      end
      Data: begin
        if (count_q != '0) begin
          count_d = count_q - 1'b1;
        end else begin
          shift_d     = {rx_sync, shift_q[7:1]};
          count_d     = FullBit;
          bit_index_d = bit_index_q + 3'd1;
          if (bit_index_q == 3'd7) state_d = Stop;
        end
      end
      Stop: begin
        if (count_q != '0) begin
          count_d = count_q - 1'b1;
        end else begin
          state_d = Idle;
          valid_d = rx_sync;
          error_d = !rx_sync;
        end
      end
      default: state_d = Idle;
    endcase
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      sync_q      <= 2'b11;
      state_q     <= Idle;
      count_q     <= '0;
      bit_index_q <= 3'd0;
      shift_q     <= 8'd0;
      valid_q     <= 1'b0;
      error_q     <= 1'b0;
    end else begin
      sync_q      <= {sync_q[0], rx_i};
      state_q     <= state_d;
      count_q     <= count_d;
      bit_index_q <= bit_index_d;
      shift_q     <= shift_d;
      valid_q     <= valid_d;
      error_q     <= error_d;
    end
  end

  assign data_o        = shift_q;
  assign data_valid_o  = valid_q;
  assign frame_error_o = error_q;

`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // Two jobs. uart_rx_any_line: any line at all (no assumption on rx_i): the receiver still
  // delivers at most one byte or error per 9 bit times, the pace link_rx assumes. uart_rx: the
  // line driven by an ideal 8N1 transmitter at this receiver's bit time, the byte, the stop bit (high:
  // a byte; low: a framing error, then at least an idle bit) and when each frame starts free:
  // every byte sent is received once, unchanged, within its stop bit; every low stop bit is one
  // frame error; nothing else comes out.
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);

  // Clocks since the reset or the last byte or error, saturating at 9 bit times: link_rx's
  // environment (a byte at most once per 9 bit times) is this job's property.
  localparam int FPace = 9 * ClocksPerBit;
  logic [$clog2(FPace+1)-1:0] f_since_q = '0;
  always_ff @(posedge clk_i) begin
    if (data_valid_o || frame_error_o) f_since_q <= '0;
    else if (f_since_q != $clog2(FPace+1)'(FPace)) f_since_q <= f_since_q + 1'b1;
  end
  // The fewest clocks from now to the next output (data_valid_o or frame_error_o high).
  int unsigned f_to_output;
  always_comb begin
    unique case (state_q)
      Idle:    f_to_output = 2 + HalfBit + 9 * ClocksPerBit;
      Start:   f_to_output = 32'(count_q) + 1 + 9 * ClocksPerBit;
      Data:    f_to_output = 32'(count_q) + 1 + (8 - 32'(bit_index_q)) * ClocksPerBit;
      default: f_to_output = 32'(count_q) + 1;
    endcase
    if (valid_q || error_q) f_to_output = 0;
  end
  logic f_output_seen_q = 1'b0;
  always_ff @(posedge clk_i) if (data_valid_o || frame_error_o) f_output_seen_q <= 1'b1;
  always_comb begin
    if (data_valid_o || frame_error_o) at_most_one_output_per_9_bit_times: assert (f_since_q == $clog2(FPace+1)'(FPace));
    at_most_one_output_per_9_bit_times_c: cover (data_valid_o && f_output_seen_q && f_since_q == $clog2(FPace+1)'(FPace));
    a_byte_or_an_error_never_both: assert (!(data_valid_o && frame_error_o));
    a_byte_or_an_error_never_both_c: cover (frame_error_o && f_output_seen_q);
    // Lemma: the clocks since the last output and the fewest to the next one add up to more than
    // 9 bit times (an output is one clock after a count of 0 in Stop; Idle, Start and every Data
    // bit take their counts' clocks).
    if (f_since_q != $clog2(FPace+1)'(FPace)) the_next_output_is_9_bit_times_away: assert (
        32'(f_since_q) + f_to_output >= FPace);
    the_next_output_is_9_bit_times_away_c: cover (f_output_seen_q && state_q == Data && f_since_q != $clog2(FPace+1)'(FPace));
  end

`ifndef FORMAL_UART_RX_ANY_LINE
  // The transmitter: bit 0 the start bit, 1..8 the data (LSB first), 9 the stop bit.
  (* anyseq *) logic f_go, f_stop_bit;
  (* anyseq *) logic [7:0] f_data;
  logic                  f_sending_q = 1'b0, f_stop_q = 1'b1, f_owed_q = 1'b0;
  logic [3:0]            f_bit_q = '0;
  logic [CountWidth-1:0] f_clock_q = '0;  // clocks into the bit, and into the idle bit owed after a framing error
  logic [7:0]            f_byte_q = '0;
  logic                  f_line, f_last_clock;
  logic                  f_pending_q = 1'b0;  // the frame's last data bit was sent; its byte or error not yet out
  assign f_last_clock = f_clock_q == CountWidth'(ClocksPerBit - 1);
  always_comb begin
    f_line = 1'b1;
    if (f_sending_q) begin
      if (f_bit_q == 4'd0) f_line = 1'b0;
      else if (f_bit_q == 4'd9) f_line = f_stop_q;
      else f_line = f_byte_q[3'(f_bit_q - 4'd1)];
    end
  end
  always_ff @(posedge clk_i) begin
    if (!f_sending_q) begin
      if (f_owed_q) begin
        f_clock_q <= f_last_clock ? '0 : f_clock_q + 1'b1;
        if (f_last_clock) f_owed_q <= 1'b0;
      end else if (f_go && rst_ni) begin
        f_sending_q <= 1'b1;
        f_bit_q     <= 4'd0;
        f_clock_q   <= '0;
        f_byte_q    <= f_data;
        f_stop_q    <= f_stop_bit;
      end
    end else if (f_last_clock) begin
      f_clock_q <= '0;
      f_bit_q   <= f_bit_q + 4'd1;
      if (f_bit_q == 4'd9) begin
        f_sending_q <= 1'b0;
        f_owed_q    <= !f_stop_q;
      end
    end else begin
      f_clock_q <= f_clock_q + 1'b1;
    end
    if (f_sending_q && f_bit_q == 4'd8 && f_last_clock) f_pending_q <= 1'b1;
    else if (data_valid_o || frame_error_o) f_pending_q <= 1'b0;
  end
  // The receiver's expected state. FK: the transmitter's clock in a bit at which the receiver's
  // bit of the same index begins (4 + HalfBit: synchroniser, Idle, the half bit of Start).
  localparam int FK = 4 + ClocksPerBit / 2;
  localparam int FP = ClocksPerBit;
  logic      f_line_q1 = 1'b1, f_line_q2 = 1'b1, f_settled_q = 1'b0;  // settled: two clocks after the reset
  always_ff @(posedge clk_i) begin
    f_settled_q <= f_past_valid;
    f_line_q1 <= f_line;
    f_line_q2 <= f_line_q1;
  end
  int        f_tau_clock, f_expect_count;
  rx_state_e f_expect_state;
  logic [2:0] f_expect_bit;
  logic      f_expect_shift_ok;
  int        f_received;  // data bits the receiver has shifted in
  always_comb begin
    f_tau_clock    = 32'(f_clock_q);
    f_expect_state = Idle;
    f_expect_count = 0;
    f_expect_bit   = 3'd0;
    f_received     = 0;
    if (f_sending_q) begin
      if (f_bit_q == 4'd0 && f_tau_clock < 3) begin
        f_expect_state = Idle;
      end else if (f_bit_q == 4'd0 && f_tau_clock < FK) begin
        f_expect_state = Start;
        f_expect_count = FK - 1 - f_tau_clock;
      end else if (f_bit_q <= 4'd8 && f_tau_clock >= FK) begin
        f_expect_state = f_bit_q == 4'd8 ? Stop : Data;
        f_expect_count = FP - 1 - (f_tau_clock - FK);
        f_expect_bit   = 3'(f_bit_q);
        f_received     = 32'(f_bit_q);
      end else if (f_bit_q >= 4'd1 && f_tau_clock < FK) begin
        f_expect_state = f_bit_q == 4'd9 ? Stop : Data;
        f_expect_count = FK - 1 - f_tau_clock;
        f_expect_bit   = 3'(f_bit_q - 4'd1);
        f_received     = 32'(f_bit_q) - 1;
      end else if (f_tau_clock > FK && !f_stop_q) begin  // a low stop bit read as a start bit
        f_expect_state = Start;
        f_expect_count = 2 * FK - 3 - f_tau_clock;
      end
    end else if (f_owed_q && f_tau_clock <= 2 * FK - 3 - FP) begin
      f_expect_state = Start;
      f_expect_count = 2 * FK - 3 - FP - f_tau_clock;
    end
    if (f_expect_state == Stop) f_received = 8;
    // The bits shifted in so far are the byte's first ones, at the top of the shift register.
    f_expect_shift_ok = ({24'd0, shift_q} >> (8 - f_received)) == ({24'd0, f_byte_q} & ((32'd1 << f_received) - 32'd1));
  end
  always_comb begin
    the_line_is_an_8n1_transmitter: assume (rx_i == f_line);
    // Each frame gives exactly one output, in its stop bit: the byte sent if the stop bit is
    // high, a frame error if it is low.
    if (data_valid_o) a_byte_is_the_byte_sent: assert (f_pending_q && f_stop_q && data_o == f_byte_q &&
        f_sending_q && f_bit_q == 4'd9);
    a_byte_is_the_byte_sent_c: cover (data_valid_o && data_o == 8'hA5);
    if (frame_error_o) an_error_is_a_low_stop_bit: assert (f_pending_q && !f_stop_q && f_sending_q && f_bit_q == 4'd9);
    an_error_is_a_low_stop_bit_c: cover (frame_error_o);
    if (f_sending_q && f_bit_q == 4'd9 && f_last_clock) every_frame_gives_its_output_in_its_stop_bit: assert (!f_pending_q);
    every_frame_gives_its_output_in_its_stop_bit_c: cover (f_sending_q && f_bit_q == 4'd9 && f_last_clock && f_stop_q);
    // Lemma: the receiver's state is a function of the transmitter's (the bit and the clock in
    // it): two clocks of synchroniser, half a bit to the start bit's middle, then a bit's clocks
    // per bit, each sampled in its middle (f_expect_*, below).
    if (f_settled_q) the_receiver_follows_the_transmitter: assert (
        sync_q == {f_line_q2, f_line_q1} && state_q == f_expect_state &&
        (f_expect_state == Idle || count_q == f_expect_count) && (f_expect_state != Data || bit_index_q == f_expect_bit) &&
        ((f_expect_state != Data && f_expect_state != Stop) || f_expect_shift_ok) &&
        valid_q == (f_sending_q && f_bit_q == 4'd9 && f_tau_clock == FK && f_stop_q) &&
        error_q == (f_sending_q && f_bit_q == 4'd9 && f_tau_clock == FK && !f_stop_q) &&
        f_pending_q == (f_sending_q && f_bit_q == 4'd9 && f_tau_clock <= FK) &&
        (!f_sending_q || f_bit_q <= 4'd9));
    the_receiver_follows_the_transmitter_c: cover (f_settled_q && f_sending_q && state_q == Stop && !f_stop_q);
  end
`endif
`endif
endmodule
