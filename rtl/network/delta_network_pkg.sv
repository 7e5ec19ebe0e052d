// Fixed-point formats and casts of the network, mirroring hls/README.md "Fixed-point specification
// of the network (version 1)" step by step (section numbers below are the spec's).
//
// A code is two's complement; Q(i.f) in b bits means value = code * 2^-f. The only two casts are
// round_shift(x, s) = (x + 2^(s-1)) >>> s (round half up) and sat_b(x) (clamp to b bits); the
// network adds each rounding half early (into a bias or table word) so that a cast is only a
// shift and a saturation, off the carry chains. Widths
// are the spec's defaults (golden::Formats); the bit-exact tests against the golden model fail if
// the two ever disagree. Functions assign their name (yosys 0.23 reads no `return`).
package delta_network_pkg;
  localparam int unsigned NumInputs  = 3;
  localparam int unsigned NumHidden  = 25;
  localparam int unsigned NumOutputs = 3;

  // 1-2. Raw input x: metres, Q4.28 in 32 bits; scaled input u = sat_16(round_shift(x - centre,
  // shift)), Q1.15. The difference takes 33 bits, plus the rounding half 34.
  localparam int unsigned InputWidth       = 32;
  localparam int unsigned ScaledInputWidth = 16;
  localparam int unsigned InputShiftWidth  = 8;   // shift_j (28 + e_j - 15), as exported
  localparam int unsigned OffsetWidth      = InputWidth + 2;

  // 3. Hidden pre-activation: IW' Q5.19 in 24 bits, b1' Q4.34 in 38 bits, products 40 bits,
  // acc1 Q7.34 in 41 bits (exact), n = sat_21(round_shift(acc1, 17)) Q4.17.
  localparam int unsigned Weight1Width    = 24;
  localparam int unsigned Bias1Width      = 38;
  localparam int unsigned Product1Width   = ScaledInputWidth + Weight1Width;
  localparam int unsigned Accum1Width     = 41;
  localparam int unsigned TanhInputWidth  = 21;
  localparam int unsigned TanhInputShift  = 17;  // 34 - 17 fraction bits

  // 4. tanh: a = min(|n|, 2^20 - 1); i = a >> 10 (1024 segments), f = a & 0x3FF;
  // m = round_shift(T[i] * 2^10 + D[i] * f, 13); h = n < 0 ? -m : m, Q1.17 in 18 bits.
  localparam int unsigned TanhMagnitudeWidth = TanhInputWidth - 1;                 // a: 20 bits
  localparam int unsigned TanhFractionWidth  = 10;                                 // f
  localparam int unsigned TanhIndexWidth     = TanhMagnitudeWidth - TanhFractionWidth;  // i
  localparam int unsigned TanhSegments       = 1 << TanhIndexWidth;                // 1024
  localparam int unsigned TanhEntryWidth     = 20;  // T: unsigned Q0.20
  localparam int unsigned TanhSlopeWidth     = 15;  // D >= 0, up to 2^13 at i = 0: unsigned 15 bits read the file
  localparam int unsigned TanhGuardBits      = 3;
  localparam int unsigned InterpolationWidth = TanhEntryWidth + TanhFractionWidth + 1;  // < 2^31
  localparam int unsigned HiddenWidth        = 18;  // h: Q1.17

  // 5-6. Output: LW' Q7.17 in 24 bits, b2' Q10.34 in 44 bits, products 42 bits, acc2 Q13.34 in
  // 47 bits (exact), alpha = sat_24(round_shift(acc2, 20)): degrees, Q10.14.
  localparam int unsigned Weight2Width  = 24;
  localparam int unsigned Bias2Width    = 44;
  localparam int unsigned Product2Width = HiddenWidth + Weight2Width;
  localparam int unsigned Accum2Width   = 47;
  localparam int unsigned OutputShift   = 20;
  localparam int unsigned OutputWidth   = 24;

  // The generated $readmemh files (hls/README.md, "Export for RTL").
  localparam InputCentreFile = "input_centre.mem";  // 3 x 32 bits
  localparam InputShiftFile  = "input_shift.mem";   // 3 shift_j
  localparam Weight1File     = "input_weights.mem"; // IW', H x 3 row-major
  localparam Bias1File       = "hidden_bias.mem";   // b1', H
  localparam TanhEntryFile   = "tanh_table.mem";    // T, 1024
  localparam TanhSlopeFile   = "tanh_slope.mem";    // D, 1024
  localparam Weight2File     = "output_weights.mem";// LW', 3 x H row-major
  localparam Bias2File       = "output_bias.mem";   // b2', 3

  // sat_b of a Wide-bit value, as a b-bit code: in range when the bits above b-1 copy the sign.
  // 2. u = sat_16(shifted offset).
  function automatic logic signed [ScaledInputWidth-1:0] saturate_scaled_input(
      input logic signed [OffsetWidth-1:0] value);
    logic all_equal;
    all_equal = (value[OffsetWidth-1:ScaledInputWidth-1] == '0) ||
                (value[OffsetWidth-1:ScaledInputWidth-1] == '1);
    if (all_equal) saturate_scaled_input = value[ScaledInputWidth-1:0];
    else if (value[OffsetWidth-1]) saturate_scaled_input = {1'b1, {(ScaledInputWidth - 1){1'b0}}};
    else saturate_scaled_input = {1'b0, {(ScaledInputWidth - 1){1'b1}}};
  endfunction

  // 3-4. n = sat_21(round_shift(acc1, 17)) and a = min(|n|, 2^20 - 1), given acc1 + 2^16 (the
  // rounding half, added by the network to the bias). With s = the shifted accumulator (24 bits),
  // sat_21 only clamps s to [-2^20, 2^20 - 1], so min(|n|, 2^20 - 1) = min(|s|, 2^20 - 1):
  // a = |s| mod 2^20 (a 20-bit negation, the one carry chain), or 2^20 - 1 when |s| >= 2^20
  // (decided from s beside the chain; the network applies it a cycle later). The sign of n is
  // the sign of s.
  localparam int unsigned Accum1RoundedWidth = Accum1Width - TanhInputShift;
  function automatic logic [TanhMagnitudeWidth-1:0] tanh_magnitude_low(input logic signed [Accum1Width-1:0] accum_plus_half);
    logic [Accum1RoundedWidth-1:0] shifted;  // s
    shifted = accum_plus_half[Accum1Width-1:TanhInputShift];
    if (shifted[Accum1RoundedWidth-1]) tanh_magnitude_low = TanhMagnitudeWidth'(0) - shifted[TanhMagnitudeWidth-1:0];
    else tanh_magnitude_low = shifted[TanhMagnitudeWidth-1:0];
  endfunction

  function automatic logic tanh_magnitude_saturates(input logic signed [Accum1Width-1:0] accum_plus_half);
    logic [Accum1RoundedWidth-1:0] shifted;  // s
    shifted = accum_plus_half[Accum1Width-1:TanhInputShift];
    if (shifted[Accum1RoundedWidth-1]) begin  // s <= -2^20
      tanh_magnitude_saturates = shifted[Accum1RoundedWidth-1:TanhMagnitudeWidth] != '1 ||
                                 shifted[TanhMagnitudeWidth-1:0] == '0;
    end else begin  // s >= 2^20
      tanh_magnitude_saturates = shifted[Accum1RoundedWidth-1:TanhMagnitudeWidth] != '0;
    end
  endfunction

  // 4. m = round_shift(interpolation, 13), given interpolation + 2^12 (the rounding half, added
  // by the network to T[i]): a shift. m <= 2^17 - 1 (the table is capped), so the top bits of the
  // shifted value are zero and are dropped without saturation.
  localparam int unsigned TanhRoundShift = TanhFractionWidth + TanhGuardBits;
  function automatic logic [HiddenWidth-2:0] tanh_round(input logic [InterpolationWidth-1:0] interpolation_plus_half);
    tanh_round = interpolation_plus_half[TanhRoundShift +: HiddenWidth - 1];
  endfunction

  // 5. alpha = sat_24(round_shift(acc2, 20)), given acc2 + 2^19 (the rounding half, in the
  // accumulator's initial value): the shift and the saturation.
  localparam int unsigned Accum2RoundedWidth = Accum2Width - OutputShift;
  function automatic logic signed [OutputWidth-1:0] output_code(input logic signed [Accum2Width-1:0] accum_plus_half);
    logic [Accum2RoundedWidth-1:0] shifted;
    logic                          in_range;
    shifted  = accum_plus_half[Accum2Width-1:OutputShift];
    in_range = (shifted[Accum2RoundedWidth-1:OutputWidth-1] == '0) ||
               (shifted[Accum2RoundedWidth-1:OutputWidth-1] == '1);
    if (in_range) output_code = shifted[OutputWidth-1:0];
    else if (shifted[Accum2RoundedWidth-1]) output_code = {1'b1, {(OutputWidth - 1){1'b0}}};
    else output_code = {1'b0, {(OutputWidth - 1){1'b1}}};
  endfunction
endpackage
