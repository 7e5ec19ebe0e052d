// Quadrature decoder (x4) with a 16-bit signed position counter in shaft encoder counts (0.01 deg).
//
// Inputs must already be synchronised to clk_i. Every edge of A or B is one count (x4 decoding);
// a step of both channels at once (a lost state) is not counted but flagged on error_o for one
// cycle. The counter starts at HomeCount: the joint is assumed at its home angle at reset.
// rising_o says which way the count last stepped (1: up; 1 from reset): behind a joint's play it
// is the side the play was last taken up on (reference_interpolator.sv's resting shift).
module quadrature_counter #(
  parameter logic [15:0] HomeCount = 16'd3000  // 30.00 deg, the paper's start pose
) (
  input  logic        clk_i,
  input  logic        rst_ni,
  input  logic        a_i,
  input  logic        b_i,
  input  logic        home_i,   // set home: the count becomes HomeCount (wins over a step)
  output logic [15:0] count_o,  // two's complement counts, wraps at +-32768 (+-327 deg)
  output logic        error_o,
  output logic        rising_o   // the last step was up (set at reset)
);
  logic [1:0]  previous_q;
  logic [15:0] count_q, count_d;
  logic        error_d, error_q;
  logic        rising_d, rising_q;

  always_comb begin
    count_d  = count_q;
    error_d  = 1'b0;
    rising_d = rising_q;
    // {A, B} in Gray order 00 -> 10 -> 11 -> 01 -> 00 (A leads B) counts up.
    unique case ({previous_q, a_i, b_i})
      4'b00_10, 4'b10_11, 4'b11_01, 4'b01_00: begin
        count_d  = count_q + 16'd1;
        rising_d = 1'b1;
      end
      4'b00_01, 4'b01_11, 4'b11_10, 4'b10_00: begin
        count_d  = count_q - 16'd1;
        rising_d = 1'b0;
      end
      4'b00_11, 4'b11_00, 4'b01_10, 4'b10_01: error_d = 1'b1;
      default: ;  // no change
    endcase
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      previous_q <= 2'b00;
      error_q    <= 1'b0;
      rising_q   <= 1'b1;
    end else begin
      previous_q <= {a_i, b_i};
      error_q    <= error_d;
      rising_q   <= rising_d;
    end
  end
  // The count loads HomeCount synchronously, at reset (released synchronously by the top) and on
  // home_i: the iCE40 flip-flops' synchronous set/reset do it, no logic cell per bit.
  always_ff @(posedge clk_i) begin
    if (!rst_ni || home_i) count_q <= HomeCount;
    else count_q <= count_d;
  end

  assign count_o = count_q;
  assign error_o = error_q;
  assign rising_o = rising_q;
`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // What the model board (host/cosim/model_board.cpp) relies on in its quiet clocks: lines that
  // show the state already taken change nothing. Environment: reset in the first cycle only.
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      if ({$past(a_i), $past(b_i)} == $past(previous_q) && !$past(home_i)) settled_lines_change_nothing: assert (
          count_q == $past(count_q) && rising_q == $past(rising_q) && !error_q && previous_q == $past(previous_q));
      settled_lines_change_nothing_c: cover ({$past(a_i), $past(b_i)} == $past(previous_q) && !$past(home_i) &&
          count_q != HomeCount && !rising_q);
    end
  end
`endif
endmodule
