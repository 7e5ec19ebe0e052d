// Formats, coefficients and microprogram of the three-joint controller (golden: host/control joint_fixed).
//
// Every value here mirrors host/golden/include/delta/golden/joint_fixed.hpp; a CTest
// (JointRtlPackage) checks the coefficients against make_fixed_coefficients() of the defaults.
package delta_joint_pkg;

  // Ports: reference Q24.8 shaft encoder counts (32 bits), encoder counts (16), current Q1.15 A
  // (16); states Q8.24 (32); coefficients signed 24 bits, bit-serial; multiplier operand
  // saturated to 40 bits; the accumulator is exact: three 40 x 24 products + a shifted state.
  localparam int unsigned AccumulatorWidth = 66;
  // Play shift input: whole counts, signed (golden::kShiftBits).
  localparam int unsigned ShiftBits = 10;

  // Coefficients at the default design (hls/README.md, "Joint controller fixed-point formats").
  localparam logic [23:0] ReferenceGain           = 24'h6DB6DB;  //  g_ref Ts/(1+g_ref Ts) << 26
  localparam logic [23:0] VelocityEncoderGain     = 24'h555555;  //  g_v Ts/(1+g_v Ts)     << 25
  localparam logic [23:0] VelocityCurrentGain     = 24'h446F6C;  //  1/(Kacc (1+g_v Ts))   << 25
  localparam logic [23:0] DisturbanceGain         = 24'h0AAAAB;  //  g_d Ts/(1+g_d Ts)     << 22
  localparam logic [23:0] DisturbanceVelocityGain = 24'hBD7F60;  // -g_d Ts/(1+g_d Ts) Kacc << 22
  localparam logic [23:0] LawAccelerationGain     = 24'h63C0F0;  //  Kacc                  << 20
  localparam logic [23:0] LawVelocityGain         = 24'hFF00A1;  // -Kacc k_v Ts           << 20
  localparam logic [23:0] LawPositionGain         = 24'hBEA01D;  // -Kacc k_p Ts^2         << 36
  localparam logic [15:0] CurrentLimit            = 16'h4000;    //  0.5 A in Q1.15

  // Plain constants rather than enums and structs: yosys 0.23 resolves neither enum items nor
  // typedefs inside package functions.
  // State slots of one joint in one bank. The new bank of a period is the old bank of the next.
  localparam logic [2:0] SlotReference = 3'd0;  // reference, Q24.8 (written from the input)
  localparam logic [2:0] SlotRefVelocity = 3'd1;
  localparam logic [2:0] SlotRefAccel = 3'd2;
  localparam logic [2:0] SlotEncoder = 3'd3;  // encoder count (written from the input)
  localparam logic [2:0] SlotVelocity = 3'd4;  // VOB
  localparam logic [2:0] SlotDisturbance = 3'd5;  // DOB
  localparam logic [2:0] SlotCurrent = 3'd6;  // applied current, Q1.15 sign-extended
  localparam logic [2:0] SlotShift = 3'd7;  // play shift s, whole counts (written from the input)
  localparam logic [2:0] SlotUnused = 3'd7;  // as a destination: none

  // Operations.
  localparam logic [1:0] OpInit = 2'd0;  // acc = (a << frac) + 2^(shift-1)
  localparam logic [1:0] OpMac = 2'd1;  // acc += coefficient * sat40(((a - b) << operand_shift) - c)
  localparam logic [1:0] OpStoreState = 2'd2;  // new[dest] = sat32(acc >>> shift)
  localparam logic [1:0] OpStoreCurrent = 2'd3;  // new[dest] = clamp(acc >>> shift, +-CurrentLimit), also the output

  // Source banks (a source is {bank[1:0], slot[2:0]}).
  localparam logic [1:0] SourceZero = 2'd0;
  localparam logic [1:0] SourceOld = 2'd1;  // bank of the previous period
  localparam logic [1:0] SourceNew = 2'd2;  // bank being written this period

  // Left shifts of the operand difference.
  localparam logic [2:0] Shift0 = 3'd0;
  localparam logic [2:0] Shift8 = 3'd1;  // Q.8 reference -> encoder counts Q.8
  localparam logic [2:0] Shift9 = 3'd2;  // Q1.15 current -> Q.24
  localparam logic [2:0] Shift16 = 3'd3;  // Q.8 reference -> Q.24
  localparam logic [2:0] Shift24 = 3'd4;  // counts -> Q.24

  // Coefficient selectors.
  localparam logic [3:0] CoefReference = 4'd0;
  localparam logic [3:0] CoefVelocityEncoder = 4'd1;
  localparam logic [3:0] CoefVelocityCurrent = 4'd2;
  localparam logic [3:0] CoefDisturbance = 4'd3;
  localparam logic [3:0] CoefDisturbanceVelocity = 4'd4;
  localparam logic [3:0] CoefLawAcceleration = 4'd5;
  localparam logic [3:0] CoefLawVelocity = 4'd6;
  localparam logic [3:0] CoefLawPosition = 4'd7;

  localparam int unsigned SourceWidth = 5;
  localparam int unsigned InstructionWidth = 2 + 3 * SourceWidth + 3 + 4 + 5 + 5 + 3;

  // Sources. An instruction is {op, a, b, c, operand_shift, coefficient, frac, shift, dest}.
  localparam logic [4:0] Zero           = {SourceZero, SlotUnused};
  localparam logic [4:0] OldReference   = {SourceOld, SlotReference};
  localparam logic [4:0] OldRefVelocity = {SourceOld, SlotRefVelocity};
  localparam logic [4:0] OldRefAccel    = {SourceOld, SlotRefAccel};
  localparam logic [4:0] OldEncoder     = {SourceOld, SlotEncoder};
  localparam logic [4:0] OldVelocity    = {SourceOld, SlotVelocity};
  localparam logic [4:0] OldDisturbance = {SourceOld, SlotDisturbance};
  localparam logic [4:0] OldCurrent     = {SourceOld, SlotCurrent};
  localparam logic [4:0] NewReference   = {SourceNew, SlotReference};
  localparam logic [4:0] NewRefVelocity = {SourceNew, SlotRefVelocity};
  localparam logic [4:0] NewRefAccel    = {SourceNew, SlotRefAccel};
  localparam logic [4:0] NewEncoder     = {SourceNew, SlotEncoder};
  localparam logic [4:0] NewVelocity    = {SourceNew, SlotVelocity};
  localparam logic [4:0] NewDisturbance = {SourceNew, SlotDisturbance};
  localparam logic [4:0] OldShift       = {SourceOld, SlotShift};
  localparam logic [4:0] NewShift       = {SourceNew, SlotShift};

  // One joint's period (21 instructions), the same order of operations as fixed_update() in the golden model.
  function automatic logic [InstructionWidth-1:0] program_rom(logic [4:0] pc);
    unique case (pc)
      // Reference velocity: v' = v + beta ((r' - r) << 16 + (s' - s) << 24 - v)
      5'd0:  program_rom = {OpInit, OldRefVelocity, Zero, Zero, Shift0, CoefReference, 5'd26, 5'd26, SlotUnused};
      5'd1:  program_rom = {OpMac, NewReference, OldReference, OldRefVelocity,
                          Shift16, CoefReference, 5'd0, 5'd0, SlotUnused};
      5'd2:  program_rom = {OpMac, NewShift, OldShift, Zero, Shift24, CoefReference, 5'd0, 5'd0, SlotUnused};
      5'd3:  program_rom = {OpStoreState, Zero, Zero, Zero, Shift0, CoefReference, 5'd0, 5'd26, SlotRefVelocity};
      // Reference acceleration: a' = a + beta ((v' - v) - a)
      5'd4:  program_rom = {OpInit, OldRefAccel, Zero, Zero, Shift0, CoefReference, 5'd26, 5'd26, SlotUnused};
      5'd5:  program_rom = {OpMac, NewRefVelocity, OldRefVelocity, OldRefAccel,
                          Shift0, CoefReference, 5'd0, 5'd0, SlotUnused};
      5'd6:  program_rom = {OpStoreState, Zero, Zero, Zero, Shift0, CoefReference, 5'd0, 5'd26, SlotRefAccel};
      // VOB: v' = v + beta_v ((e' - e) << 24 + (s' - s) << 24 - v) + gamma (i << 9 - d)
      5'd7:  program_rom = {OpInit, OldVelocity, Zero, Zero, Shift0, CoefReference, 5'd25, 5'd25, SlotUnused};
      5'd8:  program_rom = {OpMac, NewEncoder, OldEncoder, OldVelocity,
                          Shift24, CoefVelocityEncoder, 5'd0, 5'd0, SlotUnused};
      5'd9:  program_rom = {OpMac, NewShift, OldShift, Zero, Shift24, CoefVelocityEncoder, 5'd0, 5'd0, SlotUnused};
      5'd10: program_rom = {OpMac, OldCurrent, Zero, OldDisturbance,
                          Shift9, CoefVelocityCurrent, 5'd0, 5'd0, SlotUnused};
      5'd11: program_rom = {OpStoreState, Zero, Zero, Zero, Shift0, CoefReference, 5'd0, 5'd25, SlotVelocity};
      // DOB: d' = d + beta_d (i << 9 - d) - beta_d Kacc (v' - v)
      5'd12: program_rom = {OpInit, OldDisturbance, Zero, Zero, Shift0, CoefReference, 5'd22, 5'd22, SlotUnused};
      5'd13: program_rom = {OpMac, OldCurrent, Zero, OldDisturbance,
                          Shift9, CoefDisturbance, 5'd0, 5'd0, SlotUnused};
      5'd14: program_rom = {OpMac, NewVelocity, OldVelocity, Zero,
                          Shift0, CoefDisturbanceVelocity, 5'd0, 5'd0, SlotUnused};
      5'd15: program_rom = {OpStoreState, Zero, Zero, Zero, Shift0, CoefReference, 5'd0, 5'd22, SlotDisturbance};
      // Eq. 5: i = d' + Kacc a' - Kacc k_v Ts (v' - v_ref') - Kacc k_p Ts^2 (e << 8 - r)
      5'd16: program_rom = {OpInit, NewDisturbance, Zero, Zero, Shift0, CoefReference, 5'd20, 5'd29, SlotUnused};
      5'd17: program_rom = {OpMac, NewRefAccel, Zero, Zero, Shift0, CoefLawAcceleration, 5'd0, 5'd0, SlotUnused};
      5'd18: program_rom = {OpMac, NewVelocity, NewRefVelocity, Zero,
                          Shift0, CoefLawVelocity, 5'd0, 5'd0, SlotUnused};
      5'd19: program_rom = {OpMac, NewEncoder, Zero, NewReference,
                          Shift8, CoefLawPosition, 5'd0, 5'd0, SlotUnused};
      default: program_rom = {OpStoreCurrent, Zero, Zero, Zero, Shift0, CoefReference, 5'd0, 5'd29, SlotCurrent};
    endcase
  endfunction

  function automatic logic [23:0] coefficient_value(logic [3:0] coefficient);
    unique case (coefficient)
      CoefReference:           coefficient_value = ReferenceGain;
      CoefVelocityEncoder:     coefficient_value = VelocityEncoderGain;
      CoefVelocityCurrent:     coefficient_value = VelocityCurrentGain;
      CoefDisturbance:         coefficient_value = DisturbanceGain;
      CoefDisturbanceVelocity: coefficient_value = DisturbanceVelocityGain;
      CoefLawAcceleration:     coefficient_value = LawAccelerationGain;
      CoefLawVelocity:         coefficient_value = LawVelocityGain;
      default:                 coefficient_value = LawPositionGain;
    endcase
  endfunction

  // The datapath only adds (joint_controller.sv, "Schedule"): a negative coefficient c multiplies
  // the operand's complement ~x = -x - 1 by |c|, and |c| is added once, so the sum is x c; the
  // rounding constant 2^(shift-1) of an OpInit whose frac differs from its shift (its bit is inside
  // the shifted state) is added with the next instruction, which is always an OpMac. Those two
  // constants are the OpMac's correction (the others are 0, and an OpInit ORs its rounding bit).
  // Both tables are constants of the program (no adder is built for them).
  function automatic logic [AccumulatorWidth-1:0] correction_at(logic [4:0] pc);
    logic [InstructionWidth-1:0] rom_word, rom_previous;  // fields of these read (a lint waiver)
    logic [23:0] c;
    logic [4:0] shift;
    rom_word = program_rom(pc);
    rom_previous = program_rom(pc - 5'd1);
    c = coefficient_value(rom_word[InstructionWidth-1-2-3*SourceWidth-3 -: 4]);
    correction_at = c[23] ? AccumulatorWidth'(24'(-c)) : '0;
    shift = rom_previous[7:3];
    if (pc != 5'd0 && rom_previous[InstructionWidth-1 -: 2] == OpInit && rom_previous[12:8] != shift)
      correction_at = correction_at + (AccumulatorWidth'(1) << (shift - 5'd1));
  endfunction

  function automatic logic [32*AccumulatorWidth-1:0] correction_table();
    for (int pc = 0; pc < 32; pc++) correction_table[AccumulatorWidth * pc +: AccumulatorWidth] = correction_at(5'(pc));
  endfunction

  // |c| when c is negative, else c: the bit-serial multiplier's 23 coefficient bits.
  function automatic logic [22:0] magnitude_of(logic [23:0] c);
    magnitude_of = c[23] ? 23'(24'(-c)) : c[22:0];
  endfunction

  function automatic logic [16*23-1:0] magnitude_table();
    for (int k = 0; k < 16; k++) magnitude_table[23 * k +: 23] = magnitude_of(coefficient_value(4'(k)));
  endfunction

  localparam logic [32*AccumulatorWidth-1:0] MacCorrections = correction_table();
  localparam logic [16*23-1:0] CoefficientMagnitudes = magnitude_table();

  function automatic logic [AccumulatorWidth-1:0] mac_correction(logic [4:0] pc);
    mac_correction = MacCorrections[AccumulatorWidth * pc +: AccumulatorWidth];
  endfunction

  function automatic logic [22:0] coefficient_magnitude(logic [3:0] coefficient);
    coefficient_magnitude = CoefficientMagnitudes[23 * coefficient +: 23];
  endfunction

  function automatic logic coefficient_negative(logic [3:0] coefficient);
    logic [23:0] rom_coefficient;  // its sign read (a lint waiver)
    rom_coefficient = coefficient_value(coefficient);
    coefficient_negative = rom_coefficient[23];
  endfunction

endpackage
