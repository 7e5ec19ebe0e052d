// Everything on the iCEBreaker except the PLL and the pads: UART link to the host, the network,
// and the three joint controllers (quadrature encoders in, drive current commands out).
//
// Data path: host UART request (positions as raw input codes) -> network_uart_link ->
// network_crossing -> network (ap_ctrl_hs) -> back: response (joint references as raw output
// codes) to the host, and the same references to joint_axes (10 kHz controllers, PWM +
// direction). See network_uart_link.sv for the frame format and README.md for the host side.
//
// Two clocks from one PLL. clk_network_i (46.5 MHz) runs the network alone: its 92-cycle latency
// is 1.98 us there. clk_i (half of it, 23.25 MHz) runs everything else: UART, link, LEDs,
// encoders, joint controllers (their datapath routes at about 24 MHz, rtl/joint/README.md) and
// PWM. network_crossing is the only place where signals cross (a toggle handshake each way).
module board_core #(
  // Defaults: the board's facts (delta_board_pkg.sv); the Verilated test build overrides the
  // first two with SimClocksPerBit and SimClocksPerPeriod.
  parameter int unsigned ClocksPerBit    = delta_board_pkg::ClocksPerBit,     // clk_i / UART baud rate
  parameter int unsigned ClocksPerPeriod = delta_board_pkg::ClocksPerPeriod,  // clk_i / 10 kHz
  parameter int unsigned LedHoldBits     = delta_board_pkg::LedHoldBits,      // LED pulses: 2^LedHoldBits cycles
  parameter logic [15:0] HomeCount       = 16'(delta_board_pkg::HomeCount),   // encoder counts at reset
  parameter              MemDir          = "."  // directory of the network's .mem files (synthesis)
) (
  input  logic       clk_i,           // board clock: UART, link, joints
  input  logic       rst_ni,          // asynchronous assertion, synchronous release in clk_i
  input  logic       clk_network_i,   // the network's clock
  input  logic       rst_network_ni,  // asynchronous assertion, synchronous release in clk_network_i
  input  logic       uart_rx_i,
  output logic       uart_tx_o,
  output logic       led_red_o,       // a request was rejected (checksum or range), held ~0.36 s
  output logic       led_green_o,     // a request was answered, held ~0.36 s
  input  logic [2:0] encoder_a_i,     // quadrature encoders, asynchronous
  input  logic [2:0] encoder_b_i,
  output logic [2:0] drive_pwm_o,     // drive current command: PWM duty = |current| / 0.5 A
  output logic [2:0] drive_dir_o,     // drive current command: sign (1 = negative)
  output logic       drive_enable_o,  // low until the first network answer
  output logic [2:0] encoder_error_o, // sticky: encoder j skipped a quadrature state
  output logic       joint_limited_o, // sticky: a joint controller saturated an operand or state
  output logic       joint_fault_o,   // latched until reset: torque off (joint_axes.sv, "Safety")
  output logic [delta_board_pkg::FaultCauseBits-1:0] joint_fault_cause_o  // bits: delta_board_pkg::Fault*
);
  // Network formats (yosys 0.23 reads no `import`: qualified names only).
  localparam int unsigned NumInputs   = delta_network_pkg::NumInputs;
  localparam int unsigned NumOutputs  = delta_network_pkg::NumOutputs;
  localparam int unsigned InputWidth  = delta_network_pkg::InputWidth;
  localparam int unsigned OutputWidth = delta_network_pkg::OutputWidth;

  // ---- UART and framing -------------------------------------------------------------------
  logic [7:0] rx_data, tx_data;
  logic       rx_valid, rx_frame_error, tx_valid, tx_ready;

  uart_rx #(.ClocksPerBit(ClocksPerBit)) u_uart_rx (
    .clk_i,
    .rst_ni,
    .rx_i         (uart_rx_i),
    .data_o       (rx_data),
    .data_valid_o (rx_valid),
    .frame_error_o(rx_frame_error)
  );

  uart_tx #(.ClocksPerBit(ClocksPerBit)) u_uart_tx (
    .clk_i,
    .rst_ni,
    .data_i      (tx_data),
    .data_valid_i(tx_valid),
    .data_ready_o(tx_ready),
    .tx_o        (uart_tx_o)
  );

  logic                                 net_start, net_done, net_ready;
  logic [NumInputs*InputWidth-1:0]      net_inputs;
  logic [NumOutputs*OutputWidth-1:0]    net_outputs;  // the last answer, held
  logic                                 answered, rejected;

  network_uart_link #(
    .Inputs     (NumInputs),
    .Outputs    (NumOutputs),
    .InputWidth (InputWidth),
    .OutputWidth(OutputWidth)
  ) u_link (
    .clk_i,
    .rst_ni,
    .rx_data_i (rx_data),
    .rx_valid_i(rx_valid),
    .tx_data_o (tx_data),
    .tx_valid_o(tx_valid),
    .tx_ready_i(tx_ready),
    .start_o   (net_start),
    .ready_i   (net_ready),
    .done_i    (net_done),
    .inputs_o  (net_inputs),
    .outputs_i (net_outputs),
    .answered_o(answered),
    .rejected_o(rejected)
  );

  // ---- the network, on its own clock behind the crossing ----------------------------------------
  logic                              net_clk_start, net_clk_ready, net_clk_done;
  logic [NumInputs*InputWidth-1:0]   net_clk_inputs;
  logic [NumOutputs*OutputWidth-1:0] net_clk_outputs;
  logic                              net_idle;
  logic [NumOutputs-1:0]             net_output_valid;

  network_crossing #(
    .InputBits (NumInputs * InputWidth),
    .OutputBits(NumOutputs * OutputWidth)
  ) u_crossing (
    .clk_i,
    .rst_ni,
    .start_i       (net_start),
    .ready_o       (net_ready),
    .done_o        (net_done),
    .inputs_i      (net_inputs),
    .outputs_o     (net_outputs),
    .clk_network_i,
    .rst_network_ni,
    .net_start_o   (net_clk_start),
    .net_ready_i   (net_clk_ready),
    .net_done_i    (net_clk_done),
    .net_inputs_o  (net_clk_inputs),
    .net_outputs_i (net_clk_outputs)
  );
  delta_network #(.MemDir(MemDir)) u_network (
    .ap_clk      (clk_network_i),
    .ap_rst      (!rst_network_ni),
    .ap_start    (net_clk_start),
    .ap_done     (net_clk_done),
    .ap_idle     (net_idle),
    .ap_ready    (net_clk_ready),
    .x_0         (net_clk_inputs[0*InputWidth +: InputWidth]),
    .x_1         (net_clk_inputs[1*InputWidth +: InputWidth]),
    .x_2         (net_clk_inputs[2*InputWidth +: InputWidth]),
    .y_0         (net_clk_outputs[0*OutputWidth +: OutputWidth]),
    .y_0_ap_vld  (net_output_valid[0]),
    .y_1         (net_clk_outputs[1*OutputWidth +: OutputWidth]),
    .y_1_ap_vld  (net_output_valid[1]),
    .y_2         (net_clk_outputs[2*OutputWidth +: OutputWidth]),
    .y_2_ap_vld  (net_output_valid[2])
  );

  // ---- joint I/O ------------------------------------------------------------------------------
  // Two-flip-flop synchronisers for the asynchronous encoder inputs.
  logic [2:0] encoder_a_meta_q, encoder_a_q, encoder_b_meta_q, encoder_b_q;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      encoder_a_meta_q <= 3'b000;
      encoder_a_q      <= 3'b000;
      encoder_b_meta_q <= 3'b000;
      encoder_b_q      <= 3'b000;
    end else begin
      encoder_a_meta_q <= encoder_a_i;
      encoder_a_q      <= encoder_a_meta_q;
      encoder_b_meta_q <= encoder_b_i;
      encoder_b_q      <= encoder_b_meta_q;
    end
  end

  // ---- the three joint controllers: references = the network's last answer ---------------------
  logic [15:0] joint_overflow_count;
  joint_axes #(
    .ClocksPerPeriod(ClocksPerPeriod),
    .HomeCount      (HomeCount)
  ) u_joint_axes (
    .clk_i,
    .rst_ni,
    .encoder_a_i      (encoder_a_q),
    .encoder_b_i      (encoder_b_q),
    .references_i     (net_outputs),
    .reference_valid_i(net_done),
    .drive_pwm_o,
    .drive_dir_o,
    .drive_enable_o,
    .encoder_error_o,
    .overflow_count_o (joint_overflow_count),
    .fault_o          (joint_fault_o),
    .fault_cause_o    (joint_fault_cause_o)
  );
  assign joint_limited_o = joint_overflow_count != '0;

  logic unused_status;
  assign unused_status = ^{net_idle, net_output_valid, rx_frame_error};

  // ---- status LEDs --------------------------------------------------------------------------
  // Pulse stretchers: 2^LedHoldBits cycles, about 0.36 s at 23.25 MHz. The pulses are registered first: the
  // link's decision logic and the counters' carry chains stay in separate cycles.
  logic [LedHoldBits-1:0] green_count_q, red_count_q;
  logic        answered_q, rejected_q;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      answered_q    <= 1'b0;
      rejected_q    <= 1'b0;
      green_count_q <= '0;
      red_count_q   <= '0;
    end else begin
      answered_q <= answered;
      rejected_q <= rejected;
      if (answered_q) green_count_q <= '1;
      else if (green_count_q != '0) green_count_q <= green_count_q - 1'b1;
      if (rejected_q) red_count_q <= '1;
      else if (red_count_q != '0) red_count_q <= red_count_q - 1'b1;
    end
  end
  assign led_green_o = (green_count_q != '0);
  assign led_red_o   = (red_count_q != '0);
endmodule
