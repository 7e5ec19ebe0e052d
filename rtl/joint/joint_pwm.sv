// Drive current commands as PWM magnitude + direction, and the drive enable, for three joints.
//
// Each current (Q1.15 A, |current| <= CurrentLimitCode = 0.5 A) updates its joint's duty as soon
// as it is stored (current_valid_i); PWM period 2^PwmBits board cycles, duty = |current| / 0.5 A,
// direction = sign (1 = negative). A fault stops the torque: every PWM output, every direction
// output and the enable low, registered with the outputs (glitch-free pins). The drives are on
// while the board enables them (enabled_i: an accepted enable command or a bench jog,
// docs/board_link.md) and there is no fault; off, every PWM and direction output is low too.
module joint_pwm #(
  parameter int unsigned PwmBits = delta_board_pkg::PwmBits
) (
  input  logic        clk_i,
  input  logic        rst_ni,
  input  logic [47:0] currents_i,       // joint j at [16j +: 16], Q1.15 A
  input  logic [2:0]  current_valid_i,  // joint j's current is stored this cycle
  input  logic        enabled_i,
  input  logic        fault_i,
  output logic [2:0]  drive_pwm_o,
  output logic [2:0]  drive_dir_o,
  output logic        drive_enable_o
);
  localparam int unsigned DutyBits = PwmBits + 1;  // 0 .. 2^PwmBits (= 100 %)
  // |current| <= 2^14 (0.5 A) -> duty <= 2^PwmBits: the duty is |current| >> (14 - PwmBits).
  localparam int unsigned DutyShift = 14 - PwmBits;

  // The PWM period's position counts down (remaining = 2^PwmBits - 1 - phase), so that the duty
  // comparison is one carry chain per joint with no inverters: phase < duty <=> duty + remaining
  // >= 2^PwmBits.
  logic [PwmBits-1:0]    pwm_remaining_q;
  logic [3*DutyBits-1:0] duty_q, duty_d;
  logic [2:0]            direction_q, direction_d;

  // |x| >> DutyShift without a negation: -x keeps x's bits up to its lowest 1 and flips those
  // above, so bit k of |x| is x[k] ^ (x < 0 && x[k-1:0] != 0). That prefix OR is the carry of
  // {x[14:DutyShift], x[DutyShift-1:0] != 0} + {x[15] repeated} (a carry chain, one logic cell per bit
  // with the duty's flip-flop); 16'(-x) >> DutyShift bit for bit, for every x.
  function automatic logic [DutyBits-1:0] duty_of(logic [15:0] x);
    duty_of = DutyBits'(({x[14:DutyShift], x[DutyShift-1:0] != '0} + {(DutyBits + 1){x[15]}}) >> 1) ^ {DutyBits{x[15]}};
  endfunction

  always_comb begin
    duty_d      = duty_q;
    direction_d = direction_q;
    for (int j = 0; j < 3; j++) begin
      if (current_valid_i[j]) begin
        duty_d[DutyBits * j +: DutyBits] = duty_of(currents_i[16 * j +: 16]);
        direction_d[j] = currents_i[16 * j + 15];
      end
    end
  end

  // Outputs registered (the fault gate included): glitch-free pins.
  logic [2:0] pwm_d, pwm_q, dir_q;
  logic       enable_q;
  always_comb begin
    for (int j = 0; j < 3; j++) begin
      // duty + remaining < 2^DutyBits (duty <= 2^PwmBits, remaining < 2^PwmBits).
      pwm_d[j] = enabled_i && !fault_i && DutyBits'(duty_q[DutyBits * j +: DutyBits] + DutyBits'(pwm_remaining_q)) >= DutyBits'(1 << PwmBits);
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      pwm_remaining_q <= '1;
      duty_q      <= '0;
      direction_q <= '0;
      pwm_q       <= '0;
      dir_q       <= '0;
      enable_q    <= 1'b0;
    end else begin
      pwm_remaining_q <= pwm_remaining_q - 1'b1;
      duty_q      <= duty_d;
      direction_q <= direction_d;
      pwm_q       <= pwm_d;
      dir_q       <= direction_d & {3{enabled_i && !fault_i}};  // low whenever the drives are off
      enable_q    <= enabled_i && !fault_i;
    end
  end

  assign drive_pwm_o    = pwm_q;
  assign drive_dir_o    = dir_q;
  assign drive_enable_o = enable_q;

