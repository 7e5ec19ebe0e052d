// Board facts of the iCEBreaker build, written once: clocks, link rate, control period, encoder
// home, PWM, current scale, joint safety limits and fault-cause bits.
//
// This package is the one source. The C++ header delta/board_facts.hpp is generated from it at
// configure time (cmake/BoardFacts.cmake: every `localparam int Name /*verilator public*/ = value;` line below becomes
// `constexpr long long kName = value;`), and the CTest BoardFacts.* checks the Verilated package,
// the generated header and icebreaker.pcf against each other. Keep each constant on one line as
// `localparam int Name /*verilator public*/ = value;` (decimal or sized literals) so the generator
// reads it (public: the Verilated model lists every fact, and the test compares them all).
package delta_board_pkg;

  // ---- clocks (one PLL, icebreaker_top.sv; icebreaker.pcf's set_frequency lines must agree) ----
  localparam int NetworkClockHz /*verilator public*/ = 46_500_000;  // PLL port A (GENCLK): the network alone
  localparam int BoardClockHz /*verilator public*/ = 23_250_000;  // PLL port B (GENCLK_HALF): link, joints, PWM
  localparam int ControlRateHz /*verilator public*/ = 10_000;  // joint control period: 100 us
  localparam int ClocksPerPeriod /*verilator public*/ = 2_325;  // BoardClockHz / ControlRateHz

  // ---- the control period's schedule (board_core.sv; tick 0 .. ClocksPerPeriod - 1 of joint_axes) ----
  // Tick 0 starts a period (the controllers' ap_start, the safety check); the telemetry snapshot is
  // at tick ClocksPerPeriod / 2 of phase 0. The C++ model board (host/cosim/model_board.cpp) keeps
  // to these.
  localparam int PlayTick /*verilator public*/ = 1;  // tick of phase 0 that plays a setpoint (the network starts)
  localparam int InterpolationLeadClocks /*verilator public*/ = 100;  // the update of the next period's references starts at tick ClocksPerPeriod - 100
  localparam int InterpolatorDeltaStep /*verilator public*/ = 4;  // reference_interpolator.sv: a joint's step that takes its segment change D
  localparam int InterpolatorReferenceStep /*verilator public*/ = 7;  // reference_interpolator.sv: a joint's last step (r', D', the play shift, then the next joint): 8 clocks a joint
  localparam int JointControllerLoadCycles /*verilator public*/ = 6;  // joint_controller.sv: ap_start seen to ap_ready (the inputs copied)
  localparam int JointControllerJointCycles /*verilator public*/ = 355;  // joint_controller.sv: one joint's microprogram (5 x 3 + 11 x 30 + 5 x 2)

  // ---- host link v2, 8N1 UART: the one description of the frames is docs/board_link.md; every number
  // it uses is here. RTL: rtl/board/link_*.sv; C++ codec: host/include/delta/link/*.hpp.
  // A frame is sync, length (payload bytes), sequence, type, payload, CRC-16 (high byte first) over
  // length..payload; CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF.
  localparam int LinkBaud /*verilator public*/ = 1_000_000;  // FT2232H: 3 MHz / 3, exact
  localparam int LinkClocksPerBit /*verilator public*/ = 23;  // BoardClockHz / 23 = 1,010,870 baud, +1.09 %
  localparam int ProtocolVersion /*verilator public*/ = 3;
  localparam int FrameSync /*verilator public*/ = 32'h7E;
  localparam int FrameHeaderBytes /*verilator public*/ = 4;  // sync, length, sequence, type
  localparam int FrameCrcBytes /*verilator public*/ = 2;
  localparam int FrameMaxPayloadBytes /*verilator public*/ = 48;
  localparam int FrameCrcPolynomial /*verilator public*/ = 32'h1021;
  localparam int FrameCrcInit /*verilator public*/ = 32'hFFFF;
  localparam int FrameTypeIdentifyRequest /*verilator public*/ = 32'h01;  // host -> board, no payload
  localparam int FrameTypeSetpoint /*verilator public*/ = 32'h02;  // host -> board: sample index, 3 position codes
  localparam int FrameTypeCommand /*verilator public*/ = 32'h03;  // host -> board: one command byte
  localparam int FrameTypeModel /*verilator public*/ = 32'h04;  // host -> board: one word of the model (frame number, 48 bits)
  localparam int FrameTypeIdentify /*verilator public*/ = 32'h81;  // board -> host, answers 0x01 (same sequence)
  localparam int FrameTypeTelemetry /*verilator public*/ = 32'h82;  // board -> host, 1 kHz
  localparam int SetpointPayloadBytes /*verilator public*/ = 10;
  localparam int CommandPayloadBytes /*verilator public*/ = 1;
  localparam int ModelPayloadBytes /*verilator public*/ = 8;
  localparam int IdentifyPayloadBytes /*verilator public*/ = 24;
  localparam int TelemetryPayloadBytes /*verilator public*/ = 48;
  localparam int RxRingBytes /*verilator public*/ = 512;  // received bytes kept for the rescan after a drop
  localparam int LinkTxWords /*verilator public*/ = 256;  // link_tx.sv's payload RAM: 16-bit words (identify from word 0)
  localparam int LinkTxTelemetryWord /*verilator public*/ = 16;  // link_tx.sv's payload RAM: the telemetry payload's first word

  // Setpoints: 1 kHz, addressed by sample index, into a buffer of SetpointDepth entries.
  localparam int SetpointRateHz /*verilator public*/ = 1_000;
  localparam int PeriodsPerSetpoint /*verilator public*/ = 10;  // ControlRateHz / SetpointRateHz
  localparam int SetpointDepth /*verilator public*/ = 256;  // entries (256 ms; one block RAM per 16-bit lane)
  localparam int StreamLeadSetpoints /*verilator public*/ = 200;  // the host keeps 200 ms sent ahead (< SetpointDepth)
  localparam int SetpointIndexOffset /*verilator public*/ = 0;  // u32 sample index
  localparam int SetpointInputOffset /*verilator public*/ = 4;  // 3 x i16 scaled network input codes u_x, u_y, u_z (Q1.15)

  // The model as data (docs/board_link.md, "The model"): frames of type FrameTypeModel, payload u16
  // frame number n at ModelFrameOffset and a 48-bit word w (3 x u16, low first) at ModelWordOffset.
  // n = 0 starts a load (the model is void at once); each next n is taken in order with the drives
  // off; the words go into the network's memories; n = ModelCommitFrame carries the CRC-32 of the
  // words of frames 0 .. ModelCommitFrame - 1 (6 bytes each, little-endian) and ends the load.
  localparam int ModelFrameOffset /*verilator public*/ = 0;  // u16 frame number n
  localparam int ModelWordOffset /*verilator public*/ = 2;  // 3 x u16: the 48-bit word, low lane first
  localparam int ModelWeight1Frame /*verilator public*/ = 0;  // IW'_kj, word 3k + j (input_weights.mem), 24 bits
  localparam int ModelBias1Frame /*verilator public*/ = 75;  // b1'_k (hidden_bias.mem), 38 bits
  localparam int ModelWeight2Frame /*verilator public*/ = 100;  // LW'_ok, word 25o + k (output_weights.mem), 24 bits
  localparam int ModelBias2Frame /*verilator public*/ = 175;  // b2'_o + 2^19 (output_bias.mem plus the output cast's rounding half), 47 bits
  localparam int ModelPlayFrame /*verilator public*/ = 178;  // joint j's play: H_j, the play shift's ends and rounding (docs)
  localparam int ModelScalingFrame /*verilator public*/ = 181;  // input j's centre (bits 0-31) and shift (32-39): the host scales, the CRC covers them
  localparam int ModelCommitFrame /*verilator public*/ = 184;  // CRC-32/ISO-HDLC of the words before it (bits 0-31)
  localparam int ModelFrames /*verilator public*/ = 185;
  localparam int ModelWordBits /*verilator public*/ = 48;
  // The loader (model_loader.sv): a taken frame's word is written into the memories in the clock
  // of its frame_ok, then runs bit-serially through the board's CRC-32 for ModelCrcClocks clocks,
  // during which link_rx's parser stalls (its ring keeps receiving); the model flag and identify's
  // CRC change in the clock after the commit's frame_ok. Words land in the network's memories at
  // the network's memories at address n (each memory reads only its own frames: IW', b1', LW' and
  // the b2' words' own memory, read by the neuron-0 tokens), and in the interpolator's play word
  // n - ModelPlayFrame.
  localparam int ModelCrcClocks /*verilator public*/ = 48;  // one CRC bit a clock, ModelWordBits

  // Interpolation: reference r(k) = B + round(D * K(k) / 2^InterpolationShift), K(k) = round(k 2^14 / 10).
  localparam int InterpolationShift /*verilator public*/ = 14;
  localparam int SegmentDeltaBits /*verilator public*/ = 16;  // D: reference change per setpoint, Q.8 counts, saturated
  localparam int HalfPlayBits /*verilator public*/ = 17;  // H: backlash half-play per joint, Q.8 counts, unsigned (half_play.mem)

  // Command byte values (payload of a command frame).
  localparam int CommandEnable /*verilator public*/ = 1;  // drives on (homed, no fault); resumes after hold
  localparam int CommandDisable /*verilator public*/ = 2;  // drives off, buffer flushed (setpoints refused while off)
  localparam int CommandHold /*verilator public*/ = 3;  // stop taking setpoints, hold the reference
  localparam int CommandClearFault /*verilator public*/ = 4;  // refused while a cause persists
  localparam int CommandSetHome /*verilator public*/ = 5;  // counts of the joints not referenced := HomeCount (drives off only)
  localparam int CommandHomeStart /*verilator public*/ = 6;  // drives off only: forget the references, start homing
  localparam int CommandEstop /*verilator public*/ = 7;  // drives off at once, buffer flushed, the e-stop cause latched (any state) until a clear-fault
  // Bench jog (`deltactl bench jog`, docs/bench.md): byte CommandJogBase + 2 j + n, drives off, no fault
  // latched, homed or not (no model needed): joint j alone at the open-loop current +JogCurrentCode
  // (n = 0) or -JogCurrentCode (n = 1), the other joints at zero current, for JogPeriods control
  // periods, then the drives off. Any fault, a disable or an e-stop ends it at once; setpoints are
  // refused while it runs.
  localparam int CommandJogBase /*verilator public*/ = 16;  // .. CommandJogBase + 5
  localparam int JogCurrentCode /*verilator public*/ = 1_638;  // 0.05 A in Q1.15 (a tenth of the current limit)
  localparam int JogPeriods /*verilator public*/ = 5_000;  // 0.5 s
  localparam int TelemetryJogBit /*verilator public*/ = 6;  // bit 6 of the home byte: a bench jog runs (the drives on, open loop)

  // Identify payload (u16/u32 little-endian).
  localparam int IdentifyProtocolOffset /*verilator public*/ = 0;  // u16 ProtocolVersion
  localparam int IdentifyDepthOffset /*verilator public*/ = 2;  // u16 SetpointDepth
  localparam int IdentifyBuildIdOffset /*verilator public*/ = 4;  // u32 gateware build id
  localparam int IdentifyWeightsCrcOffset /*verilator public*/ = 8;  // u32 CRC-32 of the loaded model (0: none)
  localparam int IdentifyNetworkClockOffset /*verilator public*/ = 12;  // u32 NetworkClockHz
  localparam int IdentifyBoardClockOffset /*verilator public*/ = 16;  // u32 BoardClockHz
  localparam int IdentifyControlRateOffset /*verilator public*/ = 20;  // u16 ControlRateHz
  localparam int IdentifySetpointRateOffset /*verilator public*/ = 22;  // u16 SetpointRateHz

  // Telemetry payload, one frame per setpoint period (snapshot at the middle of sub-period 0;
  // references, counts and currents are those of that control period, from the controller's state
  // memory). Every field starts on a 16-bit word.
  localparam int TelemetrySampleIndexOffset /*verilator public*/ = 0;  // u32 next sample index to play
  localparam int TelemetryTickOffset /*verilator public*/ = 4;  // u32 control periods since reset
  localparam int TelemetryReferencesOffset /*verilator public*/ = 8;  // 3 x i32 joint references, Q24.8 counts
  localparam int TelemetryCountsOffset /*verilator public*/ = 20;  // 3 x i16 encoder counts
  localparam int TelemetryCurrentsOffset /*verilator public*/ = 26;  // 3 x i16 applied currents, Q1.15 A
  localparam int TelemetryFaultOffset /*verilator public*/ = 32;  // u8 fault cause bits (Fault*, bits 0-3), play sides (bits 4-6), e-stop latched (bit 7)
  localparam int TelemetryPlaySideShift /*verilator public*/ = 4;  // bit 4 + j of the fault byte: joint j's count last stepped up
  localparam int TelemetryFlagsOffset /*verilator public*/ = 33;  // u8 flags (Flag*)
  localparam int TelemetryFillOffset /*verilator public*/ = 34;  // u16 setpoints buffered
  localparam int StatusCounterBits /*verilator public*/ = 12;  // bad frames, underruns, slew limits, refused: saturate at 4095
  localparam int TelemetryBadFramesOffset /*verilator public*/ = 36;  // u16 dropped frames (saturating)
  localparam int TelemetryUnderrunsOffset /*verilator public*/ = 38;  // u16 setpoint periods with an empty buffer
  localparam int TelemetrySaturationsOffset /*verilator public*/ = 40;  // u16 controller saturations (saturating)
  localparam int TelemetrySlewLimitsOffset /*verilator public*/ = 42;  // u16 reference changes limited (saturating)
  localparam int TelemetryRejectedOffset /*verilator public*/ = 44;  // u16 refused commands and setpoints (bits 0-11, saturating), board faults (bits 12-15)
  localparam int TelemetrySequenceOffset /*verilator public*/ = 46;  // u8 sequence of the last accepted frame
  localparam int TelemetryHomeOffset /*verilator public*/ = 47;  // u8 home switches (bits 0-2), joints referenced (bits 3-5), a bench jog runs (bit 6)
  localparam int FlagDriveEnable /*verilator public*/ = 0;
  localparam int FlagHomed /*verilator public*/ = 1;
  localparam int FlagHolding /*verilator public*/ = 2;
  localparam int FlagFault /*verilator public*/ = 3;
  localparam int FlagEncoderError /*verilator public*/ = 4;
  localparam int FlagReferenced /*verilator public*/ = 5;  // every joint homed against its reference
  localparam int FlagHoming /*verilator public*/ = 6;  // homing (CommandHomeStart .. every joint referenced, a hold, a fault)
  localparam int FlagModel /*verilator public*/ = 7;  // a complete model whose CRC-32 checked is loaded (else enable is refused)

  // ---- joints ----
  // Homing (docs/homing.md): each upper arm closes its home switch at and above its reference angle.
  // While homing with the drives on, a joint's switch closing sets its count to HomeCount, marks the
  // joint referenced and turns the drives off (and flushes the buffer); a segment's reference change
  // then persists from one setpoint period to the next (a jog at constant speed, set by a setpoint).
  localparam int HomeCount /*verilator public*/ = 3_000;  // encoder count at reset and at the home switch: 30.00 deg (0.01 deg per count)
  localparam int EncoderCountMicrodeg /*verilator public*/ = 10_000;  // one encoder count: 0.01 deg
  localparam int PwmBits /*verilator public*/ = 10;  // PWM period 2^10 = 1024 board cycles (22.7 kHz)
  localparam int PwmPeriodCycles /*verilator public*/ = 1_024;  // 2^PwmBits
  localparam int CurrentFullScaleMilliamp /*verilator public*/ = 500;  // 100 % duty: the current limit, 0.5 A
  localparam int CurrentLimitCode /*verilator public*/ = 16_384;  // 0.5 A in Q1.15 (the controllers' limit)

  // ---- joint safety (joint_axes.sv, "Safety") ----
  localparam int FollowingBits /*verilator public*/ = 9;  // following error limit: -512 .. 511 counts (5.12 deg)
  localparam int WatchdogPeriods /*verilator public*/ = 2_500;  // drives on and no valid frame for 2500 periods (250 ms): fault
  localparam int MinTravelBlock /*verilator public*/ = -1;  // reference travel in 1024-count blocks:
  localparam int MaxTravelBlock /*verilator public*/ = 8;  //   -1024 .. 9215 counts (-10.24 .. 92.15 deg)

  // Fault cause bits (fault_cause_o of joint_axes, joint_fault_cause_o of board_core).
  localparam int FaultEncoderSkip /*verilator public*/ = 0;  // an encoder skipped a quadrature state
  localparam int FaultFollowing /*verilator public*/ = 1;  // reference - encoder outside the following limit
  localparam int FaultWatchdog /*verilator public*/ = 2;  // no valid frame for 250 ms with the drives on
  localparam int FaultTravel /*verilator public*/ = 3;  // a reference outside the travel
  localparam int FaultCauseBits /*verilator public*/ = 4;
  // The board's own latched causes, beside the joints' (each drives off, flushes the buffer, latches
  // until a clear-fault that finds the cause gone; never cleared by itself):
  // bit TelemetryEstopBit of the fault byte: an e-stop command (CommandEstop) was received;
  // bits BoardFaultShift + BoardFault* of the u16 at TelemetryBoardFaultOffset (the rejected counter's
  // word, whose count is 12 bits): the board's safety inputs (icebreaker_top.sv, docs/bench.md).
  localparam int TelemetryEstopBit /*verilator public*/ = 7;
  localparam int TelemetryBoardFaultOffset /*verilator public*/ = 44;  // = TelemetryRejectedOffset: bits 12-15
  localparam int BoardFaultShift /*verilator public*/ = 12;
  localparam int BoardFaultEstopInput /*verilator public*/ = 0;  // the e-stop chain opened (estop_open_i high)
  localparam int BoardFaultDrive /*verilator public*/ = 1;  // + j: drive j's fault line (drive_fault_i[j] high)
  localparam int BoardFaultBits /*verilator public*/ = 4;
  // Safety inputs: high = stop (the pins pulled up: a broken wire stops), synchronised, then sampled
  // at each control period's tick 0; BoardInputFilterPeriods samples in a row at the stop level latch
  // the cause (a shorter glitch is ignored): drives off within BoardInputFilterPeriods + 1 periods.
  localparam int BoardInputFilterPeriods /*verilator public*/ = 3;

  // ---- status LEDs ----
  localparam int LedWindowBits /*verilator public*/ = 11;  // LED windows: 2^11 control periods (0.2 s)

  // ---- stage sync output ----
  // stage_sync_o is bit StageSyncBit of the control periods since reset (the telemetry's board time):
  // it changes every 2^12 periods (0.4096 s of board time) and rises at its odd multiples. A measuring
  // stage that logs it beside its positions lets `deltactl merge` align the two clocks to within a
  // fraction of the stage's sample interval (docs/lab_loop.md).
  localparam int StageSyncBit /*verilator public*/ = 12;

endpackage
