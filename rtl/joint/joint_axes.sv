// The three joints on the board: encoder counters, the 10 kHz control tick, joint_controller,
// the fault latch (joint_safety.sv) and the drive current commands (joint_pwm.sv).
//
// references_i are the network's outputs (degrees, Q10.14, 24 bits each, joint j at [24j +: 24]),
// held by the caller and refreshed with reference_valid_i. Until the first reference arrives the
// controller holds each joint where its encoder is and drive_enable_o stays low. Every
// ClocksPerPeriod cycles (10 kHz) the encoder counts and references are latched and the
// controller started (892-cycle latency, see joint_controller.sv); each current command updates
// its PWM as soon as it is stored (joint_pwm.sv). A fault (joint_safety.sv) stops the torque and
// stays latched until reset. Board facts (clock, home count, limits, cause bits): delta_board_pkg.
module joint_axes #(
  parameter int unsigned ClocksPerPeriod = delta_board_pkg::ClocksPerPeriod,  // clk_i / 10 kHz
  parameter logic [15:0] HomeCount       = 16'(delta_board_pkg::HomeCount),   // encoder count at reset
  parameter int unsigned FollowingBits   = delta_board_pkg::FollowingBits,
  parameter int unsigned WatchdogPeriods = delta_board_pkg::WatchdogPeriods,
  parameter int          MinTravelBlock  = delta_board_pkg::MinTravelBlock,
  parameter int          MaxTravelBlock  = delta_board_pkg::MaxTravelBlock
) (
  input  logic        clk_i,
  input  logic        rst_ni,
  input  logic [2:0]  encoder_a_i,        // synchronised to clk_i
  input  logic [2:0]  encoder_b_i,
  input  logic [71:0] references_i,       // degrees, Q10.14
  input  logic        reference_valid_i,
  output logic [2:0]  drive_pwm_o,
  output logic [2:0]  drive_dir_o,
  output logic        drive_enable_o,
  output logic [2:0]  encoder_error_o,    // sticky: a quadrature state was skipped
  output logic [15:0] overflow_count_o,   // the controller's saturation counter
  output logic        fault_o,            // latched: torque off
  output logic [delta_board_pkg::FaultCauseBits-1:0] fault_cause_o  // latched causes (joint_safety.sv)
);
  localparam int unsigned TickWidth = $clog2(ClocksPerPeriod);

  // ---- encoders -------------------------------------------------------------------------------
  logic [47:0] counts;
  logic [2:0]  step_error;
  for (genvar j = 0; j < 3; j++) begin : g_encoder
    quadrature_counter #(.HomeCount(HomeCount)) u_counter (
      .clk_i,
      .rst_ni,
      .a_i    (encoder_a_i[j]),
      .b_i    (encoder_b_i[j]),
      .count_o(counts[16 * j +: 16]),
      .error_o(step_error[j])
    );
  end

  // ---- control tick and latched inputs --------------------------------------------------------
  logic [TickWidth-1:0] tick_q;
  logic        start_q, referenced_q, reference_latched_q;
  logic [47:0] counts_q;
  logic [71:0] references_q;
  logic [2:0]  encoder_error_q;
  logic        ap_done, ap_idle, ap_ready;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      tick_q          <= '0;
      start_q         <= 1'b0;
      referenced_q    <= 1'b0;
      reference_latched_q <= 1'b0;
      counts_q        <= '0;
      references_q    <= '0;
      encoder_error_q <= '0;
    end else begin
      tick_q          <= tick_q == TickWidth'(ClocksPerPeriod - 1) ? '0 : tick_q + 1'b1;
      encoder_error_q <= encoder_error_q | step_error;
      if (reference_valid_i) referenced_q <= 1'b1;
      // ap_start stays high until ap_ready; the inputs are latched at the tick and held.
      if (ap_ready) start_q <= 1'b0;
      // Whether this period uses the network's reference is latched with the reference itself:
      // a reference_valid_i arriving while the controller copies its inputs must not pair the
      // new flag with the old (zero) reference (that would command 0 deg for one period).
      if (tick_q == '0 && ap_idle) begin
        start_q             <= 1'b1;
        counts_q            <= counts;
        references_q        <= references_i;
        reference_latched_q <= referenced_q;
      end
    end
  end

  // Reference in Q24.8 encoder counts: degrees x 25600 = raw x 2^14 x 25 / 16, exact after the
  // rounding: round_shift(25 * raw, 4). Before the first reference: the encoder count itself.
  function automatic logic [31:0] reference_code(logic [23:0] raw);
    logic [28:0] rounded;
    rounded = {{5{raw[23]}}, raw} + {{2{raw[23]}}, raw, 3'b000} + {{1{raw[23]}}, raw, 4'b0000} + 29'd8;
    reference_code = 32'($signed({{3{rounded[28]}}, rounded}) >>> 4);
  endfunction

  logic [95:0] references;
  for (genvar j = 0; j < 3; j++) begin : g_reference
    assign references[32 * j +: 32] = reference_latched_q ? reference_code(references_q[24 * j +: 24])
                                                   : {{8{counts_q[16 * j + 15]}}, counts_q[16 * j +: 16], 8'd0};
  end

  // ---- faults ------------------------------------------------------------------------------------
  logic fault;
  joint_safety #(
    .FollowingBits  (FollowingBits),
    .WatchdogPeriods(WatchdogPeriods),
    .MinTravelBlock (MinTravelBlock),
    .MaxTravelBlock (MaxTravelBlock)
  ) u_safety (
    .clk_i,
    .rst_ni,
    .tick_i             (tick_q == '0),
    .period_start_i     (tick_q == '0 && ap_idle),
    .step_error_i       (step_error),
    .reference_valid_i,
    .referenced_i       (referenced_q),
    .reference_latched_i(reference_latched_q),
    .references_i       (references),
    .counts_i           (counts_q),
    .fault_o            (fault),
    .fault_cause_o
  );

  // ---- controller -----------------------------------------------------------------------------
  logic [47:0] currents;
  logic [2:0]  current_valid, limited;

  joint_controller u_controller (
    .ap_clk          (clk_i),
    .ap_rst          (!rst_ni),
    .ap_start        (start_q),
    .ap_done,
    .ap_idle,
    .ap_ready,
    .reference_0     (references[31:0]),
    .reference_1     (references[63:32]),
    .reference_2     (references[95:64]),
    .encoder_0       (counts_q[15:0]),
    .encoder_1       (counts_q[31:16]),
    .encoder_2       (counts_q[47:32]),
    .current_0       (currents[15:0]),
    .current_0_ap_vld(current_valid[0]),
    .current_1       (currents[31:16]),
    .current_1_ap_vld(current_valid[1]),
    .current_2       (currents[47:32]),
    .current_2_ap_vld(current_valid[2]),
    .limited,
    .overflow_count  (overflow_count_o)
  );

  // ---- PWM and drive enable ----------------------------------------------------------------------
  joint_pwm u_pwm (
    .clk_i,
    .rst_ni,
    .currents_i     (currents),
    .current_valid_i(current_valid),
    .referenced_i   (referenced_q),
    .fault_i        (fault),
    .drive_pwm_o,
    .drive_dir_o,
    .drive_enable_o
  );
  assign fault_o         = fault;
  assign encoder_error_o = encoder_error_q;

  logic unused;
  assign unused = ^{ap_done, limited};
endmodule