`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // Environment: reset in the first cycle only; the controller's currents within its limit.
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  localparam logic signed [15:0] FLimit = 16'(delta_board_pkg::CurrentLimitCode);
  function automatic logic [31:0] f_magnitude(logic [15:0] current);
    f_magnitude = current[15] ? 32'(0 - 32'($signed(current))) : 32'(current);
  endfunction
  function automatic logic f_within(logic [15:0] current);
    f_within = $signed(current) <= FLimit && $signed(current) >= -FLimit;
  endfunction
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
    currents_within_the_limit: assume ((!current_valid_i[0] || f_within(currents_i[15:0])) &&
        (!current_valid_i[1] || f_within(currents_i[31:16])) && (!current_valid_i[2] || f_within(currents_i[47:32])));
  end
  // The specification: the last stored current of each joint, and the PWM period's position.
  logic [47:0]        f_current_q = '0;
  logic [PwmBits-1:0] f_phase_q = '0;
  always_ff @(posedge clk_i) begin
    f_phase_q <= rst_ni ? f_phase_q + 1'b1 : '0;
    for (int j = 0; j < 3; j++) begin
      if (!rst_ni) f_current_q[16 * j +: 16] <= '0;
      else if (current_valid_i[j]) f_current_q[16 * j +: 16] <= currents_i[16 * j +: 16];
    end
  end
  // duty = |current| / 0.5 A of the period: |current| 2^PwmBits / CurrentLimitCode cycles.
  localparam int FScale = $clog2(delta_board_pkg::CurrentLimitCode);  // the limit is a power of two
  logic [3*16-1:0] f_duty_q = '0;
  always_ff @(posedge clk_i) begin
    for (int j = 0; j < 3; j++) begin
      if (!rst_ni) f_duty_q[16 * j +: 16] <= '0;
      else if (current_valid_i[j]) f_duty_q[16 * j +: 16] <= 16'((f_magnitude(currents_i[16 * j +: 16]) << PwmBits) >> FScale);
    end
  end
  logic [2:0] f_on;  // joint j's PWM is high in this phase
  for (genvar j = 0; j < 3; j++) begin : g_spec
    assign f_on[j] = 16'(f_phase_q) < f_duty_q[16 * j +: 16];
  end

  always_comb begin
    pwm_off_whenever_the_drives_are_off: assert (drive_enable_o || drive_pwm_o == '0);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid) pwm_off_whenever_the_drives_are_off_c: cover (!drive_enable_o && $past(drive_pwm_o) != '0);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid) begin
      drives_on_only_when_enabled_and_no_fault: assert (drive_enable_o == ($past(rst_ni) && $past(enabled_i) && !$past(fault_i)));
      drives_on_only_when_enabled_and_no_fault_c: cover (drive_enable_o && $past(enabled_i) && f_current_q != '0);
      if ($past(fault_i) || !$past(enabled_i)) torque_off_the_clock_after_a_fault_or_disable: assert (!drive_enable_o && drive_pwm_o == '0);
      torque_off_the_clock_after_a_fault_or_disable_c: cover ($past(fault_i) && $past(drive_pwm_o) != '0);
      if ($past(rst_ni)) begin
        pwm_duty_is_the_current_over_full_scale: assert (drive_pwm_o == ($past(enabled_i && !fault_i) ? $past(f_on) : 3'b000));
        direction_is_the_currents_sign: assert (drive_dir_o == ($past(enabled_i && !fault_i) ? {f_current_q[47], f_current_q[31], f_current_q[15]} : 3'b000));
      end
      pwm_duty_is_the_current_over_full_scale_c: cover (drive_pwm_o == 3'b101 && drive_enable_o);
      direction_is_the_currents_sign_c: cover (drive_dir_o == 3'b011 && drive_enable_o);
    end
  end
`endif
endmodule
