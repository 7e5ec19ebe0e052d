// Everything on the iCEBreaker except the PLL and the pads: UART link to the host, the network,
// and the joint I/O (three quadrature encoders in, three drive current commands out).
//
// Data path: host UART request (positions as raw input codes) -> network_uart_link -> network
// (ap_ctrl_hs) -> response (joint references as raw output codes). See network_uart_link.sv for
// the frame format and README.md for the host side.
//
// Joint controllers (issue 6) plug in at the marked place below: they take encoder_a_i/b_i
// (already synchronised here), the network's joint references (references_q, updated with
// reference_valid_q), and drive drive_pwm_o/drive_dir_o/drive_enable_o. Until then the drive
// outputs are held off (enable low, no PWM).
module board_core #(
  parameter int unsigned ClocksPerBit = 404,  // clk_i / UART baud rate (46.5 MHz / 115200)
  parameter              MemDir       = "."   // directory of the network's .mem files (synthesis)
) (
  input  logic       clk_i,
  input  logic       rst_ni,
  input  logic       uart_rx_i,
  output logic       uart_tx_o,
  output logic       led_red_o,       // a request was rejected (checksum or range), held ~0.4 s
  output logic       led_green_o,     // a request was answered, held ~0.4 s
  input  logic [2:0] encoder_a_i,     // quadrature encoders, asynchronous
  input  logic [2:0] encoder_b_i,
  output logic [2:0] drive_pwm_o,     // drive current command: PWM duty = |current|
  output logic [2:0] drive_dir_o,     // drive current command: sign
  output logic       drive_enable_o
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

  logic                                 net_start, net_done, net_idle, net_ready;
  logic [NumInputs*InputWidth-1:0]      net_inputs;
  logic [NumOutputs*OutputWidth-1:0]    net_outputs;
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

  // ---- the network ------------------------------------------------------------------------
  logic [NumOutputs-1:0] net_output_valid;

  delta_network #(.MemDir(MemDir)) u_network (
    .ap_clk      (clk_i),
    .ap_rst      (!rst_ni),
    .ap_start    (net_start),
    .ap_done     (net_done),
    .ap_idle     (net_idle),
    .ap_ready    (net_ready),
    .x_0         (net_inputs[0*InputWidth +: InputWidth]),
    .x_1         (net_inputs[1*InputWidth +: InputWidth]),
    .x_2         (net_inputs[2*InputWidth +: InputWidth]),
    .y_0         (net_outputs[0*OutputWidth +: OutputWidth]),
    .y_0_ap_vld  (net_output_valid[0]),
    .y_1         (net_outputs[1*OutputWidth +: OutputWidth]),
    .y_1_ap_vld  (net_output_valid[1]),
    .y_2         (net_outputs[2*OutputWidth +: OutputWidth]),
    .y_2_ap_vld  (net_output_valid[2])
  );

  // Joint references for the joint controllers: the last answer, held.
  logic [NumOutputs*OutputWidth-1:0] references_q;
  logic                              reference_valid_q;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      references_q      <= '0;
      reference_valid_q <= 1'b0;
    end else begin
      reference_valid_q <= net_done;
      if (net_done) references_q <= net_outputs;
    end
  end

  // ---- joint I/O ----------------------------------------------------------------------------
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

  // >>> Joint controllers (issue 6) go here: inputs encoder_a_q, encoder_b_q, references_q,
  // reference_valid_q; outputs drive_pwm_o, drive_dir_o, drive_enable_o. Until then: drives off.
  assign drive_pwm_o    = 3'b000;
  assign drive_dir_o    = 3'b000;
  assign drive_enable_o = 1'b0;
  logic unused_joint_inputs;
  assign unused_joint_inputs = ^{encoder_a_q, encoder_b_q, references_q, reference_valid_q,
                                 net_idle, net_output_valid, rx_frame_error};

  // ---- status LEDs --------------------------------------------------------------------------
  // Pulse stretchers: 2^24 cycles, about 0.36 s at 46.5 MHz. The pulses are registered first: the
  // link's decision logic and the counters' carry chains stay in separate cycles.
  logic [23:0] green_count_q, red_count_q;
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
