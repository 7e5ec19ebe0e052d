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

  // a < b (unsigned) with one side constant, as bit logic: synthesis maps a comparison operator
  // to a carry chain, a cell per bit, where this folds into a few LUTs.
  function automatic logic unsigned_below(logic [31:0] a, logic [31:0] b);
    unsigned_below = 1'b0;
    for (int i = 0; i < 32; i++) if (a[i] != b[i]) unsigned_below = b[i];
  endfunction
  localparam logic [13:0] MinOffset = 14'(MinTravelBlock) ^ 14'h2000;
  localparam logic [13:0] MaxOffset = 14'(MaxTravelBlock) ^ 14'h2000;
  logic watchdog_expired;  // silent_periods_q > WatchdogPeriods
  assign watchdog_expired = unsigned_below(32'(WatchdogPeriods), 32'(silent_periods_q));

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
    logic [13:0] block_offset;
    assign block_offset = {~block[13], block[12:0]};
    // Pipeline registers (no reset: read only when checked_q says they hold this period's values).
    always_ff @(posedge clk_i) begin
      difference_q <= difference;
      outside_q    <= unsigned_below(32'(block_offset), 32'(MinOffset)) || unsigned_below(32'(MaxOffset), 32'(block_offset));
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
    if (enabled_i && watchdog_expired) begin
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

