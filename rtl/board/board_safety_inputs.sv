// The board's safety inputs (docs/bench.md): the e-stop chain (estop_open_i) and the three drives'
// fault lines (drive_fault_i), each high = stop (the pins are pulled up: a broken wire stops).
//
// Each input goes through a two-flip-flop synchroniser and is sampled in the cycle of each control
// period's tick 0 (sample_i). FilterPeriods samples in a row at the stop level latch its cause
// (cause_o bit BoardFaultEstopInput, BoardFaultDrive + j), at the edge that ends that tick-0 cycle:
// a stop shorter than FilterPeriods - 1 periods never latches, one held from any time on latches
// within FilterPeriods periods and a few clocks. A cause stays latched until clear_i (which the
// board gives only for an accepted clear-fault, refused while stopping_o is high); a latch in the
// clear's own cycle wins. stopping_o: some input's last sample (the last tick 0) was at the stop
// level. The module never turns anything on: its outputs only stop (board_core.sv).
module board_safety_inputs #(
  parameter int unsigned FilterPeriods = delta_board_pkg::BoardInputFilterPeriods
) (
  input  logic       clk_i,
  input  logic       rst_ni,
  input  logic       sample_i,       // tick 0 of a control period
  input  logic       estop_open_i,   // asynchronous: 1 = the e-stop chain is open
  input  logic [2:0] drive_fault_i,  // asynchronous: 1 = drive j reports a fault
  input  logic       clear_i,        // an accepted clear-fault
  output logic [delta_board_pkg::BoardFaultBits-1:0] cause_o,  // latched causes (BoardFault* bits)
  output logic       stopping_o      // an input's last sample was at the stop level
);
  localparam int unsigned Inputs      = delta_board_pkg::BoardFaultBits;
  localparam int unsigned HistoryBits = FilterPeriods - 1;  // the samples kept before this one
  // Elaboration checks (as localparams: not logic a mutant could change).
  localparam bit FilterTooShort = FilterPeriods < 2;
  localparam bit OtherBits = delta_board_pkg::BoardFaultEstopInput != 0 || delta_board_pkg::BoardFaultDrive != 1 || Inputs != 4;
  if (FilterTooShort) begin : g_bad_filter
    $error("board_safety_inputs: FilterPeriods must be at least 2");
  end
  if (OtherBits) begin : g_bad_bits
    $error("board_safety_inputs: the cause bits are e-stop input (0) and drives 1..3 (bits 1..3)");
  end

  logic [Inputs-1:0] raw, meta_q, sync_q, cause_q, latch;
  assign raw = {drive_fault_i, estop_open_i};
  logic [Inputs*HistoryBits-1:0] history_q;  // input i's at [HistoryBits i +: HistoryBits], its bit 0 the last sample

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      meta_q <= '0;
      sync_q <= '0;
    end else begin
      meta_q <= raw;
      sync_q <= meta_q;
    end
  end

  for (genvar i = 0; i < Inputs; i++) begin : g_input
    logic [HistoryBits-1:0] history;
    assign history  = history_q[HistoryBits * i +: HistoryBits];
    assign latch[i] = sample_i && sync_q[i] && history == '1;
    always_ff @(posedge clk_i or negedge rst_ni) begin
      if (!rst_ni) begin
        history_q[HistoryBits * i +: HistoryBits] <= '0;
        cause_q[i] <= 1'b0;
      end else begin
        if (sample_i) history_q[HistoryBits * i +: HistoryBits] <= HistoryBits'({history, sync_q[i]});
        if (latch[i]) cause_q[i] <= 1'b1;
        else if (clear_i) cause_q[i] <= 1'b0;
      end
    end
  end

  always_comb begin
    stopping_o = 1'b0;
    for (int i = 0; i < Inputs; i++) stopping_o = stopping_o || history_q[HistoryBits * i];
  end
  assign cause_o = cause_q;

