// Drive current commands as PWM magnitude + direction, and the drive enable, for three joints.
//
// Each current (Q1.15 A, |current| <= CurrentLimitCode = 0.5 A) updates its joint's duty as soon
// as it is stored (current_valid_i); PWM period 2^PwmBits board cycles, duty = |current| / 0.5 A,
// direction = sign (1 = negative). A fault stops the torque: every PWM output low and the enable
// low, registered with the outputs (glitch-free pins). The drives are on while the board enables
// them (enabled_i: an accepted enable command, docs/board_link.md) and there is no fault; off,
// every PWM output is low too.
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

  logic [PwmBits-1:0]    pwm_phase_q;
  logic [3*DutyBits-1:0] duty_q, duty_d;
  logic [2:0]            direction_q, direction_d;

  always_comb begin
    duty_d      = duty_q;
    direction_d = direction_q;
    for (int j = 0; j < 3; j++) begin
      if (current_valid_i[j]) begin
        // The limit keeps 16'(-x) exact (no -32768).
        duty_d[DutyBits * j +: DutyBits] =
            DutyBits'((currents_i[16 * j + 15] ? 16'(-currents_i[16 * j +: 16]) : currents_i[16 * j +: 16]) >> DutyShift);
        direction_d[j] = currents_i[16 * j + 15];
      end
    end
  end

  // Outputs registered (the fault gate included): glitch-free pins.
  logic [2:0] pwm_d, pwm_q;
  logic       enable_q;
  always_comb begin
    for (int j = 0; j < 3; j++) begin
      pwm_d[j] = enabled_i && !fault_i && ({1'b0, pwm_phase_q} < duty_q[DutyBits * j +: DutyBits]);
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      pwm_phase_q <= '0;
      duty_q      <= '0;
      direction_q <= '0;
      pwm_q       <= '0;
      enable_q    <= 1'b0;
    end else begin
      pwm_phase_q <= pwm_phase_q + 1'b1;
      duty_q      <= duty_d;
      direction_q <= direction_d;
      pwm_q       <= pwm_d;
      enable_q    <= enabled_i && !fault_i;
    end
  end

  assign drive_pwm_o    = pwm_q;
  assign drive_dir_o    = direction_q;
  assign drive_enable_o = enable_q;
endmodule
