// The 3-25-3 tanh inverse-kinematics network in fixed point, bit-exact to the golden model of
// hls/README.md (formats and casts: delta_network_pkg.sv), with the block-level interface a Vitis
// HLS export of the HLS top has.
//
// Interface (Vitis HLS ap_ctrl_hs, as the HLS export's but for the inputs: u_0..u_2 are the scaled
// inputs of spec step 2, which the host computes from the position and the model's input scaling,
// golden::scale_input; the board's setpoints carry them): ap_start is sampled while ap_idle is high and must stay high until ap_ready;
// ap_ready is high in the cycle the inputs u_0..u_2 are captured (the first one). ap_done and
// y_k_ap_vld pulse together for one cycle with y_0..y_2 valid; y keeps its value until the next
// ap_done. ap_rst is synchronous and active high. Latency from the ap_start edge to ap_done:
// Steps + 14 cycles, Steps = (NumHidden + 1) * ReuseFactor / NumHidden (40 at 25, 92 at 75).
//
// ReuseFactor (hls4ml's meaning): multiplications per multiplier per inference. Each layer does
// 3 * NumHidden products with 3 * NumHidden / ReuseFactor multipliers ("lanes"):
//   25: 3 + 3 lanes, one hidden neuron per cycle;  75: 1 + 1 lanes, one neuron every 3 cycles.
// A layer-1 lane is 16 x 24 bits (2 iCE40 DSPs), a layer-2 lane 18 x 24 (3 DSPs), the tanh
// interpolation 14 x 10 (1 DSP): 75 fits the UP5K's 8 DSPs with 6, 25 needs 16.
//
// Schedule: a token stream steps through (neuron h, group g), h = 0..NumHidden, g = 0..Groups-1,
// one token per cycle. Layer 1 of neuron h uses the tokens (h, *); layer 2 of neuron h uses the
// tokens (h + 1, *) nine stages later, when tanh(h) is ready (the extra neuron NumHidden only
// finishes layer 2 of the last real neuron). Stages of a token:
//   S0  weight RAM address                           S6  tanh ROM data (T[i], D[i])
//   S1  weight data; lane input; bias RAM address    S7  D[i] * f
//   S2  multiply u * IW'                             S8  T[i] * 2^10 + D[i] * f; LW' ROM address
//   S3  acc1 = b1' + sum of products                 S9  h = +-round_shift(.., 13) (a shift); LW' data
//   S4  n = sat_21(round_shift(acc1, 17)) and        S10 multiply h * LW'
//       a = min(|n|, 2^20 - 1) as |s| mod 2^20 and   S11 acc2 += product
//       |s| >= 2^20, s = acc1 >> 17 (pkg)            S12 round_shift(acc2, 20) (carry resolved)
//   S5  a (the clamp); tanh ROM address i, fraction f S13 alpha = sat_24(..) (last token only)
// The inputs u are registered at the accept, so they are ready in S1 of token 0.
//
// The model (IW', b1', LW', b2' + 2^19) is data in block RAM, written through the model port in
// the board's clock (model_clk_i): word n of a load (docs/board_link.md, "The model"; the board's
// model_loader.sv) is written at address n of every one of the four memories (256 words each),
// which read their own frames only: IW' at 0 .. 74, b1' at 75 .. 99, LW' at 100 .. 174 (LW'_ok at
// 100 + 25o + k), b2'_o + 2^19 at 175 + o (a 48-bit memory of its own); no decoder. The neuron-0
// tokens of layer 2, whose product is never used, add the bias instead: their S11 product
// register takes b2'_o + 2^19 from the bias memory (read in S9), and the accumulators, zeroed at
// the accept, take it as the first term. ModelFromFiles = 1 (the standalone network and its tests): the memories start with
// the .mem files of MemDir and b2' comes from output_bias.mem (the model port still writes the
// memories); 0 (the board): every memory starts at zero and the model comes only through the port.
// The tanh tables stay ROMs of MemDir in both.
module delta_network #(
  parameter int unsigned ReuseFactor    = 75,   // 25 or 75, see above
  parameter              MemDir         = ".",  // directory of the .mem files (+delta_mem_dir in sim)
  parameter bit          ModelFromFiles = 1'b1, // the model from MemDir's files (1) or the port only (0)
  // The inputs captured at the accept (1, ap_ctrl_hs), or read where they are (0, the board: its
  // setpoint buffer's RAM output register holds them from ap_start until long after ap_done)
  parameter bit          CaptureInputs  = 1'b1
) (
  input  logic                                              ap_clk,
  input  logic                                              ap_rst,
  input  logic                                              ap_start,
  output logic                                              ap_done,
  output logic                                              ap_idle,
  output logic                                              ap_ready,
  input  logic signed [delta_network_pkg::ScaledInputWidth-1:0] u_0,  // scaled inputs, Q1.15 (spec step 2)
  input  logic signed [delta_network_pkg::ScaledInputWidth-1:0] u_1,
  input  logic signed [delta_network_pkg::ScaledInputWidth-1:0] u_2,
  output logic signed [delta_network_pkg::OutputWidth-1:0]  y_0,  // degrees, Q10.14
  output logic                                              y_0_ap_vld,
  output logic signed [delta_network_pkg::OutputWidth-1:0]  y_1,
  output logic                                              y_1_ap_vld,
  output logic signed [delta_network_pkg::OutputWidth-1:0]  y_2,
  output logic                                              y_2_ap_vld,
  // the model port (board clock): word model_word_i of frame model_address_i
  input  logic                                              model_clk_i,
  input  logic                                              model_write_i,
  input  logic [7:0]                                        model_address_i,
  input  logic [47:0]                                       model_word_i
);
  // Formats from the package (yosys 0.23 reads no `import`: qualified names only).
  localparam int unsigned NumInputs          = delta_network_pkg::NumInputs;
  localparam int unsigned NumHidden          = delta_network_pkg::NumHidden;
  localparam int unsigned NumOutputs         = delta_network_pkg::NumOutputs;
  localparam int unsigned ScaledInputWidth   = delta_network_pkg::ScaledInputWidth;
  localparam int unsigned Weight1Width       = delta_network_pkg::Weight1Width;
  localparam int unsigned Bias1Width         = delta_network_pkg::Bias1Width;
  localparam int unsigned Product1Width      = delta_network_pkg::Product1Width;
  localparam int unsigned Accum1Width        = delta_network_pkg::Accum1Width;
  localparam int unsigned TanhMagnitudeWidth = delta_network_pkg::TanhMagnitudeWidth;
  localparam int unsigned TanhFractionWidth  = delta_network_pkg::TanhFractionWidth;
  localparam int unsigned TanhSegments       = delta_network_pkg::TanhSegments;
  localparam int unsigned TanhEntryWidth     = delta_network_pkg::TanhEntryWidth;
  localparam int unsigned TanhSlopeWidth     = delta_network_pkg::TanhSlopeWidth;
  localparam int unsigned InterpolationWidth = delta_network_pkg::InterpolationWidth;
  localparam int unsigned HiddenWidth        = delta_network_pkg::HiddenWidth;
  localparam int unsigned Weight2Width       = delta_network_pkg::Weight2Width;
  localparam int unsigned Bias2Width         = delta_network_pkg::Bias2Width;
  localparam int unsigned Product2Width      = delta_network_pkg::Product2Width;
  localparam int unsigned Accum2Width        = delta_network_pkg::Accum2Width;
  localparam int unsigned OutputWidth        = delta_network_pkg::OutputWidth;

  localparam int unsigned Groups      = ReuseFactor / NumHidden;   // tokens per neuron
  localparam int unsigned Lanes       = NumInputs / Groups;        // multipliers per layer
  localparam int unsigned Steps       = (NumHidden + 1) * Groups;  // tokens per inference
  localparam int unsigned LastStage   = 12;
  localparam int unsigned StepWidth   = $clog2(Steps + 1);
  localparam int unsigned NeuronWidth = $clog2(NumHidden + 1);
  localparam int unsigned GroupWidth  = (Groups > 1) ? $clog2(Groups) : 1;
  localparam int unsigned Weight1Depth        = NumHidden * NumInputs;
  localparam int unsigned Weight2Depth        = NumOutputs * NumHidden;
  localparam int unsigned ModelAddressWidth   = 8;    // the model port's frame number: every memory's address
  localparam int unsigned ModelDepth          = 256;
  localparam int unsigned Bias2WordWidth      = 48;  // b2' + 2^19: Accum2Width bits
  // The model port's frame numbers (docs/board_link.md; delta_board_pkg's Model*Frame facts,
  // checked in board_core.sv).
  localparam int unsigned Bias1Frame   = Weight1Depth;
  localparam int unsigned Weight2Frame = Bias1Frame + NumHidden;
  localparam int unsigned Bias2Frame   = Weight2Frame + Weight2Depth;

  if (ReuseFactor % NumHidden != 0 || NumInputs % (ReuseFactor / NumHidden) != 0 ||
      NumOutputs != NumInputs) begin : g_bad_reuse_factor
    $error("delta_network: ReuseFactor must be NumHidden * k with k dividing NumInputs (25 or 75)");
  end

  // ---- control: accept, token stream, done ----------------------------------------------------
  logic                   busy_q /*verilator public_flat_rd*/;  // read by the simulation's idle skip
  logic [StepWidth-1:0]   step_q;
  logic [NeuronWidth-1:0] neuron_q;
  logic [GroupWidth-1:0]  group_q;
  logic                   output_q;  // S13 of the last token: the outputs are saturated
  logic                   done_q;

  // The token in stage k (1..LastStage): valid_q[k]; its neuron and group only where they are
  // read: neuron_s1 (the bias address), group_s1 and group_s2 (the lane input, the bias select),
  // neuron_s7 and group_s7 (the LW' address), group_s9 .. group_s11 (the layer-2 bias, the
  // accumulator select). The stream is contiguous and starts at (0, 0), so a stage far down the
  // pipeline counts its own tokens (from (0, 0) again after a cycle without one) instead of a
  // delay line carrying them: stages 7 and 9 count, the others are one-stage copies. The rest
  // follows from valid_q too: the last token is in S12 when S12 holds a token and S11 none, and
  // the token in S9 is a neuron-0 token when stage 9 + Groups (the token Groups earlier) holds none.
  logic [LastStage:1]     valid_q;
  logic [NeuronWidth-1:0] neuron_s1, neuron_s7;
  logic [GroupWidth-1:0]  group_s1, group_s2, group_s7, group_s9, group_s10, group_s11;

  wire accept     = ap_start && !busy_q;
  wire issue      = busy_q && (step_q != StepWidth'(Steps));
  wire last_group = (group_q == GroupWidth'(Groups - 1));
  // The last token in S12: every output accumulator is complete.
  wire final_token = valid_q[LastStage] && !valid_q[LastStage-1];

  always_ff @(posedge ap_clk) begin
    if (ap_rst) begin
      busy_q   <= 1'b0;
      step_q   <= '0;
      neuron_q <= '0;
      group_q  <= '0;
      output_q <= 1'b0;
      done_q   <= 1'b0;
      valid_q  <= '0;
    end else begin
      output_q <= final_token;
      done_q   <= output_q;
      valid_q <= {valid_q[LastStage-1:1], issue};
      if (accept) begin
        busy_q   <= 1'b1;
        step_q   <= '0;
        neuron_q <= '0;
        group_q  <= '0;
      end else if (issue) begin
        step_q   <= step_q + 1'b1;
        group_q  <= last_group ? '0 : group_q + 1'b1;
        neuron_q <= last_group ? neuron_q + 1'b1 : neuron_q;
      end
      if (output_q) busy_q <= 1'b0;
    end
  end

  always_ff @(posedge ap_clk) begin
    neuron_s1 <= neuron_q;
    group_s1  <= group_q;
    group_s2  <= group_s1;
    // The next token of stage 7 (that of a token now in S7 is the one after it).
    if (!valid_q[7]) begin
      neuron_s7 <= '0;
      group_s7  <= '0;
    end else if (group_s7 == GroupWidth'(Groups - 1)) begin
      neuron_s7 <= neuron_s7 + 1'b1;
      group_s7  <= '0;
    end else begin
      group_s7 <= group_s7 + 1'b1;
    end
    if (!valid_q[9] || group_s9 == GroupWidth'(Groups - 1)) group_s9 <= '0;
    else group_s9 <= group_s9 + 1'b1;
    group_s10 <= group_s9;
    group_s11 <= group_s10;
  end

  // ---- spec step 2 is the host's: the inputs are the scaled codes u, captured at the accept ----
  // (or, CaptureInputs = 0, held by the caller from ap_start to ap_done)
  logic signed [ScaledInputWidth-1:0] u [NumInputs];
  logic signed [ScaledInputWidth-1:0] scaled_q [NumInputs];
  assign u[0] = u_0;
  assign u[1] = u_1;
  assign u[2] = u_2;
  for (genvar j = 0; j < NumInputs; j++) begin : g_input
    if (CaptureInputs) begin : g_capture
      always_ff @(posedge ap_clk) begin
        if (accept) scaled_q[j] <= u[j];
      end
    end else begin : g_held
      assign scaled_q[j] = u[j];
    end
  end

  // ---- layer 1: S0 addresses, S1 data, S2 multiply, S3 accumulate -------------------------------
  logic signed [Weight1Width-1:0]     weight1_q [Lanes];     // S2
  logic signed [ScaledInputWidth-1:0] lane_input_q [Lanes];  // S2
  logic signed [Product1Width-1:0]    product1_q [Lanes];    // S3
  logic signed [Accum1Width-1:0]      bias1_s3_q;            // b1' + 2^16
  logic                               first_group_s3_q;      // the token in S3 starts a neuron
  logic signed [Accum1Width-1:0]      accum1_q;              // S4

  for (genvar lane = 0; lane < Lanes; lane++) begin : g_layer1_lane
    // Token (h, g), lane l multiplies u[g * Lanes + l] by IW'[h][g * Lanes + l], stored at
    // h * NumInputs + g * Lanes + l = step * Lanes + l (row-major IW').
    logic [Weight1Width-1:0] weight1_word;
    model_ram #(
      .Depth       (ModelDepth),
      .Width       (Weight1Width),
      .InitFromFile(ModelFromFiles),
      .MemDir      (MemDir),
      .MemFile     (delta_network_pkg::Weight1File),
      .FileAddress (0)
    ) u_weight1_ram (
      .clk_i          (ap_clk),
      .address_i      (ModelAddressWidth'(step_q * Lanes + lane)),
      .data_o         (weight1_word),
      .write_clk_i    (model_clk_i),
      .write_i        (model_write_i),
      .write_address_i(model_address_i),
      .write_data_i   (model_word_i[Weight1Width-1:0])
    );

    always_ff @(posedge ap_clk) begin
      // scaled_q is valid from S1 of token 0 on.
      lane_input_q[lane] <= scaled_q[group_s1 * Lanes + lane];
      weight1_q[lane]    <= signed'(weight1_word);
      product1_q[lane]   <= Product1Width'(lane_input_q[lane]) * Product1Width'(weight1_q[lane]);
    end
  end

  logic [Bias1Width-1:0] bias1_word;
  model_ram #(
    .Depth       (ModelDepth),
    .Width       (Bias1Width),
    .InitFromFile(ModelFromFiles),
    .MemDir      (MemDir),
    .MemFile     (delta_network_pkg::Bias1File),
    .FileAddress (Bias1Frame)
  ) u_bias1_ram (
    .clk_i          (ap_clk),
    .address_i      (ModelAddressWidth'(Bias1Frame) + ModelAddressWidth'(neuron_s1)),
    .data_o         (bias1_word),
    .write_clk_i    (model_clk_i),
    .write_i        (model_write_i),
    .write_address_i(model_address_i),
    .write_data_i   (model_word_i[Bias1Width-1:0])
  );

  // S3: acc1 starts from the bias at the neuron's first group; exact in 41 bits (spec step 3).
  // The bias memory is read with the token in S1 (its output register holds b1' in S2, no copy of
  // it in the fabric). The accumulator carries + 2^16, the rounding half of n = round_shift(acc1,
  // 17), added to the bias in S2, so S4 only shifts and saturates. The bias/accumulator select is a register
  // (decoded in S2). The 41-bit add is a carry-select adder: the low 20 bits and the high 21
  // bits, the latter both without and with the low carry, chosen by it (three short carry chains
  // side by side instead of one of 41 bits: the recurrence must fit one cycle).
  localparam int unsigned Accum1LowWidth  = 20;
  localparam int unsigned Accum1HighWidth = Accum1Width - Accum1LowWidth;
  always_ff @(posedge ap_clk) begin
    logic signed [Accum1Width-1:0]   base;     // b1' + 2^16 or acc1
    logic signed [Accum1Width-1:0]   addend;   // the products of the token
    logic [Accum1LowWidth:0]         low;      // with its carry out
    logic [Accum1HighWidth-1:0]      high_without_carry;
    logic [Accum1HighWidth-1:0]      high_with_carry;  // the carry enters below the LSB as 1 + 1
    bias1_s3_q       <= Accum1Width'(signed'(bias1_word)) + (Accum1Width'(1) <<< (delta_network_pkg::TanhInputShift - 1));
    first_group_s3_q <= (group_s2 == '0);
    base   = first_group_s3_q ? bias1_s3_q : accum1_q;
    addend = '0;
    for (int lane = 0; lane < Lanes; lane++) addend = addend + Accum1Width'(product1_q[lane]);
    low                = {1'b0, base[Accum1LowWidth-1:0]} + {1'b0, addend[Accum1LowWidth-1:0]};
    high_without_carry = base[Accum1Width-1:Accum1LowWidth] + addend[Accum1Width-1:Accum1LowWidth];
    high_with_carry    = Accum1HighWidth'(({base[Accum1Width-1:Accum1LowWidth], 1'b1} +
                                           {addend[Accum1Width-1:Accum1LowWidth], 1'b1}) >> 1);
    accum1_q <= {low[Accum1LowWidth] ? high_with_carry : high_without_carry,
                 low[Accum1LowWidth-1:0]};
  end

  // ---- tanh (spec step 4): S4..S9 -------------------------------------------------------------
  logic [TanhMagnitudeWidth-1:0]        magnitude_low_q;        // S5: |s| mod 2^20
  logic                                 magnitude_saturates_q;  // S5: |s| >= 2^20
  logic [TanhMagnitudeWidth-1:0]        magnitude;              // S5: a
  logic [TanhFractionWidth-1:0]         fraction_s6_q, fraction_s7_q;
  logic [TanhEntryWidth-1:0]            entry_word, entry_s7_q, entry_s8_q;
  logic [TanhSlopeWidth-1:0]            slope_word, slope_s7_q;
  logic [TanhSlopeWidth+TanhFractionWidth-1:0] slope_product_q;  // S8, D >= 0
  logic [InterpolationWidth-1:0]        interpolation_q;  // S9
  logic [5:1]                           negative_q;       // sign of n, stages S5..S9
  logic signed [HiddenWidth-1:0]        activation_q;     // h of the neuron before the S10 token

  always_ff @(posedge ap_clk) begin
    magnitude_low_q       <= delta_network_pkg::tanh_magnitude_low(accum1_q);
    magnitude_saturates_q <= delta_network_pkg::tanh_magnitude_saturates(accum1_q);
    negative_q      <= {negative_q[4:1], accum1_q[Accum1Width-1]};  // sign of n = sign of acc1
    fraction_s6_q   <= magnitude[TanhFractionWidth-1:0];
    fraction_s7_q   <= fraction_s6_q;
    entry_s7_q      <= entry_word;
    slope_s7_q      <= slope_word;
    // + 2^12 (as 4 * 2^10): the rounding half of m = round_shift(.., 13), so S9 only shifts.
    entry_s8_q      <= entry_s7_q + TanhEntryWidth'(1 << (delta_network_pkg::TanhRoundShift - TanhFractionWidth - 1));
    slope_product_q <= (TanhSlopeWidth + TanhFractionWidth)'(slope_s7_q) *
                       (TanhSlopeWidth + TanhFractionWidth)'(fraction_s7_q);
    interpolation_q <= {1'b0, entry_s8_q, {TanhFractionWidth{1'b0}}} + InterpolationWidth'(slope_product_q);
    // h of neuron h is loaded by its last token in S9 and used by the tokens of h + 1; m is a bit
    // select of the interpolation (its rounding half is in the table word), so S9 only negates.
    // Every last-group slot loads (with one group, every slot, token or not): a load that is no
    // neuron's (neuron NumHidden's, or between inferences) is read only by neuron-0 tokens, whose
    // products are never used.
    if (group_s9 == GroupWidth'(Groups - 1)) begin
      activation_q <= negative_q[5]
          ? HiddenWidth'(0) - HiddenWidth'(delta_network_pkg::tanh_round(interpolation_q))
          : HiddenWidth'(delta_network_pkg::tanh_round(interpolation_q));
    end
  end

  // The clamp to 2^20 - 1 is applied here, off the negation's carry chain.
  assign magnitude = magnitude_saturates_q ? '1 : magnitude_low_q;

  readmemh_rom #(
    .Depth  (TanhSegments),
    .Width  (TanhEntryWidth),
    .MemDir (MemDir),
    .MemFile(delta_network_pkg::TanhEntryFile)
  ) u_tanh_entry_rom (
    .clk_i    (ap_clk),
    .address_i(magnitude[TanhMagnitudeWidth-1:TanhFractionWidth]),
    .data_o   (entry_word)
  );
  readmemh_rom #(
    .Depth  (TanhSegments),
    .Width  (TanhSlopeWidth),
    .MemDir (MemDir),
    .MemFile(delta_network_pkg::TanhSlopeFile)
  ) u_tanh_slope_rom (
    .clk_i    (ap_clk),
    .address_i(magnitude[TanhMagnitudeWidth-1:TanhFractionWidth]),
    .data_o   (slope_word)
  );

  // ---- layer 2: S8 addresses, S9 data, S10 multiply, S11 accumulate -----------------------------
  // S11: lane l's product, or for a neuron-0 token (whose product is never needed) the bias
  // b2'_o + 2^19 of the lane's output, read from the bias memory in S9. The select sits before
  // the register (the DSPs' outputs are far from the fabric; the accumulators' carry chains start
  // at this register).
  logic signed [Accum2Width-1:0]   product2_q [Lanes];
  // acc2 of output o = accum2_high_q[o] * 2^24 + accum2_low_q[o], the low part 25 bits wide: its
  // bit 24 is the carry of the last update, added to the high part by the next one. Two 24-bit
  // carry chains instead of one of 47 (the DSP's product register is far from the fabric).
  localparam int unsigned Accum2LowWidth  = 24;
  localparam int unsigned Accum2HighWidth = Accum2Width - Accum2LowWidth;
  logic [Accum2LowWidth:0]                accum2_low_q [NumOutputs];
  logic signed [Accum2HighWidth-1:0]      accum2_high_q [NumOutputs];

  // b2' + 2^19 of output o (+ 2^19: the rounding half of alpha = round_shift(acc2, 20), so S12 only
  // shifts and saturates): from the bias memory's words 175 + o, or with ModelFromFiles from
  // output_bias.mem (constants).
  logic [NumOutputs*Accum2Width-1:0] file_biases;
  if (ModelFromFiles) begin : g_file_bias2
    logic [NumOutputs*Bias2Width-1:0] bias2_words;
    readmemh_table #(
      .Depth  (NumOutputs),
      .Width  (Bias2Width),
      .MemDir (MemDir),
      .MemFile(delta_network_pkg::Bias2File)
    ) u_bias2_table (
      .words_o(bias2_words)
    );
    for (genvar o = 0; o < NumOutputs; o++) begin : g_output
      assign file_biases[o*Accum2Width +: Accum2Width] =
          Accum2Width'(signed'(bias2_words[o*Bias2Width +: Bias2Width])) +
          (Accum2Width'(1) <<< (delta_network_pkg::OutputShift - 1));
    end
  end else begin : g_no_file_bias2
    assign file_biases = '0;
  end

  for (genvar lane = 0; lane < Lanes; lane++) begin : g_layer2_lane
    // Token (h + 1, g) in S8 addresses LW'[g * Lanes + l][h], stored at (g * Lanes + l) *
    // NumHidden + h (row-major LW'); the neuron-0 tokens read a word that is never used.
    logic [Weight2Width-1:0]        weight2_word;
    logic signed [Weight2Width-1:0] weight2_q;
    logic signed [HiddenWidth-1:0]  activation_lane_q;
    // The address is computed from the token in S7 and registered: the adder in front of the RAM
    // would otherwise share its cycle.
    logic [ModelAddressWidth-1:0]   weight2_address_q;
    always_ff @(posedge ap_clk) begin
      weight2_address_q <= ModelAddressWidth'(Weight2Frame + (group_s7 * Lanes + lane) * NumHidden) +
                           ((neuron_s7 != '0) ? ModelAddressWidth'(neuron_s7) - ModelAddressWidth'(1)
                                                : ModelAddressWidth'(0));
    end
    model_ram #(
      .Depth       (ModelDepth),
      .Width       (Weight2Width),
      .InitFromFile(ModelFromFiles),
      .MemDir      (MemDir),
      .MemFile     (delta_network_pkg::Weight2File),
      .FileAddress (Weight2Frame)
    ) u_weight2_ram (
      .clk_i          (ap_clk),
      .address_i      (weight2_address_q),
      .data_o         (weight2_word),
      .write_clk_i    (model_clk_i),
      .write_i        (model_write_i),
      .write_address_i(model_address_i),
      .write_data_i   (model_word_i[Weight2Width-1:0])
    );
    // The bias memory: its own block RAM (the LW' memory's one read port is busy every cycle),
    // read with the group of the token in S9, so its output register holds the bias in S10.
    logic [Bias2WordWidth-1:0] bias2_word;
    logic [Accum2Width-1:0]    bias2;
    logic                      bias_token_s10_q;  // the token in S10 is a neuron-0 token
    always_ff @(posedge ap_clk) begin
      logic signed [Product2Width-1:0] product;
      weight2_q         <= signed'(weight2_word);
      activation_lane_q <= activation_q;
      bias_token_s10_q  <= !valid_q[9 + Groups];  // no token Groups earlier: neuron 0
      product           = Product2Width'(activation_lane_q) * Product2Width'(weight2_q);
      product2_q[lane]  <= bias_token_s10_q ? signed'(bias2) : Accum2Width'(product);
    end
    model_ram #(
      .Depth       (ModelDepth),
      .Width       (Bias2WordWidth),
      .InitFromFile(1'b0),
      .MemDir      (MemDir),
      .MemFile     (delta_network_pkg::Bias2File),
      .FileAddress (Bias2Frame)
    ) u_bias2_ram (
      .clk_i          (ap_clk),
      .address_i      (ModelAddressWidth'(Bias2Frame + group_s9 * Lanes + lane)),
      .data_o         (bias2_word),
      .write_clk_i    (model_clk_i),
      .write_i        (model_write_i),
      .write_address_i(model_address_i),
      .write_data_i   (model_word_i[Bias2WordWidth-1:0])
    );
    assign bias2 = ModelFromFiles ? file_biases[(group_s10 * Lanes + lane) * Accum2Width +: Accum2Width]
                                  : bias2_word[Accum2Width-1:0];
    logic unused_bias_bits;
    assign unused_bias_bits = ^bias2_word[Bias2WordWidth-1:Accum2Width];
  end

  // S11: output o accumulates in group o / Lanes, lane o % Lanes; exact in 47 bits (spec step 5).
  // The accumulators start at zero (the accept); the neuron-0 token adds the bias first.
  always_ff @(posedge ap_clk) begin
    logic signed [Accum2Width-1:0] product;
    for (int o = 0; o < NumOutputs; o++) begin
      product = product2_q[o % Lanes];
      if (accept) begin
        accum2_low_q[o]  <= '0;
        accum2_high_q[o] <= '0;
      end else if (valid_q[11] && group_s11 == GroupWidth'(o / Lanes)) begin
        accum2_low_q[o]  <= {1'b0, accum2_low_q[o][Accum2LowWidth-1:0]} +
                            {1'b0, product[Accum2LowWidth-1:0]};
        accum2_high_q[o] <= accum2_high_q[o] + product[Accum2Width-1:Accum2LowWidth] +
                            Accum2HighWidth'(accum2_low_q[o][Accum2LowWidth]);
      end
    end
  end

  // ---- S12, S13: outputs (spec step 5) -----------------------------------------------------------
  // S12 adds the low part's pending carry c to the high part: resolved = acc2 >> 20 (the rounding
  // half is already in); S13 saturates it to 24 bits. In one cycle, the carry chain and the
  // range check behind it were the board's critical path.
  // resolved_q holds the high part only: the low part's bits stay in the accumulators, which no
  // token changes after the last one's S11 (until the next accept).
  logic [Accum2HighWidth-1:0]    resolved_q [NumOutputs];  // S12
  logic signed [OutputWidth-1:0] y_q [NumOutputs];         // S13
  always_ff @(posedge ap_clk) begin
    if (final_token) begin
      for (int o = 0; o < NumOutputs; o++) begin
        resolved_q[o] <= accum2_high_q[o] + Accum2HighWidth'(accum2_low_q[o][Accum2LowWidth]);
      end
    end
    if (output_q) begin
      for (int o = 0; o < NumOutputs; o++) begin
        y_q[o] <= delta_network_pkg::output_code({resolved_q[o],
                                                  accum2_low_q[o][Accum2LowWidth-1:delta_network_pkg::OutputShift],
                                                  delta_network_pkg::OutputShift'(0)});
      end
    end
  end

  assign ap_done    = done_q;
  assign ap_ready   = accept;  // the inputs are captured in the accept cycle
  assign ap_idle    = !busy_q;
  assign y_0        = y_q[0];
  assign y_1        = y_q[1];
  assign y_2        = y_q[2];
  assign y_0_ap_vld = done_q;
  assign y_1_ap_vld = done_q;
  assign y_2_ap_vld = done_q;
endmodule
