// CRC-16/CCITT-FALSE of the board link v2's frames (docs/board_link.md), one byte per cycle:
// polynomial delta_board_pkg::FrameCrcPolynomial (0x1021), initial value FrameCrcInit (0xFFFF),
// no reflection, no final XOR; the C++ codec's crc16() (host/include/delta/link/frame_codec.hpp)
// is its golden model (test LinkCrc16.*).
//
// Handshake: clear_i loads the initial value; a byte with valid_i updates the CRC, which crc_o
// shows from the next cycle (latency 1). clear_i and valid_i together start a new CRC with the
// byte.
module link_crc16 (
  input  logic        clk_i,
  input  logic        rst_ni,
  input  logic        clear_i,
  input  logic        valid_i,
  input  logic [7:0]  data_i,
  output logic [15:0] crc_o
);
  localparam logic [15:0] Polynomial = 16'(delta_board_pkg::FrameCrcPolynomial);
  localparam logic [15:0] Init       = 16'(delta_board_pkg::FrameCrcInit);

  // Eight shift-and-XOR steps, MSB first, unrolled: 37 LUT4 + 16 flip-flops (yosys synth_ice40).
  function automatic logic [15:0] crc_byte(logic [15:0] crc, logic [7:0] data);
    logic [15:0] value;
    value = crc ^ {data, 8'h00};
    for (int bit_index = 0; bit_index < 8; bit_index++) begin
      value = value[15] ? {value[14:0], 1'b0} ^ Polynomial : {value[14:0], 1'b0};
    end
    crc_byte = value;
  endfunction

  logic [15:0] crc_d, crc_q;
  always_comb begin
    crc_d = crc_q;
    if (clear_i) crc_d = Init;
    if (valid_i) crc_d = crc_byte(clear_i ? Init : crc_q, data_i);
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) crc_q <= Init;
    else crc_q <= crc_d;
  end

  assign crc_o = crc_q;
endmodule
