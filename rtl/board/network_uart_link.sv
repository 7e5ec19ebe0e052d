// Framed request/response link between the host's UART and the network's ap_ctrl_hs interface.
//
// Request  (host -> FPGA): 0xA5, then Inputs codes of InputBytes bytes each (little-endian,
//   two's complement, sign-extended from InputWidth bits), then a checksum byte chosen so that
//   the 8-bit sum of the code bytes and the checksum is zero.
// Response (FPGA -> host): 0x5A, Outputs codes of OutputBytes bytes each (little-endian, sign-
//   extended from OutputWidth bits), checksum as above; or the single byte 0x15 (NAK) when the
//   checksum is wrong or a code does not fit InputWidth bits (it is never silently wrapped).
// One request at a time: bytes that arrive while a request is computed or answered are dropped,
// so the host waits for each answer (the answer takes (Outputs * OutputBytes + 2) byte times).
//
// Network handshake (Vitis HLS ap_ctrl_hs): start_o rises with inputs valid and stays high until
// ready_i; outputs are taken in the cycle done_i is high.
module network_uart_link #(
  parameter int unsigned Inputs      = 3,
  parameter int unsigned Outputs     = 3,
  parameter int unsigned InputWidth  = 16,  // bits of one raw input code
  parameter int unsigned OutputWidth = 16   // bits of one raw output code
) (
  input  logic                           clk_i,
  input  logic                           rst_ni,
  // from uart_rx
  input  logic [7:0]                     rx_data_i,
  input  logic                           rx_valid_i,
  // to uart_tx
  output logic [7:0]                     tx_data_o,
  output logic                           tx_valid_o,
  input  logic                           tx_ready_i,
  // to and from the network (ap_ctrl_hs)
  output logic                           start_o,
  input  logic                           ready_i,
  input  logic                           done_i,
  output logic [Inputs*InputWidth-1:0]   inputs_o,   // input k at [k*InputWidth +: InputWidth]
  input  logic [Outputs*OutputWidth-1:0] outputs_i,  // output k at [k*OutputWidth +: OutputWidth]
  // status for LEDs: one-cycle pulses
  output logic                           answered_o,
  output logic                           rejected_o
);
  localparam int unsigned InputBytes   = (InputWidth + 7) / 8;
  localparam int unsigned OutputBytes  = (OutputWidth + 7) / 8;
  localparam int unsigned RequestBytes = Inputs * InputBytes;
  localparam int unsigned AnswerBytes  = Outputs * OutputBytes + 2;  // sync, codes, checksum
  localparam int unsigned CountWidth   = $clog2(RequestBytes + AnswerBytes + 1);
  localparam logic [7:0] RequestSync = 8'(delta_board_pkg::LinkRequestSync);
  localparam logic [7:0] AnswerSync  = 8'(delta_board_pkg::LinkAnswerSync);
  localparam logic [7:0] Nak         = 8'(delta_board_pkg::LinkNak);

  typedef enum logic [2:0] {
    WaitSync,
    ReceiveCodes,
    ReceiveChecksum,
    Check,
    Compute,
    Answer
  } link_state_e;

  link_state_e                  state_d, state_q;
  logic [CountWidth-1:0]        count_d, count_q;       // bytes still to receive or to send
  logic [RequestBytes*8-1:0]    request_d, request_q;   // byte 0 at [7:0]
  logic [7:0]                   sum_d, sum_q;           // running sum of received code bytes
  logic [AnswerBytes*8-1:0]     answer_d, answer_q;     // next byte to send at [7:0]
  logic [7:0]                   check_d, check_q;       // sync minus the code bytes sent so far
  logic                         started_d, started_q;   // ap_start accepted (ap_ready seen)

  // A code fits when the bits above InputWidth-1 repeat its sign bit.
  logic codes_fit;
  always_comb begin
    codes_fit = 1'b1;
    for (int k = 0; k < Inputs; k++) begin
      for (int b = InputWidth; b < InputBytes * 8; b++) begin
        if (request_q[k*InputBytes*8 + b] != request_q[k*InputBytes*8 + InputWidth - 1]) begin
          codes_fit = 1'b0;
        end
      end
    end
  end

  always_comb begin
    for (int k = 0; k < Inputs; k++) begin
      inputs_o[k*InputWidth +: InputWidth] = request_q[k*InputBytes*8 +: InputWidth];
    end
  end

  // The answer frame for the current outputs: sync, sign-extended codes, and a placeholder for
  // the checksum. The checksum is summed byte by byte while the frame is sent (check_q) and put
  // in its place when the last code byte leaves: an adder tree over all code bytes in the cycle
  // of done_i was the board's critical path.
  logic [AnswerBytes*8-1:0] answer_frame;
  always_comb begin
    logic [Outputs*OutputBytes*8-1:0] codes;
    codes = '0;
    for (int k = 0; k < Outputs; k++) begin
      for (int b = 0; b < OutputBytes * 8; b++) begin
        codes[k*OutputBytes*8 + b] = outputs_i[k*OutputWidth + ((b < OutputWidth) ? b : OutputWidth - 1)];
      end
    end
    answer_frame = {8'd0, codes, AnswerSync};
  end

  always_comb begin
    state_d    = state_q;
    count_d    = count_q;
    request_d  = request_q;
    sum_d      = sum_q;
    answer_d   = answer_q;
    check_d    = check_q;
    started_d  = started_q;
    start_o    = 1'b0;
    tx_valid_o = 1'b0;
    answered_o = 1'b0;
    rejected_o = 1'b0;
    unique case (state_q)
      WaitSync: begin
        if (rx_valid_i && rx_data_i == RequestSync) begin
          state_d = ReceiveCodes;
          count_d = CountWidth'(RequestBytes);
          sum_d   = 8'd0;
        end
      end
      ReceiveCodes: begin
        if (rx_valid_i) begin
          request_d = {rx_data_i, request_q[RequestBytes*8-1:8]};
          sum_d     = sum_q + rx_data_i;
          count_d   = count_q - 1'b1;
          if (count_q == CountWidth'(1)) state_d = ReceiveChecksum;
        end
      end
      ReceiveChecksum: begin
        if (rx_valid_i) begin
          sum_d   = sum_q + rx_data_i;
          state_d = Check;
        end
      end
      Check: begin  // a cycle of its own: the checksum's carry chain stays off the decision
        if (sum_q == 8'd0 && codes_fit) begin
          state_d   = Compute;
          started_d = 1'b0;
        end else begin
          state_d    = Answer;
          answer_d   = {{(AnswerBytes - 1) * 8{1'b0}}, Nak};
          count_d    = CountWidth'(1);
          rejected_o = 1'b1;
        end
      end
      Compute: begin
        start_o = !started_q;
        if (ready_i) started_d = 1'b1;
        if (done_i) begin
          state_d    = Answer;
          answer_d   = answer_frame;
          check_d    = AnswerSync;  // the sync byte is subtracted first: the checksum covers the codes
          count_d    = CountWidth'(AnswerBytes);
          answered_o = 1'b1;
        end
      end
      Answer: begin
        tx_valid_o = 1'b1;
        if (tx_ready_i) begin
          answer_d = {8'd0, answer_q[AnswerBytes*8-1:8]};
          check_d  = check_q - answer_q[7:0];
          // The last code byte leaves: the checksum (minus the sum of the code bytes) is next.
          if (count_q == CountWidth'(2)) answer_d[7:0] = check_d;
          count_d  = count_q - 1'b1;
          if (count_q == CountWidth'(1)) state_d = WaitSync;
        end
      end
      default: state_d = WaitSync;
    endcase
  end

  assign tx_data_o = answer_q[7:0];

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      state_q   <= WaitSync;
      count_q   <= '0;
      request_q <= '0;
      sum_q     <= 8'd0;
      answer_q  <= '0;
      check_q   <= 8'd0;
      started_q <= 1'b0;
    end else begin
      state_q   <= state_d;
      count_q   <= count_d;
      request_q <= request_d;
      sum_q     <= sum_d;
      answer_q  <= answer_d;
      check_q   <= check_d;
      started_q <= started_d;
    end
  end
endmodule
