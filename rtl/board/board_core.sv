// Everything on the iCEBreaker except the PLL and the pads: the link v2 to the host
// (docs/board_link.md), the setpoint buffer, the network, the reference interpolation and the
// three joint controllers (quadrature encoders in, drive current commands out).
//
// Data path: host frames (uart_rx -> link_rx) -> setpoint_buffer (1 kHz setpoints by sample
// index) -> network_crossing -> network (ap_ctrl_hs) -> reference_interpolator (10 kHz
// references between answers) -> joint_axes (controllers, PWM + direction, safety). Telemetry
// (link_tx) reports the state once per setpoint period; commands (enable, disable, hold, clear
// fault, set home, home start) change it.
//
// Period schedule (tick of joint_axes; phase k = 0..9 within the 1 kHz segment): tick 0 the
// controllers start on the references; tick 1 of k = 0 a setpoint is played (network started);
// tick ClocksPerPeriod/2 of k = 0 the telemetry snapshot; tick ClocksPerPeriod - InterpolationLeadClocks
// the references of the next period are computed (delta_board_pkg's schedule facts).
//
// Safety: the drives run only after an accepted enable (homed, no fault) or during a bench jog; a
// fault stops the torque, turns the enable off and flushes the buffer; clear fault is refused
// while a cause persists and never re-enables. The causes: the joints' (encoder skip, following
// error, travel, watchdog: no valid frame for 250 ms with the drives on), the board's safety
// inputs (board_safety_inputs.sv: the e-stop chain open, a drive's fault line, each filtered over
// BoardInputFilterPeriods samples at tick 0) and an e-stop command (CommandEstop, taken in every
// state). Setpoints are taken only with the drives on (a disable and a fault flush), so an enable
// always starts on an empty buffer.
//
// Bench jog (command CommandJogBase + 2 j + n, docs/bench.md): taken with the drives off, no fault,
// not homing. From the clock after its frame it enables the drives with joint j's current
// +-JogCurrentCode open loop (the others 0: joint_axes overrides the controllers' currents into
// the PWM) until the JogPeriods-th tick 0 after the command, then the drives are off; a fault or a
// disable ends it at once. The controllers run meanwhile as with the drives off (reset every
// period; following, travel and watchdog disarmed), so an enable afterwards starts them clean.
//
// Timing choices the C++ model board follows (/work/helpers/gate_choices.md; t = the edge that
// ends cycle t): a safety input's cause latches at the edge of the tick-0 cycle of its
// BoardInputFilterPeriods-th sample at stop (visible from tick 1; the drive pins off from tick 2,
// as for a joint fault); the e-stop latch and a jog's start or end by command change at the edge
// after the command's frame_ok; a jog's length ends at its JogPeriods-th tick 0 (jog_q low from
// the next cycle), and in the one clock after jog_q falls the PWM's stored duties are set to 0;
// the DIR pins are low whenever the drives are off (joint_pwm).
//
// Homing (delta_board_pkg, docs/homing.md): home start (drives off) forgets the references and
// starts homing; set home gives the joints not referenced HomeCount. While homing with the drives
// on, a joint's home switch closing (rising edge, synchronised) sets its count to HomeCount, marks
// it referenced and turns the drives off (the buffer flushed); the interpolator keeps a segment's
// change from one setpoint period to the next (a jog set by a setpoint). Homing ends when every
// joint is referenced, at a hold (the jog stops) or at a fault; a disable keeps it (the counts of
// the joints not referenced are set again between jogs).
//
// Two clocks from one PLL. clk_network_i (46.5 MHz) runs the network alone: its 92-cycle latency
// is 1.98 us there. clk_i (half of it, 23.25 MHz) runs everything else. network_crossing is the
// only place where signals cross (a toggle handshake each way).
module board_core #(
  parameter int unsigned ClocksPerBit    = delta_board_pkg::LinkClocksPerBit,  // clk_i / link baud rate
  parameter int unsigned ClocksPerPeriod = delta_board_pkg::ClocksPerPeriod,   // clk_i / 10 kHz
  parameter int unsigned LedWindowBits   = delta_board_pkg::LedWindowBits,     // LED windows: 2^LedWindowBits periods
  parameter logic [15:0] HomeCount       = 16'(delta_board_pkg::HomeCount),    // encoder counts at reset and set home
  parameter              MemDir          = ".",  // directory of the network's tanh tables and identify.mem
  parameter int unsigned ModelCommitFrame = delta_board_pkg::ModelCommitFrame  // the formal covers shorten the load
) (
  input  logic       clk_i,           // board clock: link, joints
  input  logic       rst_ni,          // asynchronous assertion, synchronous release in clk_i
  input  logic       clk_network_i,   // the network's clock
  input  logic       rst_network_ni,  // asynchronous assertion, synchronous release in clk_network_i
  input  logic       uart_rx_i,
  output logic       uart_tx_o,
  output logic       led_red_o,       // a frame was dropped in the last LED window (~0.2 s)
  output logic       led_green_o,     // a frame was accepted in the last LED window
  input  logic [2:0] encoder_a_i,     // quadrature encoders, asynchronous
  input  logic [2:0] encoder_b_i,
  input  logic [2:0] home_switch_i,   // home switches, asynchronous: 1 = arm j at or above its reference
  input  logic       estop_open_i,    // asynchronous: 1 = the e-stop chain is open (stop)
  input  logic [2:0] drive_fault_i,   // asynchronous: 1 = drive j reports a fault (stop)
  output logic [2:0] drive_pwm_o,     // drive current command: PWM duty = |current| / 0.5 A
  output logic [2:0] drive_dir_o,     // drive current command: sign (1 = negative)
  output logic       drive_enable_o,  // enabled and no fault
  output logic [2:0] encoder_error_o, // sticky: encoder j skipped a quadrature state
  output logic       joint_limited_o, // sticky: a joint controller saturated an operand or state
  output logic       joint_fault_o,   // any fault latched (the joints', the board's, an e-stop) until an accepted clear fault: torque off
  output logic [delta_board_pkg::FaultCauseBits-1:0] joint_fault_cause_o,  // bits: delta_board_pkg::Fault*
  output logic [delta_board_pkg::BoardFaultBits-1:0] board_fault_cause_o,  // latched safety inputs: BoardFault* bits
  output logic       estop_latched_o, // an e-stop command latched
  output logic       stage_sync_o     // bit StageSyncBit of the periods since reset: a clock a stage can log
);
  localparam int unsigned NumInputs   = delta_network_pkg::NumInputs;
  localparam int unsigned NumOutputs  = delta_network_pkg::NumOutputs;
  localparam int unsigned InputWidth  = delta_network_pkg::ScaledInputWidth;  // the setpoints' u codes
  localparam int unsigned OutputWidth = delta_network_pkg::OutputWidth;
  localparam int unsigned TickWidth   = $clog2(ClocksPerPeriod);

  // ---- UART ---------------------------------------------------------------------------------------
  logic [7:0] rx_data, tx_data;
  logic       rx_valid, rx_frame_error, tx_valid, tx_ready;

  uart_rx #(.ClocksPerBit(ClocksPerBit)) u_uart_rx (
    .clk_i,
    .rst_ni,
    .rx_i         (uart_rx_i),
    .data_o       (rx_data),
    .data_valid_o (rx_valid),
    .frame_error_o(rx_frame_error)
  );

  uart_tx #(.ClocksPerBit(ClocksPerBit)) u_uart_tx (
    .clk_i,
    .rst_ni,
    .data_i      (tx_data),
    .data_valid_i(tx_valid),
    .data_ready_o(tx_ready),
    .tx_o        (uart_tx_o)
  );

  // ---- frames in ----------------------------------------------------------------------------------
  // public: the link tests watch what the receiver delivers (tests/rtl/test_board_link.cpp).
  logic       frame_start;
  logic       payload_valid /*verilator public_flat_rd*/;
  logic       frame_ok /*verilator public_flat_rd*/;
  logic       frame_bad /*verilator public_flat_rd*/;
  logic [7:0] frame_type /*verilator public_flat_rd*/;
  logic [7:0] frame_sequence /*verilator public_flat_rd*/;
  logic [7:0] payload_byte /*verilator public_flat_rd*/;
  logic [5:0] payload_index /*verilator public_flat_rd*/;
  logic       model_stall;

  link_rx u_link_rx (
    .clk_i,
    .rst_ni,
    .rx_data_i      (rx_data),
    .rx_valid_i     (rx_valid),
    .stall_i        (model_stall),
    .start_o        (frame_start),
    .type_o         (frame_type),
    .sequence_o     (frame_sequence),
    .payload_valid_o(payload_valid),
    .payload_index_o(payload_index),
    .payload_byte_o (payload_byte),
    .ok_o           (frame_ok),
    .bad_o          (frame_bad)
  );

  logic is_setpoint, is_command, is_identify_request, is_model;
  assign is_setpoint         = frame_type == 8'(delta_board_pkg::FrameTypeSetpoint);
  assign is_command          = frame_type == 8'(delta_board_pkg::FrameTypeCommand);
  assign is_identify_request = frame_type == 8'(delta_board_pkg::FrameTypeIdentifyRequest);
  assign is_model            = frame_type == 8'(delta_board_pkg::FrameTypeModel);

  // ---- the model (docs/board_link.md, "The model") -------------------------------------------------
  // The loader takes the model frames with the drives off: the network's memories and the play words
  // are written through its port, and the model flag rises at a commit whose CRC-32 matched.
  logic        model_loaded /*verilator public_flat_rd*/;
  logic        model_refused;
  logic        model_write /*verilator public_flat_rd*/;  // read by the simulation's idle skip
  logic [7:0]  model_address;
  logic [47:0] model_word;
  logic [31:0] model_crc;
  model_loader #(.CommitFrameNumber(ModelCommitFrame)) u_model_loader (
    .clk_i,
    .rst_ni,
    .is_model_i     (is_model),
    .payload_valid_i(payload_valid),
    .payload_index_i(payload_index[2:0]),
    .payload_byte_i (payload_byte),
    .frame_ok_i     (frame_ok),
    .stall_o        (model_stall),
    .drives_on_i    (drives_on),
    .refused_o      (model_refused),
    .write_o        (model_write),
    .address_o      (model_address),
    .word_o         (model_word),
    .loaded_o       (model_loaded),
    .crc_o          (model_crc)
  );
  // The telemetry word at TelemetryRejectedOffset is the refused counter (bits 0-11) under the board's
  // causes (bits BoardFaultShift ..).
  if (delta_board_pkg::TelemetryBoardFaultOffset != delta_board_pkg::TelemetryRejectedOffset ||
      delta_board_pkg::BoardFaultShift != delta_board_pkg::StatusCounterBits ||
      delta_board_pkg::BoardFaultShift + delta_board_pkg::BoardFaultBits != 16 ||
      delta_board_pkg::TelemetryEstopBit != 7) begin : g_bad_board_fault_layout
    $error("board_core: the board's causes do not fit the telemetry words as board_core lays them out");
  end
  // The network's port takes frame numbers as its memories' layout (delta_network.sv); the package's
  // frames must be that layout.
  if (delta_board_pkg::ModelBias1Frame != NumInputs * delta_network_pkg::NumHidden ||
      delta_board_pkg::ModelWeight2Frame != delta_board_pkg::ModelBias1Frame + delta_network_pkg::NumHidden ||
      delta_board_pkg::ModelBias2Frame != delta_board_pkg::ModelWeight2Frame + NumOutputs * delta_network_pkg::NumHidden ||
      delta_board_pkg::ModelPlayFrame != delta_board_pkg::ModelBias2Frame + NumOutputs) begin : g_bad_model_layout
    $error("board_core: delta_board_pkg's model frames are not the network's memory layout");
  end

  // ---- commands and the drive state ------------------------------------------------------------------
  logic       enabled_q, holding_q, homed_q, flush, home, clear_fault, command_refused;
  logic       homing_q, home_start, homed_at_switch;
  logic [2:0] referenced_q, switch_edge, switch_meta_q, switch_q, switch_previous_q;
  logic [7:0] command_q;
  logic       fault, fault_active, joint_fault, joint_fault_active;
  logic       command_ok;
  assign command_ok = frame_ok && is_command;

  // ---- the board's own causes: the safety inputs and the e-stop command ------------------------------
  logic [delta_board_pkg::BoardFaultBits-1:0] board_cause;
  logic inputs_stopping, estop_q, estop, board_stop;
  board_safety_inputs u_safety_inputs (
    .clk_i,
    .rst_ni,
    .sample_i     (tick == '0),
    .estop_open_i,
    .drive_fault_i,
    .clear_i      (clear_fault),
    .cause_o      (board_cause),
    .stopping_o   (inputs_stopping)
  );
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) estop_q <= 1'b0;
    else if (estop) estop_q <= 1'b1;
    else if (clear_fault) estop_q <= 1'b0;
  end
  assign board_stop          = estop_q || board_cause != '0;
  assign fault               = joint_fault || board_stop;  // every latched cause stops the same way
  assign fault_active        = joint_fault_active || inputs_stopping;  // a clear is refused
  assign board_fault_cause_o = board_cause;
  assign estop_latched_o     = estop_q;

  // ---- bench jog ---------------------------------------------------------------------------------------
  localparam int unsigned JogCountBits = $clog2(delta_board_pkg::JogPeriods + 1);
  logic                    jog_q, jog_was_q, jog_negative_q, jog_start, drives_on;
  logic [1:0]              jog_joint_q;
  logic [JogCountBits-1:0] jog_left_q;  // tick 0s until the end, the current one included
  logic                    is_jog;
  logic [7:0]              jog_offset;  // 2 j + n
  assign jog_offset = command_q - 8'(delta_board_pkg::CommandJogBase);
  assign is_jog     = jog_offset < 8'd6;
  assign drives_on = enabled_q || jog_q;

  always_comb begin
    flush           = (fault && enabled_q) || homed_at_switch;  // a fault or a reference empties the buffer
    home            = 1'b0;
    home_start      = 1'b0;
    clear_fault     = 1'b0;
    command_refused = 1'b0;
    estop           = 1'b0;
    jog_start       = 1'b0;
    if (command_ok) begin
      unique case (command_q)
        8'(delta_board_pkg::CommandEnable):     command_refused = fault || !homed_q || !model_loaded || (enabled_q && !holding_q) || jog_q;
        8'(delta_board_pkg::CommandDisable):    flush = 1'b1;
        8'(delta_board_pkg::CommandHold):       command_refused = !enabled_q;
        8'(delta_board_pkg::CommandClearFault): begin
          command_refused = fault_active;
          clear_fault     = !fault_active;
        end
        8'(delta_board_pkg::CommandSetHome): begin
          command_refused = drives_on;
          home            = !drives_on;
        end
        8'(delta_board_pkg::CommandHomeStart): begin
          command_refused = drives_on;
          home_start      = !drives_on;
        end
        8'(delta_board_pkg::CommandEstop): estop = 1'b1;  // taken in every state
        default: begin
          command_refused = !is_jog || drives_on || fault || homing_q;
          jog_start       = is_jog && !command_refused;
        end
      endcase
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      command_q <= '0;
      enabled_q <= 1'b0;
      holding_q <= 1'b0;
      homed_q   <= 1'b0;
      homing_q  <= 1'b0;
      referenced_q <= '0;
    end else begin
      if (payload_valid && is_command) command_q <= payload_byte;
      if (command_ok && !command_refused) begin
        if (command_q == 8'(delta_board_pkg::CommandEnable)) begin
          enabled_q <= 1'b1;
          holding_q <= 1'b0;
        end
        if (command_q == 8'(delta_board_pkg::CommandDisable)) begin
          enabled_q <= 1'b0;
          holding_q <= 1'b0;
        end
        if (command_q == 8'(delta_board_pkg::CommandHold)) holding_q <= 1'b1;
      end
      if (home) homed_q <= 1'b1;
      if (home_start) homing_q <= 1'b1;
      referenced_q <= (home_start ? 3'b000 : referenced_q) | switch_edge;
      if ((!home_start && (referenced_q | switch_edge) == 3'b111) ||
          (command_ok && command_q == 8'(delta_board_pkg::CommandHold))) begin
        homing_q <= 1'b0;
      end
      if (fault || homed_at_switch) begin
        enabled_q <= 1'b0;
        holding_q <= 1'b0;
      end
      if (fault) homing_q <= 1'b0;
    end
  end

  // The jog: from the clock after its command to its JogPeriods-th tick 0, or a fault or a disable.
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      jog_q          <= 1'b0;
      jog_was_q      <= 1'b0;
      jog_negative_q <= 1'b0;
      jog_joint_q    <= '0;
      jog_left_q     <= '0;
    end else begin
      jog_was_q <= jog_q;
      if (jog_start) begin
        jog_q          <= 1'b1;
        jog_joint_q    <= jog_offset[2:1];
        jog_negative_q <= jog_offset[0];
        jog_left_q     <= JogCountBits'(delta_board_pkg::JogPeriods);
      end else if (jog_q && tick == '0) begin
        jog_left_q <= jog_left_q - 1'b1;
        if (jog_left_q == JogCountBits'(1)) jog_q <= 1'b0;
      end
      if (fault || (command_ok && command_q == 8'(delta_board_pkg::CommandDisable))) jog_q <= 1'b0;
    end
  end
  // The currents the PWM takes while a jog runs, and in the clock after (zero: its duties cleared).
  logic [47:0] jog_currents;
  logic        jog_override;
  logic [15:0] jog_current;  // the jogged joint's
  localparam logic [15:0] JogCurrent = 16'(delta_board_pkg::JogCurrentCode);
  assign jog_current = jog_negative_q ? 16'(-JogCurrent) : JogCurrent;
  always_comb begin
    for (int j = 0; j < 3; j++) jog_currents[16 * j +: 16] = (jog_q && jog_joint_q == 2'(j)) ? jog_current : 16'd0;
  end
  assign jog_override = jog_q || jog_was_q;

  // ---- home switches ---------------------------------------------------------------------------------
  // Two-flip-flop synchronisers and the previous state: a rising edge while homing with the drives on
  // references its joint (count := HomeCount) once.
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      switch_meta_q     <= '0;
      switch_q          <= '0;
      switch_previous_q <= '0;
    end else begin
      switch_meta_q     <= home_switch_i;
      switch_q          <= switch_meta_q;
      switch_previous_q <= switch_q;
    end
  end
  assign switch_edge     = (switch_q & ~switch_previous_q & ~referenced_q) & {3{homing_q && enabled_q && !fault}};
  assign homed_at_switch = switch_edge != '0;

  // ---- period schedule ---------------------------------------------------------------------------------
  logic [TickWidth-1:0] tick /*verilator public_flat_rd*/;
  logic [3:0]           phase_q /*verilator public_flat_rd*/;  // k of the running period (from tick 1 on)
  logic [31:0]          period_count_q; // control periods since reset
  logic                 play, update, snapshot;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      phase_q        <= 4'(delta_board_pkg::PeriodsPerSetpoint - 1);
      period_count_q <= '0;
    end else if (tick == '0) begin
      phase_q        <= (phase_q == 4'(delta_board_pkg::PeriodsPerSetpoint - 1)) ? 4'd0 : phase_q + 1'b1;
      period_count_q <= period_count_q + 1'b1;
    end
  end
  assign stage_sync_o = period_count_q[delta_board_pkg::StageSyncBit];
  assign play     = tick == TickWidth'(delta_board_pkg::PlayTick) && phase_q == 4'd0 && enabled_q && !holding_q && !fault;
  assign snapshot = tick == TickWidth'(ClocksPerPeriod / 2) && phase_q == 4'd0;
  assign update   = tick == TickWidth'(ClocksPerPeriod - delta_board_pkg::InterpolationLeadClocks);

  // ---- setpoints and the network --------------------------------------------------------------------
  logic                              net_start, net_done, net_ready, underrun, setpoint_refused;
  logic [NumInputs*InputWidth-1:0]   net_inputs;
  logic [NumOutputs*OutputWidth-1:0] net_outputs;  // the last answer, held
  logic [31:0]                       sample_index /*verilator public_flat_rd*/;
  logic [15:0]                       fill /*verilator public_flat_rd*/;

  setpoint_buffer u_setpoints (
    .clk_i,
    .rst_ni,
    .frame_start_i  (frame_start),
    .is_setpoint_i  (is_setpoint),
    .payload_valid_i(payload_valid),
    .payload_index_i(payload_index),
    .payload_byte_i (payload_byte),
    .frame_ok_i     (frame_ok),
    .refused_o      (setpoint_refused),
    .accept_i       (enabled_q && !fault),  // a jog (enabled_q low) refuses setpoints
    .flush_i        (flush),
    .play_i         (play),
    .underrun_o     (underrun),
    .start_o        (net_start),
    .ready_i        (net_ready),
    .inputs_o       (net_inputs),
    .sample_index_o (sample_index),
    .fill_o         (fill)
  );

  logic                              net_clk_start, net_clk_ready, net_clk_done;
  logic [NumInputs*InputWidth-1:0]   net_clk_inputs;
  logic [NumOutputs*OutputWidth-1:0] net_clk_outputs;
  logic                              net_idle;
  logic [NumOutputs-1:0]             net_output_valid;

  network_crossing #(
    .InputBits    (NumInputs * InputWidth),
    .OutputBits   (NumOutputs * OutputWidth),
    .CaptureInputs (1'b0),
    .CaptureOutputs(1'b0)
  ) u_crossing (
    .clk_i,
    .rst_ni,
    .start_i       (net_start),
    .ready_o       (net_ready),
    .done_o        (net_done),
    .inputs_i      (net_inputs),
    .outputs_o     (net_outputs),
    .clk_network_i,
    .rst_network_ni,
    .net_start_o   (net_clk_start),
    .net_ready_i   (net_clk_ready),
    .net_done_i    (net_clk_done),
    .net_inputs_o  (net_clk_inputs),
    .net_outputs_i (net_clk_outputs)
  );
  delta_network #(.MemDir(MemDir), .ModelFromFiles(1'b0), .CaptureInputs(1'b0)) u_network (
    .ap_clk      (clk_network_i),
    .ap_rst      (!rst_network_ni),
    .ap_start    (net_clk_start),
    .ap_done     (net_clk_done),
    .ap_idle     (net_idle),
    .ap_ready    (net_clk_ready),
    .u_0         (net_clk_inputs[0*InputWidth +: InputWidth]),
    .u_1         (net_clk_inputs[1*InputWidth +: InputWidth]),
    .u_2         (net_clk_inputs[2*InputWidth +: InputWidth]),
    .y_0         (net_clk_outputs[0*OutputWidth +: OutputWidth]),
    .y_0_ap_vld  (net_output_valid[0]),
    .y_1         (net_clk_outputs[1*OutputWidth +: OutputWidth]),
    .y_1_ap_vld  (net_output_valid[1]),
    .y_2         (net_clk_outputs[2*OutputWidth +: OutputWidth]),
    .y_2_ap_vld  (net_output_valid[2]),
    .model_clk_i    (clk_i),
    .model_write_i  (model_write),
    .model_address_i(model_address),
    .model_word_i   (model_word)
  );

  // ---- joint references ------------------------------------------------------------------------------
  logic [95:0] references /*verilator public_flat_rd*/;  // the joints' references this period
  logic        shift_write;  // the next period's play shift of joint shift_joint (whole counts)
  logic [1:0]  shift_joint;
  logic [delta_joint_pkg::ShiftBits-1:0] shift;
  logic [47:0] counts;
  logic [2:0]  counts_rising;  // bit j: joint j's count last stepped up (the side its play was taken up on)
  logic        slew_limited;
  // The deployed model's play words (H_j and the play shift's ends; zero for the plain network):
  // frames ModelPlayFrame + j of a load.
  logic play_write;
  logic [7:0] play_index;
  assign play_index = model_address - 8'(delta_board_pkg::ModelPlayFrame);
  assign play_write = model_write && model_address >= 8'(delta_board_pkg::ModelPlayFrame) &&
                      model_address < 8'(delta_board_pkg::ModelPlayFrame + 3);
  reference_interpolator u_interpolator (
    .clk_i,
    .rst_ni,
    .update_i      (update),
    .phase_i       (phase_q),
    .enabled_i     (enabled_q && !fault),
    .homing_i      (homing_q),
    .answer_i      (net_done),
    .outputs_i     (net_outputs),
    .counts_i      (counts),
    .rising_i      (counts_rising),
    .play_write_i  (play_write),
    .play_joint_i  (play_index[1:0]),
    .play_word_i   (model_word[delta_board_pkg::HalfPlayBits+20:0]),
    .references_o  (references),
    .shift_write_o (shift_write),
    .shift_joint_o (shift_joint),
    .shift_o       (shift),
    .slew_limited_o(slew_limited)
  );

  // ---- joint I/O ---------------------------------------------------------------------------------------
  // Two-flip-flop synchronisers for the asynchronous encoder inputs.
  logic [2:0] encoder_a_meta_q, encoder_a_q, encoder_b_meta_q, encoder_b_q;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      encoder_a_meta_q <= 3'b000;
      encoder_a_q      <= 3'b000;
      encoder_b_meta_q <= 3'b000;
      encoder_b_q      <= 3'b000;
    end else begin
      encoder_a_meta_q <= encoder_a_i;
      encoder_a_q      <= encoder_a_meta_q;
      encoder_b_meta_q <= encoder_b_i;
      encoder_b_q      <= encoder_b_meta_q;
    end
  end

  logic [15:0] joint_overflow_count;
  joint_axes #(
    .ClocksPerPeriod(ClocksPerPeriod),
    .HomeCount      (HomeCount)
  ) u_joint_axes (
    .clk_i,
    .rst_ni,
    .encoder_a_i     (encoder_a_q),
    .encoder_b_i     (encoder_b_q),
    .home_i          ({3{home}} & ~referenced_q | switch_edge),
    .references_i    (references),
    .shift_write_i   (shift_write),
    .shift_joint_i   (shift_joint),
    .shift_i         (shift),
    .enabled_i       (enabled_q),
    .stop_i          (board_stop),
    .jog_i           (jog_q),
    .jog_override_i  (jog_override),
    .jog_currents_i  (jog_currents),
    .frame_valid_i   (frame_ok),
    .clear_fault_i   (clear_fault),
    .tick_o          (tick),
    .counts_o        (counts),
    .counts_rising_o (counts_rising),
    .peek_address_i  ({peek_joint, peek_slot}),
    .peek_data_o     (peek_data),
    .drive_pwm_o,
    .drive_dir_o,
    .drive_enable_o,
    .encoder_error_o,
    .overflow_count_o(joint_overflow_count),
    .fault_o         (joint_fault),
    .fault_cause_o   (joint_fault_cause_o),
    .fault_active_o  (joint_fault_active)
  );
  assign joint_limited_o = joint_overflow_count != '0;
  assign joint_fault_o   = fault;

  // ---- counters (saturating: a count never wraps back to small) ----------------------------------------
  localparam int unsigned CounterBits = delta_board_pkg::StatusCounterBits;
  logic [CounterBits-1:0] bad_frames_q, underruns_q, slew_limits_q, refused_q;
  logic [7:0]  last_sequence_q;
  function automatic logic [CounterBits-1:0] saturating_increment(logic [CounterBits-1:0] value);
    saturating_increment = (value == '1) ? value : value + 1'b1;
  endfunction
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      bad_frames_q    <= '0;
      underruns_q     <= '0;
      slew_limits_q   <= '0;
      refused_q       <= '0;
      last_sequence_q <= '0;
    end else begin
      if (frame_bad) bad_frames_q <= saturating_increment(bad_frames_q);
      if (underrun && !homing_q) underruns_q <= saturating_increment(underruns_q);
      if (slew_limited) slew_limits_q <= saturating_increment(slew_limits_q);
      if (command_refused || setpoint_refused || model_refused) refused_q <= saturating_increment(refused_q);
      if (frame_ok) last_sequence_q <= frame_sequence;
    end
  end

  // ---- frames out: identify and telemetry --------------------------------------------------------------
  // link_tx asks for telemetry word w (payload bytes 2w, 2w+1) and takes it one cycle later: the
  // joint words are read from the controllers' state memory (peek, one cycle), the rest are
  // registers chosen by the word index of the previous cycle. Offsets: delta_board_pkg Telemetry*.
  localparam int unsigned ReferenceWord = delta_board_pkg::TelemetryReferencesOffset / 2;
  localparam int unsigned CountWord     = delta_board_pkg::TelemetryCountsOffset / 2;
  localparam int unsigned CurrentWord   = delta_board_pkg::TelemetryCurrentsOffset / 2;
  logic [4:0]  telemetry_word_index, word_index_q;
  logic [15:0] telemetry_word;
  logic [7:0]  flags;
  logic [1:0]  peek_joint;
  logic [2:0]  peek_slot;
  logic [31:0] peek_data;

  always_comb begin  // which state word the asked-for telemetry word comes from
    peek_joint = 2'd0;
    peek_slot  = delta_joint_pkg::SlotReference;
    if (telemetry_word_index >= 5'(CurrentWord)) begin
      peek_joint = 2'(telemetry_word_index - 5'(CurrentWord));
      peek_slot  = delta_joint_pkg::SlotCurrent;
    end else if (telemetry_word_index >= 5'(CountWord)) begin
      peek_joint = 2'(telemetry_word_index - 5'(CountWord));
      peek_slot  = delta_joint_pkg::SlotEncoder;
    end else if (telemetry_word_index >= 5'(ReferenceWord)) begin
      peek_joint = 2'((telemetry_word_index - 5'(ReferenceWord)) >> 1);
    end
  end

  always_ff @(posedge clk_i) word_index_q <= telemetry_word_index;

  always_comb begin
    flags = '0;
    flags[delta_board_pkg::FlagDriveEnable]  = drives_on && !fault;
    flags[delta_board_pkg::FlagHomed]        = homed_q;
    flags[delta_board_pkg::FlagHolding]      = holding_q;
    flags[delta_board_pkg::FlagFault]        = fault;
    flags[delta_board_pkg::FlagEncoderError] = encoder_error_o != '0;
    flags[delta_board_pkg::FlagReferenced]   = referenced_q == 3'b111;
    flags[delta_board_pkg::FlagHoming]       = homing_q;
    flags[delta_board_pkg::FlagModel]        = model_loaded;
    unique case (5'(word_index_q))
      5'(delta_board_pkg::TelemetrySampleIndexOffset / 2):     telemetry_word = sample_index[15:0];
      5'(delta_board_pkg::TelemetrySampleIndexOffset / 2 + 1): telemetry_word = sample_index[31:16];
      5'(delta_board_pkg::TelemetryTickOffset / 2):            telemetry_word = period_count_q[15:0];
      5'(delta_board_pkg::TelemetryTickOffset / 2 + 1):        telemetry_word = period_count_q[31:16];
      5'(delta_board_pkg::TelemetryFaultOffset / 2):           telemetry_word = {flags, estop_q, counts_rising, 4'(joint_fault_cause_o)};
      5'(delta_board_pkg::TelemetryFillOffset / 2):            telemetry_word = fill;
      5'(delta_board_pkg::TelemetryBadFramesOffset / 2):       telemetry_word = 16'(bad_frames_q);
      5'(delta_board_pkg::TelemetryUnderrunsOffset / 2):       telemetry_word = 16'(underruns_q);
      5'(delta_board_pkg::TelemetrySaturationsOffset / 2):     telemetry_word = joint_overflow_count;
      5'(delta_board_pkg::TelemetrySlewLimitsOffset / 2):      telemetry_word = 16'(slew_limits_q);
      5'(delta_board_pkg::TelemetryRejectedOffset / 2):        telemetry_word = {board_cause, refused_q};
      5'(delta_board_pkg::TelemetrySequenceOffset / 2):        telemetry_word = {1'b0, jog_q, referenced_q, switch_q, last_sequence_q};
      default: begin  // references (low, high half), counts and currents (low half; a jog's own)
        telemetry_word = (word_index_q >= 5'(ReferenceWord) && word_index_q < 5'(CountWord) && word_index_q[0] != 1'(ReferenceWord))
                             ? peek_data[31:16] : peek_data[15:0];
        if (jog_q && word_index_q >= 5'(CurrentWord)) telemetry_word = (2'(word_index_q - 5'(CurrentWord)) == jog_joint_q) ? jog_current : 16'd0;
      end
    endcase
  end

  link_tx #(.MemDir(MemDir)) u_link_tx (
    .clk_i,
    .rst_ni,
    .snapshot_i         (snapshot),
    .word_index_o       (telemetry_word_index),
    .word_i             (telemetry_word),
    .identify_i         (frame_ok && is_identify_request),
    .identify_sequence_i(frame_sequence),
    .weights_crc_i      (model_crc),
    .tx_data_o          (tx_data),
    .tx_valid_o         (tx_valid),
    .tx_ready_i         (tx_ready)
  );

  logic unused_status;
  assign unused_status = ^{net_idle, net_output_valid, rx_frame_error, play_index[7:2]};

  // ---- status LEDs -------------------------------------------------------------------------------------
  // On for the window of 2^LedWindowBits control periods (0.2 s) after one in which a frame was
  // accepted (green) or dropped (red): a blink at 5 Hz while frames flow.
  logic green_seen_q, red_seen_q, green_q, red_q, window_end;
  assign window_end = tick == '0 && period_count_q[LedWindowBits-1:0] == '0;
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      green_seen_q <= 1'b0;
      red_seen_q   <= 1'b0;
      green_q      <= 1'b0;
      red_q        <= 1'b0;
    end else if (window_end) begin
      green_q      <= green_seen_q || frame_ok;
      red_q        <= red_seen_q || frame_bad;
      green_seen_q <= 1'b0;
      red_seen_q   <= 1'b0;
    end else begin
      if (frame_ok) green_seen_q <= 1'b1;
      if (frame_bad) red_seen_q <= 1'b1;
    end
  end
  assign led_green_o = green_q;
  assign led_red_o   = red_q;

`ifdef FORMAL
  // ---- Formal properties (scripts/formal.sh; docs/formal.md) ----
  // Proved with the network, its crossing, the interpolator, the joint controllers' datapath, the
  // UARTs, link_tx and link_rx as black boxes whose outputs are free (a sound over-approximation):
  // link_rx's delivery is proved in its own job and assumed here through setpoint_buffer's
  // protocol assumptions, the controllers' current limit through joint_pwm's.
  // Environment: reset in the first cycle only.
  logic f_past_valid = 1'b0;
  always_ff @(posedge clk_i) f_past_valid <= 1'b1;
  always_comb begin
    reset_only_in_the_first_cycle: assume (rst_ni == f_past_valid);
    // link_rx's delivery of a command frame (job link_rx: a frame starts only when its length is
    // its type's payload size, and presents exactly its payload bytes): one byte, index 0.
    a_command_has_one_payload_byte: assume (!(payload_valid && is_command) || payload_index == 6'd0);
  end

  // The command a CRC-valid command frame carries (its one payload byte), kept independently.
  logic [7:0] f_command_q = '0;
  always_ff @(posedge clk_i) if (payload_valid && is_command && payload_index == 6'd0) f_command_q <= payload_byte;
  logic f_valid_enable, f_valid_disable, f_valid_hold, f_valid_clear, f_valid_home;
  assign f_valid_enable  = frame_ok && is_command && f_command_q == 8'(delta_board_pkg::CommandEnable);
  assign f_valid_disable = frame_ok && is_command && f_command_q == 8'(delta_board_pkg::CommandDisable);
  assign f_valid_hold    = frame_ok && is_command && f_command_q == 8'(delta_board_pkg::CommandHold);
  assign f_valid_clear   = frame_ok && is_command && f_command_q == 8'(delta_board_pkg::CommandClearFault);
  assign f_valid_home    = frame_ok && is_command && f_command_q == 8'(delta_board_pkg::CommandSetHome);
  logic f_valid_estop, f_valid_jog, f_board_cause;
  assign f_valid_estop = frame_ok && is_command && f_command_q == 8'(delta_board_pkg::CommandEstop);
  assign f_valid_jog   = frame_ok && is_command && f_command_q >= 8'(delta_board_pkg::CommandJogBase) &&
                         f_command_q < 8'(delta_board_pkg::CommandJogBase + 6);
  assign f_board_cause = board_fault_cause_o != '0 || estop_latched_o;
  always_comb begin
    pwm_outputs_off_whenever_the_drives_are_off: assert (drive_enable_o || drive_pwm_o == '0);
    pwm_outputs_off_whenever_the_drives_are_off_c: cover (!drive_enable_o && enabled_q);
    the_fault_pin_is_the_latch: assert (joint_fault_o == (joint_fault_cause_o != '0 || f_board_cause));
    the_fault_pin_is_the_latch_c: cover (joint_fault_o);
    // The board's causes (board_safety_inputs.sv proves its filter and latch in its own job).
    if (f_valid_clear && inputs_stopping) a_clear_is_refused_while_an_input_samples_at_stop: assert (!clear_fault && command_refused);
    a_clear_is_refused_while_an_input_samples_at_stop_c: cover (f_valid_clear && inputs_stopping && board_fault_cause_o != '0);
    // The bench jog: never beside the closed-loop enable, and bounded by its period count.
    a_jog_never_runs_with_the_drives_enabled: assert (!(jog_q && enabled_q));
    a_jog_never_runs_with_the_drives_enabled_c: cover (jog_q);
    if (jog_q) a_jog_is_bounded_by_its_periods: assert (jog_left_q != '0 && jog_left_q <= JogCountBits'(delta_board_pkg::JogPeriods));
    a_jog_is_bounded_by_its_periods_c: cover (jog_q && jog_left_q == JogCountBits'(delta_board_pkg::JogPeriods - 1));
    if (jog_q) a_jog_takes_no_setpoints: assert (!enabled_q && !play);
    a_jog_takes_no_setpoints_c: cover (jog_q && frame_ok && is_setpoint);
    if (clear_fault) a_clear_is_taken_only_with_the_cause_gone: assert (f_valid_clear && !fault_active);
    a_clear_is_taken_only_with_the_cause_gone_c: cover (clear_fault && fault);
    if (f_valid_clear && !fault_active) a_valid_clear_with_the_cause_gone_is_taken: assert (clear_fault);
    a_valid_clear_with_the_cause_gone_is_taken_c: cover (f_valid_clear && !fault_active && fault);
    if (home) set_home_only_with_the_drives_off: assert (f_valid_home && !enabled_q);
    set_home_only_with_the_drives_off_c: cover (home);
    if (play) plays_only_with_the_drives_on_and_no_fault: assert (enabled_q && !holding_q && !fault);
    plays_only_with_the_drives_on_and_no_fault_c: cover (play);
    holding_only_while_enabled: assert (!holding_q || enabled_q);
    holding_only_while_enabled_c: cover (holding_q);
    // The model (model_loader.sv): the drives are never on without a loaded model (its flag rises only
    // at a commit whose CRC matched, and a load, which voids it, is taken only with the drives off).
    the_drives_are_never_on_without_a_model: assert (!enabled_q || model_loaded);
    the_drives_are_never_on_without_a_model_c: cover (enabled_q && model_loaded);
  end
  always_ff @(posedge clk_i) begin
    if (f_past_valid && $past(rst_ni)) begin
      // Enable: only after an enable command in a CRC-valid frame, homed, a model loaded, no fault latched.
      if (!$past(enabled_q) && enabled_q) enables_only_on_a_valid_enable_homed_without_fault: assert ($past(f_valid_enable) && $past(homed_q) && $past(model_loaded) && !$past(fault));
      enables_only_on_a_valid_enable_homed_without_fault_c: cover (!$past(enabled_q) && enabled_q);
      if (!$past(drive_enable_o) && drive_enable_o) drives_on_only_a_clock_after_the_enable: assert (($past(enabled_q) || $past(jog_q)) && !$past(fault));
      drives_on_only_a_clock_after_the_enable_c: cover (!$past(drive_enable_o) && drive_enable_o);
      // Progress: a valid enable in the allowed state enables in the next clock.
      if ($past(f_valid_enable) && $past(homed_q) && $past(model_loaded) && !$past(fault) && !$past(homed_at_switch) &&
          !($past(enabled_q) && !$past(holding_q))) begin
        a_valid_enable_homed_without_fault_enables: assert (enabled_q && !holding_q);
      end
      a_valid_enable_homed_without_fault_enables_c: cover ($past(f_valid_enable) && $past(homed_q) && $past(holding_q));
      // Commands act only on a CRC-valid command frame (a dropped frame changes no state); a fault
      // or a home switch referencing its joint are the only other ways the drives go off, and
      // nothing turns them on by itself.
      if ($past(enabled_q) != enabled_q || $past(holding_q) != holding_q || $past(homed_q) != homed_q) begin
        state_changes_only_on_a_valid_command_or_a_fault: assert ($past(frame_ok && is_command) || (($past(fault) || $past(homed_at_switch)) && !enabled_q && !holding_q));
      end
      state_changes_only_on_a_valid_command_or_a_fault_c: cover ($past(frame_bad) && $past(enabled_q) && enabled_q);
      if ($past(fault)) a_fault_turns_the_enable_off: assert (!enabled_q && !holding_q && !jog_q && !drive_enable_o);
      a_fault_turns_the_enable_off_c: cover ($past(fault) && $past(enabled_q));
      // A board cause (a safety input's latch, an e-stop command) turns the drives off, the PWM and
      // direction pins low, in the next clock; with board_safety_inputs' filter (a cause latches at
      // the BoardInputFilterPeriods-th sample at stop), an input held at stop has the drives off
      // within BoardInputFilterPeriods tick 0s and two clocks.
      if ($past(f_board_cause)) a_board_cause_turns_the_drives_off: assert (!drive_enable_o && drive_pwm_o == '0 && drive_dir_o == '0 && !enabled_q && !jog_q);
      a_board_cause_turns_the_drives_off_c: cover ($past(board_fault_cause_o != '0) && $past(drive_enable_o));
      // The e-stop command latches in every state; only an accepted clear ends it; nothing else raises it.
      if ($past(f_valid_estop)) an_estop_command_latches_in_every_state: assert (estop_latched_o && !$past(command_refused));
      an_estop_command_latches_in_every_state_jogging_c: cover ($past(f_valid_estop) && $past(jog_q));
      an_estop_command_latches_in_every_state_c: cover ($past(f_valid_estop) && $past(enabled_q));
      if (!$past(estop_latched_o) && estop_latched_o) the_estop_latch_rises_only_on_an_estop_command: assert ($past(f_valid_estop));
      the_estop_latch_rises_only_on_an_estop_command_c: cover (!$past(estop_latched_o) && estop_latched_o && $past(fault));
      if ($past(estop_latched_o) && !estop_latched_o) the_estop_latch_falls_only_at_an_accepted_clear: assert ($past(f_valid_clear) && !$past(fault_active));
      the_estop_latch_falls_only_at_an_accepted_clear_c: cover ($past(estop_latched_o) && !estop_latched_o);
      // A board cause falls only at an accepted clear, which no input sampled at stop allows.
      if (($past(board_fault_cause_o) & ~board_fault_cause_o) != '0) a_board_cause_falls_only_at_a_clear_with_the_inputs_back: assert (
          $past(f_valid_clear) && !$past(inputs_stopping) && !$past(fault_active));
      a_board_cause_falls_only_at_a_clear_with_the_inputs_back_c: cover ($past(board_fault_cause_o) != '0 && board_fault_cause_o == '0);
      // The jog starts only on a valid jog command with the drives off, no fault, not homing; a
      // fault or a disable ends it in the next clock.
      if (!$past(jog_q) && jog_q) a_jog_starts_only_on_a_valid_jog_command_with_the_drives_off: assert (
          $past(f_valid_jog) && !$past(enabled_q) && !$past(fault) && !$past(homing_q));
      a_jog_starts_only_on_a_valid_jog_command_with_the_drives_off_c: cover (!$past(jog_q) && jog_q);
      if ($past(jog_q) && ($past(fault) || $past(f_valid_disable))) a_fault_or_a_disable_ends_a_jog: assert (!jog_q);
      a_fault_or_a_disable_ends_a_jog_c: cover ($past(jog_q) && $past(f_valid_disable));
      if ($past(f_valid_disable)) disable_turns_the_drives_off: assert (!enabled_q && !holding_q);
      disable_turns_the_drives_off_c: cover ($past(f_valid_disable) && $past(enabled_q));
      if ($past(f_valid_hold) && $past(enabled_q) && !$past(fault) && !$past(homed_at_switch)) hold_holds: assert (holding_q && enabled_q);
      hold_holds_c: cover ($past(f_valid_hold) && $past(enabled_q));
      if ($past(f_valid_disable) || $past(fault && enabled_q)) disable_or_fault_flushes_the_setpoints: assert (fill == '0);
      disable_or_fault_flushes_the_setpoints_c: cover ($past(f_valid_disable) && $past(fill) != '0);
      // Homing (docs/homing.md): a switch references its joint only while homing with the drives on
      // and no fault, and turns the drives off; a joint becomes referenced only at its switch's edge.
      if ($past(homed_at_switch)) a_reference_turns_the_drives_off: assert (!enabled_q && !holding_q && fill == '0);
      a_reference_turns_the_drives_off_c: cover ($past(homed_at_switch));
      if ($past(homed_at_switch)) references_only_while_homing_with_the_drives_on: assert ($past(homing_q) && $past(enabled_q) && !$past(fault));
      references_only_while_homing_with_the_drives_on_c: cover ($past(homed_at_switch) && $past(homing_q) && $past(enabled_q));
      referenced_only_at_a_switch_edge: assert ((referenced_q & ~$past(referenced_q) & ~$past(switch_edge)) == '0);
      referenced_only_at_a_switch_edge_c: cover (referenced_q == 3'b111);
      // A model frame with the drives on changes nothing: the model stays, nothing is written.
      if ($past(frame_ok && is_model && enabled_q)) a_model_frame_with_the_drives_on_changes_nothing: assert (
          model_loaded == $past(model_loaded) && model_crc == $past(model_crc) && !$past(model_write) && $past(model_refused));
      a_model_frame_with_the_drives_on_changes_nothing_c: cover ($past(frame_ok && is_model && enabled_q) && model_loaded);
    end
  end
`endif
endmodule
