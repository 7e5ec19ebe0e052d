// iCEBreaker (iCE40UP5K-SG48) top: 12 MHz oscillator -> PLL -> board_core; pins in icebreaker.pcf.
//
// Clocks: the PLL makes NetworkClockHz from the 12 MHz pin (DivR/DivF/DivQ/FilterRange from
// `icepll -i 12 -o 46.5`: 12 MHz * (DivF + 1) / (DivR + 1) / 2^DivQ = 46.5 MHz) on port A for the
// network alone (92 cycles = 1.98 us, README.md), and half of it on port B (GENCLK_HALF,
// 23.25 MHz) for the rest of the board: UART link and the joint controllers, whose datapath
// routes at about 24 MHz. The frequencies the place and route checks are in icebreaker.pcf. Reset: held until the PLL locks and while the user button (active low)
// is pressed; asserted asynchronously, released synchronously in each clock domain.
module icebreaker_top #(
  parameter              MemDir      = ".",  // directory of the network's .mem files
  parameter logic [3:0]  DivR        = 4'd0,
  parameter logic [6:0]  DivF        = 7'd61,
  parameter logic [2:0]  DivQ        = 3'd4,
  parameter logic [2:0]  FilterRange = 3'd1,
  parameter int unsigned NetworkClockHz = delta_board_pkg::NetworkClockHz,  // what the PLL settings above make
  parameter int unsigned BaudRate      = delta_board_pkg::LinkBaud
) (
  input  logic       clk_12mhz_i,   // pin 35, 12 MHz oscillator
  input  logic       button_ni,     // pin 10, user button, low when pressed: reset
  input  logic       uart_rx_i,     // pin 6, from the FTDI's TXD (host -> FPGA)
  output logic       uart_tx_o,     // pin 9, to the FTDI's RXD (FPGA -> host)
  output logic       led_red_no,    // pin 11, low = on
  output logic       led_green_no,  // pin 37, low = on
  input  logic [2:0] encoder_a_i,   // PMOD1A pins 1, 3, 7 (4, 47, 3)
  input  logic [2:0] encoder_b_i,   // PMOD1A pins 2, 4, 8 (2, 45, 48)
  input  logic [2:0] home_switch_i, // P1A9, P1A10, P1B10 (46, 44, 28): home switch j, 1 = at or above the reference
  output logic [2:0] drive_pwm_o,   // PMOD1B pins 1, 3, 7 (43, 34, 42)
  output logic [2:0] drive_dir_o,   // PMOD1B pins 2, 4, 8 (38, 31, 36)
  output logic       drive_enable_no, // PMOD1B pin 9 (32), active low: low = drives enabled (the pull-up
                                      // before and during configuration reads disabled)
  // PMOD2, the safety connector (docs/bench.md); inputs pulled up (icebreaker.pcf): high = stop
  input  logic       estop_open_i,    // P2_9 (20): the e-stop chain is open
  input  logic [2:0] drive_fault_i,   // P2_1, P2_2, P2_4 (27, 25, 19): drive j reports a fault
  output logic       led_encoder_error_o, // P2_7 (26): an encoder skipped a state (sticky)
  output logic       led_joint_fault_o,   // P2_8 (23): a fault latched (the joints', the board's), torque off
  output logic       led_drive_enable_o,  // P2_3 (21): drives enabled (active high)
  output logic       stage_sync_o         // P2_10 (18): the board's time for a measuring stage to log
);
  logic clk_network, clk, pll_locked;  // port A, port B (half)

  SB_PLL40_2F_PAD #(
    .FEEDBACK_PATH       ("SIMPLE"),
    .PLLOUT_SELECT_PORTA ("GENCLK"),
    .PLLOUT_SELECT_PORTB ("GENCLK_HALF"),
    .DIVR                (DivR),
    .DIVF                (DivF),
    .DIVQ                (DivQ),
    .FILTER_RANGE        (FilterRange)
  ) u_pll (
    .PACKAGEPIN     (clk_12mhz_i),
    .PLLOUTCOREA    (),
    .PLLOUTGLOBALA  (clk_network),
    .PLLOUTCOREB    (),
    .PLLOUTGLOBALB  (clk),
    .EXTFEEDBACK    (1'b0),
    .DYNAMICDELAY   (8'd0),
    .LOCK           (pll_locked),
    .BYPASS         (1'b0),
    .RESETB         (1'b1),
    .LATCHINPUTVALUE(1'b0),
    .SDO            (),
    .SDI            (1'b0),
    .SCLK           (1'b0)
  );

  // Asynchronous assertion, synchronous release, one synchroniser per clock domain.
  logic [1:0] reset_sync_q, network_reset_sync_q;
  always_ff @(posedge clk or negedge pll_locked) begin
    if (!pll_locked) reset_sync_q <= 2'b00;
    else reset_sync_q <= {reset_sync_q[0], button_ni};
  end
  always_ff @(posedge clk_network or negedge pll_locked) begin
    if (!pll_locked) network_reset_sync_q <= 2'b00;
    else network_reset_sync_q <= {network_reset_sync_q[0], button_ni};
  end
  wire rst_n         = reset_sync_q[1];
  wire rst_network_n = network_reset_sync_q[1];

  logic led_red, led_green;
  localparam int unsigned BoardClockHz = NetworkClockHz / 2;
  // Seen in simulation (tests, deltactl cosim); on the board the fault LED and the drive-enable
  // LED show what matters.
  logic       joint_limited, estop_latched, drive_enable;
  logic [2:0] encoder_error;
  logic [delta_board_pkg::FaultCauseBits-1:0] joint_fault_cause;
  logic [delta_board_pkg::BoardFaultBits-1:0] board_fault_cause;
  logic       stage_sync;
  board_core #(
    .ClocksPerBit   ((BoardClockHz + BaudRate / 2) / BaudRate),
    .ClocksPerPeriod(BoardClockHz / delta_board_pkg::ControlRateHz),
    .MemDir         (MemDir)
  ) u_core (
    .clk_i         (clk),
    .rst_ni        (rst_n),
    .clk_network_i (clk_network),
    .rst_network_ni(rst_network_n),
    .uart_rx_i,
    .uart_tx_o,
    .led_red_o  (led_red),
    .led_green_o(led_green),
    .encoder_a_i,
    .encoder_b_i,
    .home_switch_i,
    .estop_open_i,
    .drive_fault_i,
    .drive_pwm_o,
    .drive_dir_o,
    .drive_enable_o     (drive_enable),
    .encoder_error_o    (encoder_error),
    .joint_limited_o    (joint_limited),
    .joint_fault_o      (led_joint_fault_o),
    .joint_fault_cause_o(joint_fault_cause),
    .board_fault_cause_o(board_fault_cause),
    .estop_latched_o    (estop_latched),
    .stage_sync_o       (stage_sync)
  );
  // The stage sync output leaves through the pin's own output register (PIN_TYPE 0101_01, the
  // input side unused): no logic cell, and an edge a clock after period_count_q's. Verilator (the
  // lint) cannot take the cell model's inout pin at the top: there the pin is the signal itself.
`ifdef VERILATOR
  assign stage_sync_o = stage_sync;
`else
  SB_IO #(.PIN_TYPE(6'b0101_01)) u_stage_sync_io (
    .PACKAGE_PIN(stage_sync_o),
    .OUTPUT_CLK (clk),
    .D_OUT_0    (stage_sync)
  );
`endif
  logic       unused_status;
  assign unused_status = ^{joint_limited, joint_fault_cause, board_fault_cause, estop_latched};
  assign drive_enable_no     = !drive_enable;
  assign led_drive_enable_o  = drive_enable;
  assign led_encoder_error_o = encoder_error != '0;
  assign led_red_no   = !led_red;
  assign led_green_no = !led_green;
endmodule
