// The three joints on the board: encoder counters, the 10 kHz control tick, joint_controller,
// the fault latch (joint_safety.sv) and the drive current commands (joint_pwm.sv).
//
// references_i are the joint references in Q24.8 encoder counts (reference_interpolator.sv),
// stable from each period start until the controller has copied them (6 cycles). Every
// ClocksPerPeriod cycles (10 kHz, tick_o == 0) the encoder counts are latched and the controller
// started (1072-cycle latency, see joint_controller.sv); each current command updates its PWM as
// soon as it is stored (joint_pwm.sv). The drives are on while enabled_i and no fault; a fault
// (joint_safety.sv) stops the torque and stays latched until clear_fault_i. home_i[j] sets joint
// j's encoder count to HomeCount. Board facts (clock, home count, limits, cause bits): delta_board_pkg.
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
  input  logic [2:0]  home_i,             // set home: count j := HomeCount
  input  logic [95:0] references_i,       // Q24.8 counts, joint j at [32j +: 32]
  input  logic        shift_write_i,      // the next period's play shift of joint shift_joint_i
  input  logic [1:0]  shift_joint_i,      //   (reference_interpolator, while the controller is idle)
  input  logic [delta_joint_pkg::ShiftBits-1:0] shift_i,
  input  logic        enabled_i,          // drives on (the board's enable state), closed loop
  input  logic        stop_i,             // a board cause latched (board_core): torque off as for a fault
  input  logic        jog_i,              // a bench jog runs: drives on, the PWM takes jog_currents_i
  input  logic        jog_override_i,     // the PWM takes jog_currents_i (a jog, and the clock after it)
  input  logic [47:0] jog_currents_i,     // open-loop currents, Q1.15 A, joint j at [16j +: 16]
  input  logic        frame_valid_i,      // a valid link frame arrived (watchdog)
  input  logic        clear_fault_i,      // clear the latched causes
  output logic [$clog2(ClocksPerPeriod)-1:0] tick_o,  // cycle within the control period
  output logic [47:0] counts_o,           // live encoder counts, joint j at [16j +: 16]
  output logic [2:0]  counts_rising_o,    // bit j: joint j's count last stepped up (quadrature_counter)
  input  logic [4:0]  peek_address_i,     // {joint, slot}: the controller's state of the last period
  output logic [31:0] peek_data_o,        //   one cycle later, while it is idle (board telemetry)
  output logic [2:0]  drive_pwm_o,
  output logic [2:0]  drive_dir_o,
  output logic        drive_enable_o,
  output logic [2:0]  encoder_error_o,    // sticky: a quadrature state was skipped
  output logic [15:0] overflow_count_o,   // the controller's saturation counter
  output logic        fault_o,            // latched: torque off
  output logic [delta_board_pkg::FaultCauseBits-1:0] fault_cause_o,  // latched causes (joint_safety.sv)
  output logic        fault_active_o      // a following or travel condition persists
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
      .home_i (home_i[j]),
      .count_o (counts[16 * j +: 16]),
      .error_o (step_error[j]),
      .rising_o(counts_rising_o[j])
    );
  end

  // ---- control tick and latched inputs --------------------------------------------------------
  logic [TickWidth-1:0] tick_q;
  logic        start_q;
  logic [47:0] counts_q;
  logic [2:0]  encoder_error_q;
  logic        ap_done, ap_idle, ap_ready;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      tick_q          <= '0;
      start_q         <= 1'b0;
      counts_q        <= '0;
      encoder_error_q <= '0;
    end else begin
      tick_q          <= tick_q == TickWidth'(ClocksPerPeriod - 1) ? '0 : tick_q + 1'b1;
      encoder_error_q <= encoder_error_q | step_error;
      // ap_start stays high until ap_ready; the counts are latched at the tick and held.
      if (ap_ready) start_q <= 1'b0;
      if (tick_q == '0 && ap_idle) begin
        start_q  <= 1'b1;
        counts_q <= counts;
      end
    end
  end
  assign tick_o   = tick_q;
  assign counts_o = counts;

  logic [95:0] references;
  assign references = references_i;

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
    .frame_valid_i,
    .enabled_i,
    .clear_i            (clear_fault_i),
    .references_i       (references),
    .counts_i           (counts_q),
    .fault_o            (fault),
    .fault_cause_o,
    .active_o           (fault_active_o)
  );

  // ---- controller -----------------------------------------------------------------------------
  // With the drives off the controller still runs (the telemetry reads its reference, count and
  // current) but restarts from rest every period: a one-cycle reset in the period's last cycle
  // (it is idle then). No state winds up while no current flows, and the period the drives come
  // on starts from rest at its own input (reference = encoder): no jump at enable.
  logic controller_reset;
  assign controller_reset = !rst_ni || (!enabled_i && tick_q == TickWidth'(ClocksPerPeriod - 1));

  logic [47:0] currents;
  logic [2:0]  current_valid, limited;

  joint_controller u_controller (
    .ap_clk          (clk_i),
    .ap_rst          (controller_reset),
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
    .overflow_count  (overflow_count_o),
    .peek_address    (peek_address_i),
    .peek_data       (peek_data_o),
    .shift_write     (shift_write_i),
    .shift_joint     (shift_joint_i),
    .shift_value     (shift_i)
  );

  // ---- PWM and drive enable ----------------------------------------------------------------------
  // A bench jog (board_core) overrides the controllers' currents every clock while it runs and in
  // the clock after it (then zero: no stale duty when the drives come on again); the controllers
  // run on with enabled_i low meanwhile. A board cause stops the torque as a joint fault does.
  logic [47:0] pwm_currents;
  logic [2:0]  pwm_current_valid;
  assign pwm_currents      = jog_override_i ? jog_currents_i : currents;
  assign pwm_current_valid = jog_override_i ? 3'b111 : current_valid;
  joint_pwm u_pwm (
    .clk_i,
    .rst_ni,
    .currents_i     (pwm_currents),
    .current_valid_i(pwm_current_valid),
    .enabled_i      (enabled_i || jog_i),
    .fault_i        (fault || stop_i),
    .drive_pwm_o,
    .drive_dir_o,
    .drive_enable_o
  );
  assign fault_o         = fault;
  assign encoder_error_o = encoder_error_q;

  logic unused;
  assign unused = ^{ap_done, limited};
`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // What the model board (host/cosim/model_board.cpp) relies on: the counts the safety check and
  // the controllers read are latched only at a period start. Environment: reset in the first cycle.
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      if (counts_q != $past(counts_q)) the_latched_counts_change_only_at_a_period_start: assert (
          $past(tick_q) == '0 && $past(ap_idle) && counts_q == $past(counts));
      the_latched_counts_change_only_at_a_period_start_c: cover (counts_q != $past(counts_q));
    end
  end
`endif
endmodule
