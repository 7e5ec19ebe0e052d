// UART receiver: 8 data bits, no parity, 1 stop bit (8N1), LSB first, idle high.
//
// Latency: data_valid_o pulses for one clk_i cycle half a bit after the middle of the stop bit
// (about 9.5 bit times after the start edge). A frame whose stop bit reads low is dropped and
// reported by a one-cycle frame_error_o pulse. rx_i is asynchronous: two flip-flops synchronise it.
module uart_rx #(
  parameter int unsigned ClocksPerBit = 104  // clk_i frequency / baud rate, e.g. 12 MHz / 115200
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
endmodule
