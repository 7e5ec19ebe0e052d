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
endmodule