`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // Environment: reset in the first cycle only. The inputs, the samples and the clears are free
  // (a sample may come in any cycle, every cycle included).
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
  end
  // The specification, written independently of the shift registers above: per input the number
  // of samples in a row at the stop level (saturating at FilterPeriods), of the raw line as it was
  // two clocks before each sample (the synchroniser's delay).
  localparam int unsigned RunBits = $clog2(FilterPeriods + 1);
  logic [Inputs-1:0] f_raw_1 = '0, f_raw_2 = '0;  // the raw lines one and two clocks ago
  logic [Inputs-1:0] f_last_q = '0;               // each input's last sample
  always_ff @(posedge clk_i) begin
    f_raw_1 <= rst_ni ? {drive_fault_i, estop_open_i} : '0;  // the pins, not raw (a mutant of raw is caught)
    f_raw_2 <= rst_ni ? f_raw_1 : '0;
    if (!rst_ni) f_last_q <= '0;
    else if (sample_i) f_last_q <= f_raw_2;
  end
  always_comb begin
    if (rst_ni) begin
      the_synchroniser_is_two_clocks: assert (sync_q == f_raw_2);
      stopping_is_any_last_sample_at_stop: assert (stopping_o == (f_last_q != '0));
    end
    the_synchroniser_is_two_clocks_c: cover (rst_ni && sync_q == 4'b1011);
    stopping_is_any_last_sample_at_stop_c: cover (rst_ni && stopping_o && cause_o == '0);
  end
  // f_latching[i]: this cycle's sample of input i is at stop and the FilterPeriods - 1 before it were.
  logic [Inputs-1:0] f_latching;
  for (genvar i = 0; i < Inputs; i++) begin : g_spec
    logic [RunBits-1:0] f_run_q = '0;  // samples in a row at stop before this cycle's
    always_ff @(posedge clk_i) begin
      if (!rst_ni) f_run_q <= '0;
      else if (sample_i) f_run_q <= !f_raw_2[i] ? '0 : (f_run_q == RunBits'(FilterPeriods)) ? f_run_q : f_run_q + 1'b1;
    end
    assign f_latching[i] = sample_i && f_raw_2[i] && f_run_q >= RunBits'(FilterPeriods - 1);
  end
  always_ff @(posedge clk_i) begin
    // A reset leaves no cause latched (nor any sample kept: stopping_is_any_last_sample_at_stop).
    if (f_past_valid && !$past(rst_ni)) no_cause_after_a_reset: assert (cause_o == '0);
    if (f_past_valid) no_cause_after_a_reset_c: cover (!$past(rst_ni) && rst_ni);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni) && rst_ni) begin
      // FilterPeriods samples in a row at stop (this one the last) latch the cause.
      filter_periods_samples_at_stop_latch: assert ((cause_o & $past(f_latching)) == $past(f_latching));
      filter_periods_samples_at_stop_latch_c: cover (($past(f_latching) & ~$past(cause_o)) == 4'b1000);
      // A cause rises only at such a sample: fewer in a row (a glitch) never latch.
      a_cause_rises_only_after_filter_periods_samples_at_stop: assert ((cause_o & ~$past(cause_o) & ~$past(f_latching)) == '0);
      a_cause_rises_only_after_filter_periods_samples_at_stop_c: cover ((cause_o & ~$past(cause_o)) == 4'b0001 && $past(clear_i));
      // A latched cause stays until a clear: it never clears itself.
      if (!$past(clear_i)) a_cause_falls_only_at_a_clear: assert ((cause_o & $past(cause_o)) == $past(cause_o));
      a_cause_falls_only_at_a_clear_c: cover ($past(cause_o) == 4'b0110 && cause_o == '0);
      // A clear clears every cause whose sample in the clear's cycle is not latching.
      if ($past(clear_i)) a_clear_clears_what_is_not_latching: assert ((cause_o & ~$past(f_latching)) == '0);
      a_clear_clears_what_is_not_latching_c: cover ($past(clear_i) && $past(cause_o) == 4'b0011 && cause_o == 4'b0001);
    end
  end
`endif
endmodule