`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; the list and how to run them: docs/formal.md) ----
  // Environment: reset in the first cycle only; a period start is a tick (joint_axes). Every
  // other input is free: ticks may come every cycle, frames, enables and clears at any time.
  logic [1:0] f_cycles_q = 2'd0;  // saturating: $past(x) valid from 1, $past(x, 2) from 2
  logic       f_past_valid, f_past2_valid;
  always_ff @(posedge clk_i) if (f_cycles_q != 2'd3) f_cycles_q <= f_cycles_q + 2'd1;
  assign f_past_valid  = f_cycles_q != 2'd0;
  assign f_past2_valid = f_cycles_q[1];
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
    a_period_start_is_a_tick: assume (!period_start_i || tick_i);
  end

  // The specification of the checks, written independently of the pipeline above: the whole
  // reference (24 integer bits) against the count, and the travel in counts.
  localparam int FollowingLimit = 1 << FollowingBits;
  localparam int TravelLow      = MinTravelBlock * 1024;
  localparam int TravelHigh     = (MaxTravelBlock + 1) * 1024;  // first count outside
  logic [2:0] f_following, f_outside;
  for (genvar j = 0; j < 3; j++) begin : g_spec
    logic signed [31:0] f_reference, f_count, f_difference;
    assign f_reference    = 32'($signed(references_i[32 * j + 8 +: 24]));
    assign f_count        = 32'($signed(counts_i[16 * j +: 16]));
    assign f_difference   = f_reference - f_count;
    assign f_following[j] = f_difference < -FollowingLimit || f_difference >= FollowingLimit;
    assign f_outside[j]   = f_reference < TravelLow || f_reference >= TravelHigh;
  end
  // Periods with the drives on and no valid frame (the watchdog's specification), saturating.
  logic [WatchdogWidth-1:0] f_silent_q = '0;
  always_ff @(posedge clk_i) begin
    if (!rst_ni || frame_valid_i || !enabled_i) f_silent_q <= '0;
    else if (tick_i && ~f_silent_q != '0) f_silent_q <= f_silent_q + 1'b1;
  end

  // The check's registers from this clock's references and latched counts (the pipeline's own
  // formula): what they hold in the next clock, whatever else happens.
  logic [2:0] f_following_next, f_outside_next;
  for (genvar j = 0; j < 3; j++) begin : g_next
    logic signed [23:0] f_reference_count;
    logic signed [16:0] f_difference17;
    logic signed [13:0] f_block;
    assign f_reference_count   = references_i[32 * j + 8 +: 24];
    assign f_difference17      = f_reference_count[16:0] - {counts_i[16 * j + 15], counts_i[16 * j +: 16]};
    assign f_block             = f_reference_count[23:10];
    assign f_following_next[j] = f_difference17[16:FollowingBits] != '0 && f_difference17[16:FollowingBits] != '1;
    assign f_outside_next[j]   = f_block < 14'(MinTravelBlock) || f_block > 14'(MaxTravelBlock);
  end
  localparam int Skip = delta_board_pkg::FaultEncoderSkip, Following = delta_board_pkg::FaultFollowing;
  localparam int Watchdog = delta_board_pkg::FaultWatchdog, Travel = delta_board_pkg::FaultTravel;
  always_comb begin
    if (rst_ni) watchdog_counts_silent_periods: assert (silent_periods_q == f_silent_q);
    watchdog_counts_silent_periods_c: cover (rst_ni && silent_periods_q == WatchdogWidth'(2) && enabled_i);
    fault_is_any_latched_cause: assert (fault_o == (fault_cause_o != '0));
    fault_is_any_latched_cause_c: cover (fault_o && fault_cause_o != 4'b1111);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && rst_ni && $past(rst_ni)) begin
      // A latched cause stays until a clear: never clears, never re-enables by itself.
      if ($past(fault_o) && !$past(clear_i)) cause_holds_until_a_clear: assert ((fault_cause_o & $past(fault_cause_o)) == $past(fault_cause_o));
      cause_holds_until_a_clear_c: cover ($past(fault_o) && !$past(clear_i) && $past(step_error_i) == '0);
      // The check's registers follow the last clock's references and latched counts alone (the model
      // board computes them once when these hold).
      the_check_follows_only_the_references_and_counts: assert (following == $past(f_following_next) &&
          outside == $past(f_outside_next));
      the_check_follows_only_the_references_and_counts_c: cover (following != '0 && outside != '0 && !$past(checked_q));
      // A clear with no cause present in its cycle clears every cause (progress).
      if ($past(clear_i) && $past(step_error_i) == '0 && !($past(enabled_i) && $past(checked_q)) &&
          !($past(enabled_i) && $past(silent_periods_q) > WatchdogWidth'(WatchdogPeriods))) begin
        clear_with_the_cause_gone_clears: assert (!fault_o);
      end
      clear_with_the_cause_gone_clears_c: cover ($past(fault_o) && $past(clear_i) && !fault_o);
      // A cause present in the clear's own cycle still latches (a clear never hides a cause).
      if ($past(step_error_i) != '0) encoder_skip_latches: assert (fault_cause_o[Skip]);
      encoder_skip_latches_c: cover ($past(step_error_i) != '0 && $past(clear_i));
      // Each cause rises only for its reason.
      if (!$past(fault_cause_o[Skip]) && fault_cause_o[Skip]) skip_rises_only_on_a_skip: assert ($past(step_error_i) != '0);
      skip_rises_only_on_a_skip_c: cover (!$past(fault_cause_o[Skip]) && fault_cause_o[Skip]);
      // Watchdog: drives on and no valid frame for more than WatchdogPeriods ticks -> the cause
      // latches in the next clock (joint_axes: the drives go off in the clock after). Stated on
      // the design's counter, which watchdog_counts_silent_periods (below) proves equal to the
      // specification's f_silent_q in every reachable state: PDR proves each of the three in
      // well under a second, where the composed statement takes it minutes (the 12-bit counters
      // compared with 2500).
      if ($past(enabled_i) && $past(silent_periods_q) > WatchdogWidth'(WatchdogPeriods)) watchdog_fires_after_the_watchdog_time: assert (fault_cause_o[Watchdog]);
      watchdog_fires_after_the_watchdog_time_c: cover ($past(enabled_i) && $past(silent_periods_q) > WatchdogWidth'(WatchdogPeriods));
      if (!$past(fault_cause_o[Watchdog]) && fault_cause_o[Watchdog]) begin
        watchdog_never_fires_early: assert ($past(enabled_i) && $past(silent_periods_q) > WatchdogWidth'(WatchdogPeriods));
      end
      watchdog_never_fires_early_c: cover ($past(enabled_i) && $past(silent_periods_q) == WatchdogWidth'(WatchdogPeriods) && !fault_cause_o[Watchdog]);
    end
    if (f_past2_valid && rst_ni && $past(rst_ni, 2)) begin
      // Following and travel: judged on the values of the cycle after a period start, latched two
      // cycles later when the drives are on.
      if ($past(checked_q) && $past(enabled_i) && $past(f_outside, 2) != '0) reference_outside_the_travel_latches: assert (fault_cause_o[Travel]);
      reference_outside_the_travel_latches_c: cover ($past(checked_q) && $past(enabled_i) && $past(f_outside, 2) != '0);
      if ($past(checked_q) && $past(enabled_i) && $past(f_following & ~f_outside, 2) != '0) following_error_latches: assert (fault_cause_o[Following]);
      following_error_latches_c: cover ($past(checked_q) && $past(enabled_i) && $past(f_following & ~f_outside, 2) != '0);
      if (!$past(fault_cause_o[Travel]) && fault_cause_o[Travel]) begin
        travel_rises_only_outside: assert ($past(checked_q) && $past(enabled_i) && $past(f_outside, 2) != '0);
      end
      travel_rises_only_outside_c: cover ($past(checked_q) && $past(enabled_i) && $past(f_outside, 2) == '0 && !fault_o);
      if (!$past(fault_cause_o[Following]) && fault_cause_o[Following]) begin
        following_rises_only_on_an_error: assert ($past(checked_q) && $past(enabled_i) && $past(f_following | f_outside, 2) != '0);
      end
      following_rises_only_on_an_error_c: cover ($past(checked_q) && $past(enabled_i) && $past(f_following | f_outside, 2) == '0 && !fault_o);
      // active_o (a clear is refused while it is high): the conditions of the last checked period.
      if ($past(checked_q)) begin
        active_is_the_last_periods_condition: assert (($past(f_outside, 2) != '0) ? active_o : active_o == ($past(f_following, 2) != '0));
      end else begin
        active_holds_between_checks: assert (active_o == $past(active_o));
      end
      active_is_the_last_periods_condition_c: cover ($past(checked_q) && active_o && !$past(enabled_i));
      active_holds_between_checks_c: cover (!$past(checked_q) && active_o);
    end
  end
`endif
endmodule
