// Three joint controllers (reference filter, VOB, DOB, eq. 5) on one bit-serial datapath, no DSP.
//
// Interface (Vitis HLS ap_ctrl_hs, port names as the export of hls/joint's joint_top, like
// rtl/network's delta_network): ap_start is sampled while ap_idle is high and must stay high
// until ap_ready; reference_j and encoder_j must stay stable until ap_ready, which is high in the
// last of the 6 cycles that copy them into the state memory. current_j changes when joint j's
// command is stored, with current_j_ap_vld high for that cycle; ap_done pulses after the third
// joint, with limited and overflow_count valid; all outputs hold until rewritten. ap_rst is
// synchronous and active high. The first period after reset starts from rest at its own input
// (golden: fixed_rest_state). Latency from the ap_start edge to ap_done: 1072 cycles (6 input
// copies, 3 x 355 for the joints, 1 done cycle): 46.1 us at the board's 23.25 MHz, 46 % of the 100 us period.
//
// Schedule: per joint the 21 instructions of delta_joint_pkg::program_rom, each
//   OpInit 3 cycles (read, register, load acc), OpMac 30 (read a, b, c; a - b shifted; minus c and
//   the correction into the multiplicand; saturate, add the correction; 24 bit-serial steps over
//   the coefficient's magnitude), OpStore 2 (shift, then saturate and write): 5 x 3 + 11 x 30 +
//   5 x 2 = 355.
// The accumulator has one adder and only adds (delta_joint_pkg::mac_correction): a negative
// coefficient multiplies the complemented operand by its magnitude plus a correction, and an
// OpInit's rounding constant is ORed in or, where its bit is inside the state, is the next OpMac's
// correction.
// The instruction, every memory word (word_n_q), each step of the operand and the shifted
// accumulator pass a register, so no path holds more than one carry chain: 25 MHz beside the
// network on the UP5K.
module joint_controller (
  input  logic        ap_clk,
  input  logic        ap_rst,
  input  logic        ap_start,
  output logic        ap_done,
  output logic        ap_idle,
  output logic        ap_ready,
  input  logic [31:0] reference_0,       // Q24.8 shaft encoder counts (0.01 deg)
  input  logic [31:0] reference_1,
  input  logic [31:0] reference_2,
  input  logic [15:0] encoder_0,         // shaft encoder counts
  input  logic [15:0] encoder_1,
  input  logic [15:0] encoder_2,
  output logic [15:0] current_0,         // applied current, Q1.15 A
  output logic        current_0_ap_vld,
  output logic [15:0] current_1,
  output logic        current_1_ap_vld,
  output logic [15:0] current_2,
  output logic        current_2_ap_vld,
  output logic [2:0]  limited,           // bit j: the current limit clipped joint j's command
  output logic [15:0] overflow_count,    // saturated operands and states since reset (sticks at max)
  // Not part of the HLS export: while idle, the state memory answers {joint, slot} of the last
  // period (its reference, encoder count, applied current...) one cycle later (board telemetry).
  input  logic [4:0]  peek_address,
  output logic [31:0] peek_data,
  // The HLS top's shift_j, written while idle (one joint per shift_write pulse, before the
  // ap_start of the period it belongs to): the play shift s_j in whole counts, stored offset by
  // half its range (s + 2^(ShiftBits - 1)), so that differences of stored words are differences of s.
  input  logic        shift_write,
  input  logic [1:0]  shift_joint,
  input  logic [delta_joint_pkg::ShiftBits-1:0] shift_value
);
  localparam int unsigned AccWidth = delta_joint_pkg::AccumulatorWidth;
  localparam int unsigned LimitBit = $clog2(delta_joint_pkg::CurrentLimit);  // CurrentLimit = 2^LimitBit
  if (delta_joint_pkg::CurrentLimit != 16'(1 << LimitBit)) begin : g_limit_is_a_power_of_two
    $error("joint_controller: delta_joint_pkg::CurrentLimit must be a power of two");
  end

  typedef enum logic [1:0] {StateIdle, StateLoad, StateRun, StateDone} state_e;

  state_e       state_q, state_d;
  logic [2:0]   load_q, load_d;      // input write counter: joint = load / 2, reference then encoder
  logic [1:0]   joint_q, joint_d;
  logic [4:0]   pc_q, pc_d;
  logic [2:0]   phase_q, phase_d;
  logic [4:0]   bit_q, bit_d;
  logic         bank_q, bank_d;      // bank written this period; the other holds the old states
  logic         primed_q, primed_d;  // an earlier period has filled the old bank
  logic [AccWidth-1:0] acc_q, acc_d;
  logic [AccWidth-1:0] multiplicand_q, multiplicand_d;  // operand << bit
  logic [22:0]  coefficient_q, coefficient_d;  // |c|, shifted right a bit per step
  logic [31:0]  word_n_q, word_d;    // the word read two cycles ago, masked, complemented (pipeline register)
  logic [31:0]  memory_word;         // ~word_n_q: a subtraction of the word takes word_n_q, no inverters
  logic [31:0]  first_q, first_d;    // operand a
  logic [57:0]  shifted_difference_q, shifted_difference_d;  // (a - b) << operand_shift
  logic [57:0]  operand_wide_q, operand_wide_d;              // ((a - b) << operand_shift) - c
  logic [4:0]   source_q, source_d;  // source of the word arriving on read_data
  logic [47:0]  current_q, current_d;
  logic [2:0]   limited_q, limited_d;
  logic [15:0]  overflow_q, overflow_d;
  logic [2:0]   current_valid_q, current_valid_d;

  logic [95:0]  references;  // joint j at [32j +: 32] (yosys 0.23 reads no packed 2-D arrays)
  logic [47:0]  encoders;    // joint j at [16j +: 16]
  assign references = {reference_2, reference_1, reference_0};
  assign encoders   = {encoder_2, encoder_1, encoder_0};

  logic [5:0]   read_address, write_address;
  logic [31:0]  read_data, write_data, source_data;
  logic         write_enable, overflow_event;

  // Fields of the current instruction (delta_joint_pkg, "An instruction is ...").
  logic [1:0] op;
  logic [4:0] source_a, source_b, source_c, instr_frac, instr_shift;
  logic [2:0] operand_shift, dest;
  logic [3:0] coefficient;
  // The instruction is registered (decoded from pc_d) so that no data path starts at the ROM.
  logic [delta_joint_pkg::InstructionWidth-1:0] instruction_q;
  assign {op, source_a, source_b, source_c, operand_shift, coefficient, instr_frac, instr_shift, dest} =
      instruction_q;

  joint_state_ram u_state_ram (
    .clk_i          (ap_clk),
    .read_address_i (read_address),
    .read_data_o    (read_data),
    .write_enable_i (write_enable),
    .write_address_i(write_address),
    .write_data_i   (write_data)
  );

  // Before the first period the old bank is empty: its states read as zero and its previous
  // reference and encoder as this period's (rest at the first input).
  // A source is {bank[1:0], slot[2:0]} (delta_joint_pkg::source_t).
  function automatic logic is_input_slot(logic [2:0] slot);
    is_input_slot = slot == delta_joint_pkg::SlotReference || slot == delta_joint_pkg::SlotEncoder ||
                    slot == delta_joint_pkg::SlotShift;
  endfunction

  function automatic logic reads_new_bank(logic [4:0] source, logic primed);
    reads_new_bank = source[4:3] == delta_joint_pkg::SourceNew || (!primed && is_input_slot(source[2:0]));
  endfunction

  function automatic logic reads_zero(logic [4:0] source, logic primed);
    reads_zero = source[4:3] == delta_joint_pkg::SourceZero ||
           (source[4:3] == delta_joint_pkg::SourceOld && !primed && !is_input_slot(source[2:0]));
  endfunction

  // Constant shifts selected per instruction (a barrel shifter would cost far more logic). The
  // rounding constant 2^(shift-1) is ORed in when frac = shift (its bit is below the state's);
  // otherwise it is the next OpMac's correction (delta_joint_pkg::mac_correction).
  function automatic logic [AccWidth-1:0] init_value(logic [31:0] word, logic [4:0] frac, logic [4:0] shift);
    logic [AccWidth-1:0] extended, shifted;
    extended = {{(AccWidth - 32){word[31]}}, word};
    unique case (frac)
      5'd26:   shifted = (extended << 26) | (shift == 5'd26 ? AccWidth'(1) << 25 : '0);
      5'd25:   shifted = (extended << 25) | (shift == 5'd25 ? AccWidth'(1) << 24 : '0);
      5'd22:   shifted = (extended << 22) | (shift == 5'd22 ? AccWidth'(1) << 21 : '0);
      default: shifted = (extended << 20) | (shift == 5'd20 ? AccWidth'(1) << 19 : '0);
    endcase
    init_value = shifted;
  endfunction

  function automatic logic [AccWidth-1:0] shift_right(logic [AccWidth-1:0] value, logic [4:0] shift);
    unique case (shift)
      5'd26:   shift_right = $signed(value) >>> 26;
      5'd25:   shift_right = $signed(value) >>> 25;
      5'd22:   shift_right = $signed(value) >>> 22;
      default: shift_right = $signed(value) >>> 29;
    endcase
  endfunction

  // acc >>> shift fits 32 bits: acc[65:31 + shift] all equal the sign, for shift 22, 25, 26 or
  // else 29 (nested ranges, so no shifted copy of the accumulator's top is built); top is acc_q's
  // bits 53 and up (index 0 here is bit 53).
  function automatic logic fits_word(logic [AccWidth-54:0] top, logic sign, logic [4:0] shift);
    logic s22, s26, s29;
    s22 = shift == 5'd22;
    s26 = shift == 5'd26;
    s29 = !(s22 || s26 || shift == 5'd25);
    fits_word = top[AccWidth-54:7] == {(AccWidth - 60){sign}} && (s29 || top[6:4] == {3{sign}}) &&
                (s29 || s26 || top[3] == sign) && (!s22 || top[2:0] == {3{sign}});
  endfunction

  // (a - b) << shift on 58 bits, exact; the operand is this minus c.
  function automatic logic [57:0] shift_difference(logic [32:0] difference, logic [2:0] shift);
    logic [57:0] extended;
    extended = {{25{difference[32]}}, difference};
    unique case (shift)
      delta_joint_pkg::Shift8:  shift_difference = extended << 8;
      delta_joint_pkg::Shift9:  shift_difference = extended << 9;
      delta_joint_pkg::Shift16: shift_difference = extended << 16;
      delta_joint_pkg::Shift24: shift_difference = extended << 24;
      default:                  shift_difference = extended;
    endcase
  endfunction

  logic [57:0]         operand_wide;
  logic [39:0]         operand;
  logic                operand_saturated;
  logic [31:0]         shifted_acc;    // (acc >>> shift)[31:0], registered
  logic [31:0]         shifted_word_q;   // (acc >>> shift)[31:0]
  logic                shifted_sign_q;   // acc < 0
  logic                shifted_over_q;   // acc >>> shift does not fit 32 bits
  logic [AccWidth-1:0] acc_sum;          // the accumulator's one adder
  logic                coefficient_negative;
  logic                state_saturated;
  logic [31:0]         state_word;
  logic                current_high, current_low;
  logic [15:0]         current_word;
  logic [4:0]          issue_source;

  always_comb begin
    operand_wide = operand_wide_q;
    operand_saturated = operand_wide[57:39] != {19{operand_wide[57]}};
    operand = operand_saturated ? {operand_wide[57], {39{!operand_wide[57]}}} : operand_wide[39:0];
    shifted_acc = 32'(shift_right(acc_q, instr_shift));
    state_saturated = shifted_over_q;
    state_word = state_saturated ? {shifted_sign_q, {31{!shifted_sign_q}}} : shifted_word_q;
    // acc >>> shift beyond +-CurrentLimit: beyond 32 bits, or its word beyond. The limit is a power
    // of two, 2^LimitBit, so these are bit tests of the word (whose bit 31 is the sign when it fits):
    // above 2^LimitBit a bit over LimitBit is set, or bit LimitBit and one below; below -2^LimitBit
    // a bit from LimitBit up is clear.
    current_high = !shifted_sign_q && (shifted_over_q || shifted_word_q[30:LimitBit+1] != '0 ||
                   (shifted_word_q[LimitBit] && shifted_word_q[LimitBit-1:0] != '0));
    current_low = shifted_sign_q && (shifted_over_q || shifted_word_q[30:LimitBit] != '1);
    current_word = current_high ? delta_joint_pkg::CurrentLimit :
                   current_low  ? 16'(-delta_joint_pkg::CurrentLimit) : shifted_word_q[15:0];
    acc_sum = acc_q + multiplicand_q;
    coefficient_negative = delta_joint_pkg::coefficient_negative(coefficient);
  end

  assign source_data = reads_zero(source_q, primed_q) ? 32'd0 : read_data;
  assign word_d      = source_data;
  assign memory_word = ~word_n_q;

  always_comb begin
    // Which operand is fetched this cycle: a at phase 0, b at 1, c at 2.
    unique case (phase_q)
      3'd0:    issue_source = source_a;
      3'd1:    issue_source = source_b;
      default: issue_source = source_c;
    endcase
    read_address = {joint_q, reads_new_bank(issue_source, primed_q) ? bank_q : !bank_q, issue_source[2:0]};
    // Idle: the bank the last period wrote (bank_q has toggled since).
    if (state_q == StateIdle) read_address = {peek_address[4:3], !bank_q, peek_address[2:0]};
  end
  assign peek_data = read_data;

  always_comb begin
    state_d        = state_q;
    load_d         = load_q;
    joint_d        = joint_q;
    pc_d           = pc_q;
    phase_d        = phase_q;
    bit_d          = bit_q;
    bank_d         = bank_q;
    primed_d       = primed_q;
    acc_d          = acc_q;
    multiplicand_d = multiplicand_q;
    coefficient_d  = coefficient_q;
    first_d        = first_q;
    shifted_difference_d = shifted_difference_q;
    operand_wide_d = operand_wide_q;
    source_d       = issue_source;
    current_d      = current_q;
    limited_d      = limited_q;
    current_valid_d = 3'b000;
    write_enable   = 1'b0;
    write_address  = {joint_q, bank_q, dest};
    write_data     = state_word;
    overflow_event = 1'b0;

    unique case (state_q)
      StateIdle: begin
        // The next period's shift, into the bank it writes (bank_q outlives ap_rst for this).
        write_enable  = shift_write;
        write_address = {shift_joint, bank_q, delta_joint_pkg::SlotShift};
        write_data    = 32'({!shift_value[delta_joint_pkg::ShiftBits-1], shift_value[delta_joint_pkg::ShiftBits-2:0]});
        if (ap_start) begin
          state_d = StateLoad;
          load_d  = 3'd0;
        end
      end
      StateLoad: begin
        write_enable  = 1'b1;
        write_address = {load_q[2:1], bank_q, load_q[0] ? delta_joint_pkg::SlotEncoder : delta_joint_pkg::SlotReference};
        write_data    = load_q[0] ? {{16{encoders[16 * load_q[2:1] + 15]}}, encoders[16 * load_q[2:1] +: 16]}
                                  : references[32 * load_q[2:1] +: 32];
        load_d        = load_q + 3'd1;
        if (load_q == 3'd5) begin
          state_d = StateRun;
          joint_d = 2'd0;
          pc_d    = 5'd0;
          phase_d = 3'd0;
        end
      end
      StateRun: begin
        unique case (op)
          delta_joint_pkg::OpInit: begin
            phase_d = phase_q + 3'd1;
            if (phase_q == 3'd2) begin
              acc_d   = init_value(memory_word, instr_frac, instr_shift);
              phase_d = 3'd0;
              pc_d    = pc_q + 5'd1;
            end
          end
          delta_joint_pkg::OpMac: begin
            phase_d = phase_q + 3'd1;
            unique case (phase_q)
              3'd0, 3'd1: ;  // reads of a and b issued
              3'd2: first_d = memory_word;
              3'd3: shifted_difference_d = shift_difference({first_q[31], first_q} - {memory_word[31], memory_word}, operand_shift);
              3'd4: begin
                operand_wide_d = shifted_difference_q - {{26{memory_word[31]}}, memory_word};
                multiplicand_d = delta_joint_pkg::mac_correction(pc_q);
              end
              3'd5: begin
                acc_d          = acc_sum;  // + the correction
                multiplicand_d = {{(AccWidth - 40){operand[39]}}, operand} ^ {AccWidth{coefficient_negative}};
                coefficient_d  = delta_joint_pkg::coefficient_magnitude(coefficient);
                bit_d          = 5'd0;
                overflow_event = operand_saturated;
              end
              default: begin
                // Bit-serial product of the (complemented) operand and |c|; bit 23 of |c| is 0.
                if (coefficient_q[0]) acc_d = acc_sum;
                multiplicand_d = multiplicand_q << 1;
                coefficient_d  = coefficient_q >> 1;
                bit_d          = bit_q + 5'd1;
                phase_d        = phase_q;
                if (bit_q == 5'd23) begin
                  phase_d = 3'd0;
                  pc_d    = pc_q + 5'd1;
                end
              end
            endcase
          end
          // Stores: phase 0 registers acc >>> shift (shifted_acc_q), phase 1 writes.
          delta_joint_pkg::OpStoreState: begin
            phase_d = 3'd1;
            if (phase_q == 3'd1) begin
              write_enable   = 1'b1;
              overflow_event = state_saturated;
              phase_d        = 3'd0;
              pc_d           = pc_q + 5'd1;
            end
          end
          default: begin  // OpStoreCurrent: last instruction of a joint
            phase_d = 3'd1;
            if (phase_q == 3'd1) begin
              phase_d      = 3'd0;
              write_enable = 1'b1;
              write_data   = {{16{current_word[15]}}, current_word};
              current_d[16 * joint_q +: 16] = current_word;
              limited_d[joint_q]            = current_high || current_low;
              current_valid_d[joint_q]      = 1'b1;
              pc_d = 5'd0;
              if (joint_q == 2'd2) begin
                state_d = StateDone;
              end else begin
                joint_d = joint_q + 2'd1;
              end
            end
          end
        endcase
      end
      default: begin  // StateDone: one cycle
        state_d  = StateIdle;
        bank_d   = !bank_q;
        primed_d = 1'b1;
      end
    endcase

    overflow_d = overflow_q;
    if (overflow_event && overflow_q != 16'hFFFF) overflow_d = overflow_q + 16'd1;
  end

  // The bank toggles every period and is not reset: the idle shift write names the bank the next
  // period writes whether or not ap_rst (the board's drives-off restart) comes in between.
  initial bank_q = 1'b0;
  always_ff @(posedge ap_clk) bank_q <= bank_d;

  always_ff @(posedge ap_clk) begin
    if (ap_rst) begin
      state_q        <= StateIdle;
      load_q         <= '0;
      joint_q        <= '0;
      pc_q           <= '0;
      phase_q        <= '0;
      bit_q          <= '0;
      primed_q       <= 1'b0;
      acc_q          <= '0;
      multiplicand_q <= '0;
      coefficient_q  <= '0;
      word_n_q       <= '1;
      first_q        <= '0;
      shifted_difference_q <= '0;
      operand_wide_q <= '0;
      source_q       <= delta_joint_pkg::Zero;
      current_q      <= '0;
      limited_q      <= '0;
      overflow_q     <= '0;
      current_valid_q <= '0;
      instruction_q  <= delta_joint_pkg::program_rom(5'd0);
      shifted_word_q <= '0;
      shifted_sign_q <= 1'b0;
      shifted_over_q <= 1'b0;
    end else begin
      state_q        <= state_d;
      load_q         <= load_d;
      joint_q        <= joint_d;
      pc_q           <= pc_d;
      phase_q        <= phase_d;
      bit_q          <= bit_d;
      primed_q       <= primed_d;
      acc_q          <= acc_d;
      multiplicand_q <= multiplicand_d;
      coefficient_q  <= coefficient_d;
      word_n_q       <= ~word_d;
      first_q        <= first_d;
      shifted_difference_q <= shifted_difference_d;
      operand_wide_q <= operand_wide_d;
      source_q       <= source_d;
      current_q      <= current_d;
      limited_q      <= limited_d;
      overflow_q     <= overflow_d;
      current_valid_q <= current_valid_d;
      instruction_q  <= delta_joint_pkg::program_rom(pc_d);
      shifted_word_q <= shifted_acc;
      shifted_sign_q <= acc_q[AccWidth-1];
      shifted_over_q <= !(fits_word(acc_q[AccWidth-1:53], 1'b0, instr_shift) || fits_word(acc_q[AccWidth-1:53], 1'b1, instr_shift));
    end
  end

  assign ap_idle          = state_q == StateIdle;
  assign ap_ready         = state_q == StateLoad && load_q == 3'd5;
  assign ap_done          = state_q == StateDone;
  assign current_0        = current_q[15:0];
  assign current_1        = current_q[31:16];
  assign current_2        = current_q[47:32];
  assign current_0_ap_vld = current_valid_q[0];
  assign current_1_ap_vld = current_valid_q[1];
  assign current_2_ap_vld = current_valid_q[2];
  assign limited          = limited_q;
  assign overflow_count   = overflow_q;
`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // What the model board (host/cosim/model_board.cpp) relies on for the state memory it keeps in
  // place: while idle, the peek reads the bank the last period wrote and the idle write (the next
  // period's play shift) goes to the other bank, so the peek never reads the word written.
  // Environment: reset (ap_rst) in the first cycle; every other input free.
  logic f_past_valid = 1'b0;
  always_ff @(posedge ap_clk) f_past_valid <= 1'b1;
  always_comb begin
    reset_in_the_first_cycle: assume (ap_rst || f_past_valid);
  end
  // The state memory builds no bypass for a read of the word written in the same cycle
  // (joint_state_ram's no_rw_check): no read, consumed or not, ever meets the write.
  always_comb begin
    if (f_past_valid && write_enable) the_memory_never_reads_the_word_written: assert (read_address != write_address);
    the_memory_never_reads_the_word_written_c: cover (f_past_valid && !ap_rst && state_q == StateRun && write_enable);
    // Lemma: outside a run the microprogram waits at its start.
    if (f_past_valid && state_q != StateRun) outside_a_run_the_program_is_at_its_start: assert (pc_q == 5'd0 && phase_q == 3'd0);
    outside_a_run_the_program_is_at_its_start_c: cover (f_past_valid && !ap_rst && state_q == StateLoad);
  end
  always_comb begin
    if (state_q == StateIdle && write_enable) the_peek_never_reads_the_word_written: assert (
        read_address[3] == !bank_q && write_address[3] == bank_q && read_address != write_address);
    the_peek_never_reads_the_word_written_c: cover (f_past_valid && !ap_rst && state_q == StateIdle && write_enable &&
        read_address[5:4] == write_address[5:4] && read_address[2:0] == write_address[2:0]);
  end

  // The schedule the model board keeps (its duty_cycle(j), kRunCycles): from the clock ap_start is
  // taken (idle), JointControllerLoadCycles clocks copy the inputs, each joint's microprogram takes
  // JointControllerJointCycles clocks (OpInit 3, OpMac 30, the stores 2), joint j's current is out
  // (current_j_ap_vld) JointControllerLoadCycles + JointControllerJointCycles (j + 1) + 1 clocks
  // after it, and ap_done with the third.
  localparam int unsigned FLoad  = delta_board_pkg::JointControllerLoadCycles;
  localparam int unsigned FJoint = delta_board_pkg::JointControllerJointCycles;
  function automatic logic [10:0] f_op_clocks(logic [1:0] operation);
    f_op_clocks = operation == delta_joint_pkg::OpInit ? 11'd3 : operation == delta_joint_pkg::OpMac ? 11'd30 : 11'd2;
  endfunction
  function automatic logic [10:0] f_clocks_before(logic [4:0] pc);  // the microprogram's clocks before pc
    logic [delta_joint_pkg::InstructionWidth-1:0] instruction;
    f_clocks_before = '0;
    for (int i = 0; i < 21; i++) begin
      instruction = delta_joint_pkg::program_rom(5'(i));
      if (5'(i) < pc) f_clocks_before = f_clocks_before + f_op_clocks(instruction[delta_joint_pkg::InstructionWidth-1 -: 2]);
    end
  endfunction
  logic [10:0] f_elapsed_q = '0;  // clocks since ap_start was taken (0 while idle)
  always_ff @(posedge ap_clk) begin
    if (ap_rst) f_elapsed_q <= '0;
    else if (state_q == StateIdle) f_elapsed_q <= ap_start ? 11'd1 : 11'd0;
    else if (f_elapsed_q != '1) f_elapsed_q <= f_elapsed_q + 11'd1;
  end
  logic [10:0] f_within;  // clocks into the present instruction
  assign f_within = (op == delta_joint_pkg::OpMac && phase_q == 3'd6) ? 11'd6 + 11'(bit_q) : 11'(phase_q);
  always_comb begin
    if (f_past_valid && state_q == StateLoad) the_load_takes_its_cycles: assert (load_q <= 3'(FLoad - 1) && f_elapsed_q == 11'(load_q) + 11'd1);
    the_load_takes_its_cycles_c: cover (f_past_valid && state_q == StateLoad && load_q == 3'(FLoad - 1));
    // Lemmas: the instruction is the microprogram's at pc, and each instruction's phase (and bit)
    // stays within its clocks; then the run is where the microprogram says, f_elapsed_q clocks
    // after ap_start.
    if (f_past_valid) the_instruction_is_the_programs_at_pc: assert (joint_q <= 2'd2 && pc_q <= 5'd20 &&
        instruction_q == delta_joint_pkg::program_rom(pc_q));
    the_instruction_is_the_programs_at_pc_c: cover (f_past_valid && state_q == StateRun && pc_q == 5'd2);
    if (f_past_valid && state_q == StateRun) the_phase_stays_within_its_instruction: assert (
        op == delta_joint_pkg::OpInit ? phase_q <= 3'd2 :
        op == delta_joint_pkg::OpMac ? (phase_q <= 3'd6 && (phase_q != 3'd6 || bit_q <= 5'd23)) : phase_q <= 3'd1);
    the_phase_stays_within_its_instruction_c: cover (f_past_valid && state_q == StateRun && op == delta_joint_pkg::OpMac && phase_q == 3'd6 && bit_q == 5'd5);
    if (f_past_valid && state_q == StateRun) the_run_follows_the_microprogram: assert (
        f_elapsed_q == 11'(FLoad + 1) + 11'(joint_q) * 11'(FJoint) + f_clocks_before(pc_q) + f_within);
    the_run_follows_the_microprogram_c: cover (f_past_valid && state_q == StateRun && op == delta_joint_pkg::OpStoreState && phase_q == 3'd1);
    if (f_past_valid && current_valid_q != '0) a_current_is_out_at_its_cycle: assert (
        (current_valid_q == 3'b001 && f_elapsed_q == 11'(FLoad + FJoint + 1)) ||
        (current_valid_q == 3'b010 && f_elapsed_q == 11'(FLoad + 2 * FJoint + 1)) ||
        (current_valid_q == 3'b100 && f_elapsed_q == 11'(FLoad + 3 * FJoint + 1)));
    a_current_is_out_at_its_cycle_c: cover (f_past_valid && current_valid_q[2]);
    if (f_past_valid && state_q == StateDone) done_at_the_runs_end: assert (f_elapsed_q == 11'(FLoad + 3 * FJoint + 1));
    done_at_the_runs_end_c: cover (f_past_valid && state_q == StateDone);
  end
`endif
endmodule
