// UART transmitter: 8N1, LSB first, idle high.
//
// Handshake: a byte is taken when data_valid_i && data_ready_o (one cycle); data_ready_o is low
// for the 10 bit times of the frame that follows.
module uart_tx #(
  parameter int unsigned ClocksPerBit = 104  // clk_i frequency / baud rate
) (
  input  logic       clk_i,
  input  logic       rst_ni,
  input  logic [7:0] data_i,
  input  logic       data_valid_i,
  output logic       data_ready_o,
  output logic       tx_o
);
  localparam int unsigned CountWidth = $clog2(ClocksPerBit + 1);
  localparam logic [CountWidth-1:0] FullBit = CountWidth'(ClocksPerBit - 1);

  // {stop, data[7:0], start}: shifted out LSB first; all ones when idle.
  logic [9:0]            frame_d, frame_q;
  logic [3:0]            bits_left_d, bits_left_q;
  logic [CountWidth-1:0] count_d, count_q;

  assign data_ready_o = (bits_left_q == 4'd0);

  always_comb begin
    frame_d     = frame_q;
    bits_left_d = bits_left_q;
    count_d     = count_q;
    if (bits_left_q == 4'd0) begin
      if (data_valid_i) begin
        frame_d     = {1'b1, data_i, 1'b0};
        bits_left_d = 4'd10;
        count_d     = FullBit;
      end
    end else if (count_q != '0) begin
      count_d = count_q - 1'b1;
    end else begin
      frame_d     = {1'b1, frame_q[9:1]};
      bits_left_d = bits_left_q - 4'd1;
      count_d     = FullBit;
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      frame_q     <= 10'h3ff;
      bits_left_q <= 4'd0;
      count_q     <= '0;
    end else begin
      frame_q     <= frame_d;
      bits_left_q <= bits_left_d;
      count_q     <= count_d;
    end
  end

  assign tx_o = frame_q[0];
`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // What the model board (host/cosim/model_board.cpp) relies on: a byte taken keeps data_ready_o
  // low for exactly 10 bit times, so link_tx (waiting in Send) hands over the next byte
  // 10 x ClocksPerBit + 1 clocks after the last. Environment: reset in the first cycle only.
  localparam int unsigned FFrameClocks = 10 * ClocksPerBit;
  localparam int unsigned FWidth = $clog2(FFrameClocks + 2);
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
  end
  logic [FWidth-1:0] f_since_load_q = '0;  // clocks since the last byte was taken (while busy)
  always_ff @(posedge clk_i) begin
    if (data_valid_i && data_ready_o) f_since_load_q <= FWidth'(1);
    else if (!data_ready_o && f_since_load_q != '1) f_since_load_q <= f_since_load_q + 1'b1;
  end
  always_comb begin
    if (rst_ni && !data_ready_o) a_byte_keeps_the_transmitter_busy_for_ten_bit_times: assert (
        bits_left_q <= 4'd10 && count_q <= FullBit && 32'(f_since_load_q) ==
        (32'd10 - 32'(bits_left_q)) * ClocksPerBit + ClocksPerBit - 32'(count_q));
    a_byte_keeps_the_transmitter_busy_for_ten_bit_times_c: cover (rst_ni && !data_ready_o && bits_left_q == 4'd1 && count_q == '0);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni) && rst_ni) begin
      if (!$past(data_ready_o) && data_ready_o) ready_again_ten_bit_times_after_a_byte: assert (
          32'($past(f_since_load_q)) == FFrameClocks);
      ready_again_ten_bit_times_after_a_byte_c: cover (!$past(data_ready_o) && data_ready_o);
    end
  end
`endif
endmodule
