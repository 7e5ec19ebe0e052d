// The three joints on the board: encoder counters, the 10 kHz control tick, joint_controller,
// and the drive current commands as PWM magnitude + direction.
//
// references_i are the network's outputs (degrees, Q10.14, 24 bits each, joint j at [24j +: 24]),
// held by the caller and refreshed with reference_valid_i. Until the first reference arrives the
// controller holds each joint where its encoder is and drive_enable_o stays low. Every
// ClocksPerPeriod cycles (10 kHz at the default 24 MHz) the encoder counts and references are
// latched and the controller started (892-cycle latency, see joint_controller.sv); each current
// command updates its PWM as soon as it is stored. PWM: period 2^PwmBits cycles (23.4 kHz at
// 24 MHz and 10 bits), duty = |current| / 0.5 A (the current limit), direction = sign.
//
// Safety: a fault stops the torque (drive_enable_o low, every PWM output low, both registered)
// and stays latched until reset. Causes (fault_cause_o): [0] an encoder skipped a quadrature
// state; [1] following error: reference - encoder count outside -2^FollowingBits ..
// 2^FollowingBits - 1 counts at a period start; [2] watchdog: a referenced controller got no new
// reference for WatchdogPeriods periods (the host must keep streaming, the hold position
// included); [3] a reference outside the travel, blocks MinBlock..MaxBlock of 1024 counts. [1]
// and [3] use the period's latched values and decide two cycles after the tick.
module joint_axes #(
  parameter int unsigned ClocksPerPeriod = 2400,     // clk_i / 10 kHz (2400 at 24 MHz, 2325 on the board: 23.25 MHz)
  parameter logic [15:0] HomeCount       = 16'd3000, // encoder count at reset (30.00 deg)
  parameter int unsigned FollowingBits   = 9,        // following limit 2^9 = 512 counts (5.12 deg)
  parameter int unsigned WatchdogPeriods = 500,      // control periods (50 ms at 10 kHz)
  parameter int          MinBlock        = -1,       // reference travel in 1024-count blocks:
  parameter int          MaxBlock        = 8         //   -1024 .. 9215 counts (-10.24 .. 92.15 deg)
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
  output logic [3:0]  fault_cause_o       // latched causes, see above
);
  localparam int unsigned PwmBits   = 10;
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
  localparam int unsigned WatchdogWidth = $clog2(WatchdogPeriods + 2);
  logic [WatchdogWidth-1:0] silent_periods_q;  // periods since the last reference
  logic                     check_q;           // the cycle after a start: latched values ready
  logic                     checked_q;         // the next: differences and flags registered
  logic [3:0]               fault_cause_q;
  logic [2:0]               following, outside;
  // Cheap on a full device: the following error is a 17-bit difference whose bits from
  // FollowingBits up must be a sign extension (-2^FollowingBits .. 2^FollowingBits - 1, and the
  // reference fits 16 bits when it is inside the travel), and the travel is checked on the
  // reference's 1024-count blocks (its bits 23..10).
  // The reference conversion and the difference are two carry chains: the difference and the
  // travel flag are registered (the flip-flops share the subtractor's logic cells), and the
  // fault decides a cycle later (check_q, then checked_q).
  for (genvar j = 0; j < 3; j++) begin : g_check
    logic signed [23:0] reference_count;
    logic signed [16:0] difference, difference_q;
    logic signed [13:0] block;
    logic               outside_q;
    assign reference_count = references[32 * j + 8 +: 24];
    assign difference      = reference_count[16:0] - {counts_q[16 * j + 15], counts_q[16 * j +: 16]};
    assign block           = reference_count[23:10];
    always_ff @(posedge clk_i) begin
      difference_q <= difference;
      outside_q    <= block < 14'(MinBlock) || block > 14'(MaxBlock);
    end
    assign following[j] = difference_q[16:FollowingBits] != '0 && difference_q[16:FollowingBits] != '1;
    assign outside[j]   = outside_q;
    logic unused_low_bits;
    assign unused_low_bits = ^difference_q[FollowingBits-1:0];
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      silent_periods_q <= '0;
      check_q          <= 1'b0;
      checked_q        <= 1'b0;
      fault_cause_q    <= '0;
    end else begin
      check_q   <= tick_q == '0 && ap_idle;
      checked_q <= check_q;
      if (reference_valid_i) silent_periods_q <= '0;
      else if (tick_q == '0 && silent_periods_q != '1) silent_periods_q <= silent_periods_q + 1'b1;
      fault_cause_q[0] <= fault_cause_q[0] || step_error != '0;
      if (checked_q && reference_latched_q) begin
        fault_cause_q[1] <= fault_cause_q[1] || following != '0;
        fault_cause_q[3] <= fault_cause_q[3] || outside != '0;
      end
      fault_cause_q[2] <= fault_cause_q[2] ||
                          (referenced_q && silent_periods_q > WatchdogWidth'(WatchdogPeriods));
    end
  end
  wire fault = fault_cause_q != '0;

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

  // ---- PWM --------------------------------------------------------------------------------------
  logic [PwmBits-1:0] pwm_phase_q;
  logic [3*(PwmBits+1)-1:0] duty_q;  // 0 .. 2^PwmBits (= 100 %)
  logic [2:0] direction_q;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      pwm_phase_q <= '0;
      duty_q      <= '0;
      direction_q <= '0;
    end else begin
      pwm_phase_q <= pwm_phase_q + 1'b1;
      for (int j = 0; j < 3; j++) begin
        if (current_valid[j]) begin
          // |current| <= 16384 (0.5 A) -> duty <= 1024; the limit keeps 16'(-x) exact.
          duty_q[(PwmBits + 1) * j +: PwmBits + 1] <=
              11'((currents[16 * j + 15] ? 16'(-currents[16 * j +: 16]) : currents[16 * j +: 16]) >> 4);
          direction_q[j] <= currents[16 * j + 15];
        end
      end
    end
  end

  // Outputs registered (the fault gate included): glitch-free pins.
  logic [2:0] pwm_q;
  logic       enable_q;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      pwm_q    <= '0;
      enable_q <= 1'b0;
    end else begin
      for (int j = 0; j < 3; j++) begin
        pwm_q[j] <= !fault && ({1'b0, pwm_phase_q} < duty_q[(PwmBits + 1) * j +: PwmBits + 1]);
      end
      enable_q <= referenced_q && !fault;
    end
  end
  assign drive_pwm_o     = pwm_q;
  assign drive_dir_o     = direction_q;
  assign drive_enable_o  = enable_q;
  assign fault_o         = fault;
  assign fault_cause_o   = fault_cause_q;
  assign encoder_error_o = encoder_error_q;

  logic unused;
  assign unused = ^{ap_done, limited};
endmodule
