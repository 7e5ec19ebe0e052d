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

  // ---- host link (8N1 UART) ----
  localparam int UartBaud /*verilator public*/ = 115_200;
  localparam int ClocksPerBit /*verilator public*/ = 202;  // round(BoardClockHz / UartBaud): 115,099 baud, -0.09 %

  // Frames of the present link (network_uart_link.sv; host side: host/include/delta/link_v1.hpp).
  localparam int LinkRequestSync /*verilator public*/ = 32'hA5;  // host -> board: sync, 3 x 4 code bytes, checksum
  localparam int LinkAnswerSync /*verilator public*/ = 32'h5A;  // board -> host: sync, 3 x 3 code bytes, checksum
  localparam int LinkNak /*verilator public*/ = 32'h15;  // board -> host: bad checksum or a code that does not fit
  localparam int LinkRequestCodeBytes /*verilator public*/ = 4;  // per input code (32-bit raw position)
  localparam int LinkAnswerCodeBytes /*verilator public*/ = 3;  // per output code (24-bit raw angle)

  // Frames of the next link (link v2, issue 12; C++ codec host/include/delta/link/frame_codec.hpp,
  // layout in docs/board_link.md; the RTL side is not written yet). A frame is
  // sync, length (payload bytes), sequence, type, payload, CRC-16 (high byte first) over
  // length..payload; CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF.
  localparam int FrameSync /*verilator public*/ = 32'h7E;
  localparam int FrameHeaderBytes /*verilator public*/ = 4;  // sync, length, sequence, type
  localparam int FrameCrcBytes /*verilator public*/ = 2;
  localparam int FrameMaxPayloadBytes /*verilator public*/ = 48;
  localparam int FrameCrcPolynomial /*verilator public*/ = 32'h1021;
  localparam int FrameCrcInit /*verilator public*/ = 32'hFFFF;
  localparam int FrameTypeIdentifyRequest /*verilator public*/ = 32'h01;  // host -> board, no payload
  localparam int FrameTypeSetpoint /*verilator public*/ = 32'h02;  // host -> board: sample index, 3 position codes
  localparam int FrameTypeCommand /*verilator public*/ = 32'h03;  // host -> board: one command byte
  localparam int FrameTypeIdentify /*verilator public*/ = 32'h81;  // board -> host
  localparam int FrameTypeTelemetry /*verilator public*/ = 32'h82;  // board -> host, 1 kHz
  localparam int SetpointPayloadBytes /*verilator public*/ = 16;  // u32 sample index, 3 x i32 position codes
  localparam int CommandPayloadBytes /*verilator public*/ = 1;
  localparam int IdentifyPayloadBytes /*verilator public*/ = 24;
  localparam int TelemetryPayloadBytes /*verilator public*/ = 44;

  // ---- joints ----
  localparam int HomeCount /*verilator public*/ = 3_000;  // encoder count at reset: 30.00 deg (0.01 deg per count)
  localparam int EncoderCountMicrodeg /*verilator public*/ = 10_000;  // one encoder count: 0.01 deg
  localparam int PwmBits /*verilator public*/ = 10;  // PWM period 2^10 = 1024 board cycles (22.7 kHz)
  localparam int PwmPeriodCycles /*verilator public*/ = 1_024;  // 2^PwmBits
  localparam int CurrentFullScaleMilliamp /*verilator public*/ = 500;  // 100 % duty: the current limit, 0.5 A
  localparam int CurrentLimitCode /*verilator public*/ = 16_384;  // 0.5 A in Q1.15 (the controllers' limit)

  // ---- joint safety (joint_axes.sv, "Safety") ----
  localparam int FollowingBits /*verilator public*/ = 9;  // following error limit: -512 .. 511 counts (5.12 deg)
  localparam int WatchdogPeriods /*verilator public*/ = 500;  // no new reference for 500 periods (50 ms): fault
  localparam int MinTravelBlock /*verilator public*/ = -1;  // reference travel in 1024-count blocks:
  localparam int MaxTravelBlock /*verilator public*/ = 8;  //   -1024 .. 9215 counts (-10.24 .. 92.15 deg)

  // Fault cause bits (fault_cause_o of joint_axes, joint_fault_cause_o of board_core).
  localparam int FaultEncoderSkip /*verilator public*/ = 0;  // an encoder skipped a quadrature state
  localparam int FaultFollowing /*verilator public*/ = 1;  // reference - encoder outside the following limit
  localparam int FaultWatchdog /*verilator public*/ = 2;  // the reference stream stopped
  localparam int FaultTravel /*verilator public*/ = 3;  // a reference outside the travel
  localparam int FaultCauseBits /*verilator public*/ = 4;

  // ---- status LEDs ----
  localparam int LedHoldBits /*verilator public*/ = 23;  // pulses held 2^23 board cycles (0.36 s)

  // ---- the Verilated test build (rtl/CMakeLists.txt: Vboard_core for tests and deltactl cosim) ----
  // A 20 MHz board clock in simulated time and a 5 Mbaud link, so tests run fast.
  localparam int SimClocksPerPeriod /*verilator public*/ = 2_000;
  localparam int SimClocksPerBit /*verilator public*/ = 4;

endpackage
