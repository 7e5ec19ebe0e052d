// The board's joint fault latch: decides, from the period's latched inputs, whether to stop the
// torque, and keeps the causes until a clear (clear_i, which the board gives only when
// active_o is low) or reset; clearing never turns the drives back on (the board's enable does).
//
// Causes (fault_cause_o, bit numbers in delta_board_pkg): FaultEncoderSkip, an encoder skipped a
// quadrature state (step_error_i, any cycle); FaultFollowing, reference - encoder count outside
// -2^FollowingBits .. 2^FollowingBits - 1 counts at a period start; FaultWatchdog, drives on and
// no valid link frame (frame_valid_i) for WatchdogPeriods periods; FaultTravel, a reference outside the travel, blocks
// MinTravelBlock..MaxTravelBlock of 1024 counts. Following and travel are checked with the drives
// on; active_o says whether either condition holds in the last period whatever the drives (a
// clear is refused then). They use the period's values and decide two cycles after period_start_i (the difference and the travel flag are
// registered: on a full device the reference conversion and the difference are two carry chains).
module joint_safety #(
  parameter int unsigned FollowingBits   = delta_board_pkg::FollowingBits,
  parameter int unsigned WatchdogPeriods = delta_board_pkg::WatchdogPeriods,
  parameter int          MinTravelBlock  = delta_board_pkg::MinTravelBlock,
  parameter int          MaxTravelBlock  = delta_board_pkg::MaxTravelBlock
) (
  input  logic        clk_i,
  input  logic        rst_ni,
  input  logic        tick_i,               // a control period starts (every ClocksPerPeriod cycles)
  input  logic        period_start_i,       // the controller starts on the latched inputs below
  input  logic [2:0]  step_error_i,         // encoder j skipped a state this cycle
  input  logic        frame_valid_i,        // a valid link frame arrived this cycle (watchdog)
  input  logic        enabled_i,            // drives on: watchdog, following and travel armed
  input  logic        clear_i,              // clear the latched causes
  input  logic [95:0] references_i,         // the period's references, Q24.8 counts, joint j at [32j +: 32]
  input  logic [47:0] counts_i,             // latched encoder counts, joint j at [16j +: 16]
  output logic        fault_o,              // latched: torque off
  output logic [delta_board_pkg::FaultCauseBits-1:0] fault_cause_o,
  output logic        active_o              // following or travel condition in the last period
);
  localparam int unsigned WatchdogWidth = $clog2(WatchdogPeriods + 2);
  localparam int unsigned CauseBits     = delta_board_pkg::FaultCauseBits;

  logic [WatchdogWidth-1:0] silent_periods_q;  // periods since the last reference
  logic                     check_q;           // the cycle after a start: latched values ready
  logic                     checked_q;         // the next: differences and flags registered
  logic [CauseBits-1:0]     fault_cause_q;
  logic [2:0]               following, outside;

  // Cheap on a full device: the following error is a 17-bit difference whose bits from
  // FollowingBits up must be a sign extension (and the reference fits 16 bits when it is inside
  // the travel); the travel is checked on the reference's 1024-count blocks (its bits 23..10).
  for (genvar j = 0; j < 3; j++) begin : g_check
    logic signed [23:0] reference_count;
    logic signed [16:0] difference, difference_q;
    logic signed [13:0] block;
    logic               outside_q;
    assign reference_count = references_i[32 * j + 8 +: 24];
    assign difference      = reference_count[16:0] - {counts_i[16 * j + 15], counts_i[16 * j +: 16]};
    assign block           = reference_count[23:10];
    // Pipeline registers (no reset: read only when checked_q says they hold this period's values).
    always_ff @(posedge clk_i) begin
      difference_q <= difference;
      outside_q    <= block < 14'(MinTravelBlock) || block > 14'(MaxTravelBlock);
    end
    assign following[j] = difference_q[16:FollowingBits] != '0 && difference_q[16:FollowingBits] != '1;
    assign outside[j]   = outside_q;
    logic unused_low_bits;  // below the limit, and the reference's fraction (Q.8)
    assign unused_low_bits = ^{difference_q[FollowingBits-1:0], references_i[32 * j +: 8]};
  end

  logic [WatchdogWidth-1:0] silent_periods_d;
  logic [CauseBits-1:0]     fault_cause_d;
  always_comb begin
    silent_periods_d = silent_periods_q;
    if (frame_valid_i || !enabled_i) silent_periods_d = '0;
    else if (tick_i && silent_periods_q != '1) silent_periods_d = silent_periods_q + 1'b1;

    fault_cause_d = clear_i ? '0 : fault_cause_q;  // a cause in the same cycle still latches
    if (step_error_i != '0) fault_cause_d[delta_board_pkg::FaultEncoderSkip] = 1'b1;
    if (checked_q && enabled_i) begin
      if (following != '0) fault_cause_d[delta_board_pkg::FaultFollowing] = 1'b1;
      if (outside != '0) fault_cause_d[delta_board_pkg::FaultTravel] = 1'b1;
    end
    if (enabled_i && silent_periods_q > WatchdogWidth'(WatchdogPeriods)) begin
      fault_cause_d[delta_board_pkg::FaultWatchdog] = 1'b1;
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      silent_periods_q <= '0;
      check_q          <= 1'b0;
      checked_q        <= 1'b0;
      fault_cause_q    <= '0;
    end else begin
      silent_periods_q <= silent_periods_d;
      check_q          <= period_start_i;
      checked_q        <= check_q;
      fault_cause_q    <= fault_cause_d;
    end
  end

  // The conditions of the last checked period (following, travel), drives on or off.
  logic active_q;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) active_q <= 1'b0;
    else if (checked_q) active_q <= following != '0 || outside != '0;
  end
  assign active_o      = active_q;
  assign fault_o       = fault_cause_q != '0;
  assign fault_cause_o = fault_cause_q;
endmodule
