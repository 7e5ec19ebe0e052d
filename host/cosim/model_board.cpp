// The board at model fidelity (see model_board.hpp): board_core as a register-level C++ model of
// its control logic with the golden models for the arithmetic. Every register below is named as
// in the RTL (module prefix where two modules share a name); each clock computes the next values
// from the present ones, then commits them, as the RTL's always_ff blocks do.
#include "delta/cosim/model_board.hpp"

#include <algorithm>
#include <fstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/crc32.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/golden/setpoint_interpolation.hpp"
#include "delta/link/frame_codec.hpp"

namespace delta::cosim {
namespace {

constexpr int kClocksPerBit = static_cast<int>(board::kLinkClocksPerBit);
constexpr int kClocksPerPeriod = static_cast<int>(board::kClocksPerPeriod);
constexpr int kRingBytes = static_cast<int>(board::kRxRingBytes);
constexpr int kDepth = static_cast<int>(board::kSetpointDepth);
constexpr int kTelemetryWords = static_cast<int>(board::kTelemetryPayloadBytes / 2);
constexpr int kJoints = 3;
constexpr int kAllJoints = (1 << kJoints) - 1;  // a bit per joint, all set
// The all-ones mask of a counter that counts 0 .. count - 1 in the fewest bits (the RTL's
// $clog2(count) wide registers wrap there).
constexpr int counter_mask(long long count) {
  int bits = 0;
  while ((1LL << bits) < count) ++bits;
  return (1 << bits) - 1;
}
// joint_safety.sv's silent-period counter saturates at all ones: $clog2(WatchdogPeriods + 2) bits.
constexpr int kWatchdogMax = counter_mask(board::kWatchdogPeriods + 2);

// ---- the period schedule (board_core.sv; tick 0 .. ClocksPerPeriod - 1, phase 0 .. 9) ----
// The last phase k of a 1 kHz segment (board_core's phase_q wraps to 0 after it; reset value).
constexpr int kLastPhase = static_cast<int>(board::kPeriodsPerSetpoint) - 1;
// The tick of phase 0 that plays a setpoint; the controllers see ap_start (start_q, set at tick 0)
// in the same tick.
constexpr int kPlayTick = static_cast<int>(board::kPlayTick);
// The telemetry snapshot: the middle of phase 0's period (board_core.sv's snapshot).
constexpr int kSnapshotTick = kClocksPerPeriod / 2;
// The tick at which the interpolator starts computing the next period's references.
constexpr int kUpdateTick = kClocksPerPeriod - static_cast<int>(board::kInterpolationLeadClocks);
// The period's last tick: with the drives off the controllers are reset in it.
constexpr int kLastTick = kClocksPerPeriod - 1;
// The phase k after a period start.
constexpr int next_phase(int phase) { return phase == kLastPhase ? 0 : phase + 1; }

// ---- reference_interpolator.sv's update: kInterpolatorStepsPerJoint clocks per joint ----
constexpr int kDeltaStep = static_cast<int>(board::kInterpolatorDeltaStep);          // D from the answer
constexpr int kReferenceStep = static_cast<int>(board::kInterpolatorReferenceStep);  // r', d', the shift
constexpr int kStepsPerJoint = kReferenceStep + 1;                                   // step 7 rotates
constexpr std::uint64_t kUpdateClocks = static_cast<std::uint64_t>(kStepsPerJoint * kJoints);

// ---- joint_controller.sv's schedule after it sees ap_start ----
constexpr int kJointCycles = static_cast<int>(board::kJointControllerJointCycles);  // one joint's datapath run
constexpr int kLoadCycles = static_cast<int>(board::kJointControllerLoadCycles);    // ap_start seen (idle) to ap_ready
// The clock (cycles after ap_start was seen) in which joint j's PWM duty is set: the RTL stores
// current_q a clock before (at kLoadCycles + kJointCycles (j + 1)), which nothing but joint_pwm
// reads; the model stores both here.
constexpr std::uint64_t duty_cycle(int j) {
  return static_cast<std::uint64_t>(kLoadCycles + kJointCycles * (j + 1) + 1);
}
constexpr std::uint64_t kRunCycles = duty_cycle(2);  // ap_done (the RTL's, too)
// Registers the model folds where the RTL spends a clock nothing else can see:
//   link_tx's state 1 (a clock for the RAM read after a payload byte): the model's read is settled;
//   the controller's start_q, cleared at ap_ready in the RTL: here when the run starts (nothing
//   reads it while the controller runs); current_q, stored a clock before its duty (above);
//   link_rx's ring read while idle: the fetch that precedes every use of it reads it again.

// ---- the serial line, 8N1 at kClocksPerBit (B) clocks a bit ----
constexpr int kUartByteBits = 10;                // start bit, 8 data bits, stop bit
constexpr int kUartStopBit = kUartByteBits - 1;  // the stop bit's index: its middle ends a byte
constexpr int kRxSyncClocks = 2;                 // uart_rx's two-flip-flop synchroniser
// uart_rx: the start bit's first clock e reaches the synchroniser's output at e + 2; it waits B/2 + 1
// clocks to the start bit's middle, samples the data bits B clocks apart and sets valid in the
// clock at the stop bit's middle: e + 3 + B/2 + 9 B. The line at the TX pin (rtl::UartLine) sees
// the start bit after the clock uart_tx loads the byte and completes the byte B/2 + 9 B clocks
// later, at the stop bit's middle.
constexpr std::uint64_t kRxValidDelay = kRxSyncClocks + 1 + kClocksPerBit / 2 + kUartStopBit * kClocksPerBit;
constexpr std::uint64_t kTxByteDelay = kClocksPerBit / 2 + kUartStopBit * kClocksPerBit;
// The clocks one byte takes on the line.
constexpr std::uint64_t kLineByteClocks = static_cast<std::uint64_t>(kUartByteBits) * kClocksPerBit;
// link_tx hands uart_tx a byte in the first clock it finds it ready, which is 10 B + 1 clocks after
// the last: a frame's bytes load that far apart from the first (which waits for the UART's last).
constexpr std::uint64_t kTxByteClocks = kLineByteClocks + 1;

// ---- link_rx (frame layout: the board facts) ----
constexpr int kHeaderBytes = static_cast<int>(board::kFrameHeaderBytes);  // sync, length, sequence, type
constexpr int kLengthByte = 1;                                            // frame byte index of the length
constexpr int kSequenceByte = 2;                                          // ... of the sequence
constexpr int kTypeByte = kHeaderBytes - 1;                               // ... of the type, the header's last
// link_rx's index_q and end_q (6 bits): a frame's bytes.
constexpr int kFrameIndexMask =
    counter_mask(board::kFrameHeaderBytes + board::kFrameMaxPayloadBytes + board::kFrameCrcBytes);
// A byte into an idle ring is written, fetched and processed in these clocks (one micro clock).
constexpr int kWholeByteClocks = 3;
// The interpolator's whole update in one micro clock wants the encoder lines held and no byte for
// link_rx for its kUpdateClocks and this many clocks more.
constexpr std::uint64_t kWholeUpdateSlack = 4;

// ---- setpoint_buffer: a setpoint payload is its sample index, then the positions' bytes ----
constexpr int kIndexBytes = static_cast<int>(board::kSetpointInputOffset);  // u32 sample index
constexpr int kPositionBytes = static_cast<int>(board::kSetpointPayloadBytes - board::kSetpointInputOffset);
constexpr int kPositionCodeBytes = kPositionBytes / 3;  // one i16 scaled input code

// ---- link_tx's payload RAM: identify words from 0, telemetry words from kTelemetryWordBase ----
constexpr int kTelemetryWordBase = static_cast<int>(board::kLinkTxTelemetryWord);
constexpr int kTxWordMask = static_cast<int>(board::kLinkTxWords) - 1;
constexpr int kCaptureMask = counter_mask(kTelemetryWords);  // link_tx's capture_q (5 bits)
constexpr int kTxIdle = 0;                                   // link_tx's state: idle
constexpr int kTxSending = 2;  // sending (Send; the model schedules the frame on the TX line at once)

// ---- fixed-point formats ----
constexpr int kReferenceFractionBits = 8;  // references Q24.8 counts
constexpr int kReferenceCountBits = 24;    // the reference's whole counts (bits 31..8)
constexpr int kDifferenceBits = 17;        // joint_safety.sv's following-error difference
constexpr int kTravelBlockBits = 10;       // joint_safety.sv's travel blocks: 1024 counts
constexpr int kNetworkOutputBits = 24;     // the network's y_j (Q10.14 degrees)

// board_core's status counters (bad frames, underruns, slew limits, refused): StatusCounterBits wide.
constexpr std::uint16_t kCounterMax = (1u << board::kStatusCounterBits) - 1;
std::uint16_t saturating_increment(std::uint16_t value) { return value == kCounterMax ? value : value + 1; }

// The link CRC-16 register after one more byte (link_crc16.sv; the host's link::crc16).
std::uint16_t crc_byte(std::uint16_t crc, std::uint8_t data) { return link::crc16(&data, 1, crc); }

// stage_sync_o (board_core.sv): a bit of the control periods since reset.
bool stage_sync(std::uint32_t period_count) { return ((period_count >> board::kStageSyncBit) & 1U) != 0; }

int payload_size(std::uint8_t type, bool* known) {
  *known = true;
  if (type == board::kFrameTypeIdentifyRequest) return 0;
  if (type == board::kFrameTypeSetpoint) return static_cast<int>(board::kSetpointPayloadBytes);
  if (type == board::kFrameTypeCommand) return static_cast<int>(board::kCommandPayloadBytes);
  if (type == board::kFrameTypeModel) return static_cast<int>(board::kModelPayloadBytes);
  *known = false;
  return 0;
}

// What link_rx did with the byte it processed (link_rx.sv's frame parser).
struct RxProcessed {
  bool frame_start = false;    // a known type with its length: the payload follows
  bool payload_valid = false;  // a payload byte (at index - kHeaderBytes)
  bool frame_ok = false;       // the CRC's low byte matched: the frame ends, taken
  bool frame_bad = false;      // dropped (unknown type, wrong length, CRC): rescanned from after its sync
};

// Whether link_rx processing `byte` ends a frame or drops one.
template <typename Registers>
bool rx_byte_ends_frame(const Registers& s, std::uint8_t byte) {
  if (s.index == kTypeByte) {
    bool known = false;
    const int size = payload_size(byte, &known);
    return !(known && s.length == size);
  }
  return s.index >= kHeaderBytes && s.index > s.end;
}

// link_rx processing the byte it fetched: its registers' next values in `n` from the present ones
// in `s` (n may be s: every present value is read before any is written).
template <typename Registers>
RxProcessed process_rx_byte(const Registers& s, std::uint8_t byte, Registers& n) {
  const int index = s.index, read = s.read, start = s.start, end = s.end;
  const std::uint8_t length = s.length;
  const std::uint16_t crc = s.rx_crc;
  const bool crc_high_ok = s.crc_high_ok;
  RxProcessed out;
  n.read = (read + 1) % kRingBytes;
  if (index == 0) {
    if (byte == board::kFrameSync) {
      n.start = read;
      n.index = 1;
      n.rx_crc = 0xFFFF;
    }
  } else if (index < kHeaderBytes) {
    n.rx_crc = crc_byte(crc, byte);
    n.index = index + 1;
    if (index == kLengthByte) n.length = byte;
    if (index == kSequenceByte) n.sequence = byte;
    if (index == kTypeByte) {
      n.type = byte;
      bool known = false;
      const int size = payload_size(byte, &known);
      n.end = (size + kHeaderBytes) & kFrameIndexMask;
      if (known && length == size) {
        out.frame_start = true;
      } else {
        out.frame_bad = true;
        n.index = 0;
        n.read = (start + 1) % kRingBytes;
      }
    }
  } else if (index < end) {
    n.rx_crc = crc_byte(crc, byte);
    out.payload_valid = true;
    n.index = index + 1;
  } else if (index == end) {
    n.crc_high_ok = byte == (crc >> 8);
    n.index = index + 1;
  } else {
    n.index = 0;
    if (crc_high_ok && byte == (crc & 0xFF)) {
      out.frame_ok = true;
    } else {
      out.frame_bad = true;
      n.read = (start + 1) % kRingBytes;
    }
  }
  return out;
}

// Slots of a joint in the controllers' state memory (rtl/joint/delta_joint_pkg.sv, Slot*).
constexpr int kSlotReference = 0;
constexpr int kSlotEncoder = 3;
constexpr int kSlotCurrent = 6;
using PeekMemory = std::array<std::array<std::uint32_t, 8>, 3>;

// The state word telemetry word w reads from the controllers' memory (board_core.sv's peek
// decode: references two words each, then counts and currents one word each; 0 past joint 2).
std::uint32_t peek_word(const PeekMemory& memory, int w) {
  const int reference_word = static_cast<int>(board::kTelemetryReferencesOffset / 2);
  const int count_word = static_cast<int>(board::kTelemetryCountsOffset / 2);
  const int current_word = static_cast<int>(board::kTelemetryCurrentsOffset / 2);
  int joint = 0, slot = kSlotReference;
  if (w >= current_word) {
    joint = (w - current_word) & 3;
    slot = kSlotCurrent;
  } else if (w >= count_word) {
    joint = (w - count_word) & 3;
    slot = kSlotEncoder;
  } else if (w >= reference_word) {
    joint = ((w - reference_word) >> 1) & 3;
  }
  return joint < 3 ? memory[joint][slot] : 0;
}

// quadrature_counter.sv: the move from the last {A, B} to this one (+1, -1, 0), or a skipped state.
constexpr int kSkippedState = 2;
int quadrature_move(int previous, int ab) {
  switch ((previous << 2) | ab) {
    case 0b0010:
    case 0b1011:
    case 0b1101:
    case 0b0100:
      return 1;
    case 0b0001:
    case 0b0111:
    case 0b1110:
    case 0b1000:
      return -1;
    case 0b0011:
    case 0b1100:
    case 0b0110:
    case 0b1001:
      return kSkippedState;
    default:
      return 0;
  }
}

// ---- the board's safety inputs, its e-stop and the bench jog (board_core.sv) ----
// The safety inputs in one word as ModelBoard::safety_in_ and the registers hold them: bit
// BoardFaultEstopInput the e-stop chain open, bit BoardFaultDrive + j drive j's fault line (1 = stop).
constexpr int kBoardInputs = static_cast<int>(board::kBoardFaultBits);
// board_safety_inputs.sv keeps each input's last BoardInputFilterPeriods - 1 samples (bit 0 the last).
constexpr int kHistoryMask = (1 << (board::kBoardInputFilterPeriods - 1)) - 1;
constexpr int kJogCommands = 2 * kJoints;  // CommandJogBase + 2 j + n
constexpr std::uint16_t kJogCurrent = static_cast<std::uint16_t>(board::kJogCurrentCode);

// Any latched cause (the joints', the board inputs', the e-stop command): board_core's fault.
template <typename Registers>
bool faulted(const Registers& s) {
  return s.fault_cause != 0 || s.board_cause != 0 || s.estop;
}
// The drives on (drive_enable_o's next value): enabled or a bench jog, no cause latched.
template <typename Registers>
bool drives_on(const Registers& s) {
  return (s.enabled || s.jog) && !faulted(s);
}
// A safety input's last sample (the last tick 0) at the stop level (board_safety_inputs.sv's
// stopping_o): a clear-fault is refused.
template <typename Registers>
bool input_active(const Registers& s) {
  for (int i = 0; i < kBoardInputs; ++i)
    if ((s.history[i] & 1) != 0) return true;
  return false;
}
// The current joint_pwm takes for joint j: the controller's, or while a bench jog runs the jog's
// (+-JogCurrentCode on its joint, 0 on the others).
template <typename Registers>
std::uint16_t jog_current(const Registers& s, int j) {
  if (j != s.jog_joint) return 0;
  return s.jog_negative ? static_cast<std::uint16_t>(-static_cast<int>(kJogCurrent)) : kJogCurrent;
}

// The home switches ride in bits kHomeSwitchShift.. of the A lines (ModelBoard::clock): board_core's
// synchronisers and previous state. A rising edge while homing with the drives on references its
// joint (switch_edge: a full clock's work, never a quiet one's).
constexpr int kHomeSwitchShift = kJoints;
template <typename Registers>
int switch_edge(const Registers& s) {
  if (!s.homing || !s.enabled || faulted(s)) return 0;
  return ((s.enc_a >> kHomeSwitchShift) & kAllJoints) & ~s.switch_previous & ~s.referenced & kAllJoints;
}

// One quiet clock (no set-home, no switch edge) of the encoder synchronisers and quadrature
// counters, in place. True if a joint skipped a state (its step error is set).
template <typename Registers>
bool count_encoders(Registers& s, int encoder_a, int encoder_b) {
  bool skipped = false;
  s.switch_previous = (s.enc_a >> kHomeSwitchShift) & kAllJoints;
  for (int j = 0; j < kJoints; ++j) {
    const int ab = (((s.enc_a >> j) & 1) << 1) | ((s.enc_b >> j) & 1);
    const int move = quadrature_move(s.previous[j], ab);
    if (move == kSkippedState) {
      s.step_error[j] = true;
      skipped = true;
    } else {
      s.count[j] = static_cast<std::uint16_t>(s.count[j] + move);
      if (move != 0) s.rising[j] = move > 0;
    }
    s.previous[j] = ab;
  }
  s.enc_a = s.enc_a_meta;
  s.enc_a_meta = encoder_a;
  s.enc_b = s.enc_b_meta;
  s.enc_b_meta = encoder_b;
  return skipped;
}

// The synchronisers and counters hold these pins: a clock with them changes nothing.
template <typename Registers>
bool encoders_settled(const Registers& s, int encoder_a, int encoder_b) {
  if (s.enc_a_meta != encoder_a || s.enc_a != encoder_a || s.enc_b_meta != encoder_b || s.enc_b != encoder_b ||
      s.switch_previous != ((encoder_a >> kHomeSwitchShift) & kAllJoints)) {
    return false;
  }
  for (int j = 0; j < kJoints; ++j) {
    if (s.previous[j] != ((((encoder_a >> j) & 1) << 1) | ((encoder_b >> j) & 1))) return false;
  }
  return true;
}

// joint_pwm: joint j's duty and direction from its stored current (Q1.15 A): the current limit,
// CurrentLimitCode = 2^kCurrentLimitBits, is 100 % duty.
constexpr int kCurrentLimitBits = 14;
static_assert((1LL << kCurrentLimitBits) == board::kCurrentLimitCode, "the current limit is a power of two");
int duty_of(std::uint16_t current) {
  const std::int16_t c = static_cast<std::int16_t>(current);
  const int magnitude = c < 0 ? static_cast<std::uint16_t>(-c) : c;
  return (magnitude >> (kCurrentLimitBits - board::kPwmBits)) & ((1 << (board::kPwmBits + 1)) - 1);
}
template <typename Registers>
void set_duty(Registers& n, int j, std::uint16_t current) {
  n.duty[j] = duty_of(current);
  n.direction = (n.direction & ~(1 << j)) | ((static_cast<std::int16_t>(current) < 0 ? 1 : 0) << j);
}
// While a bench jog runs joint_pwm takes the jog's currents every clock instead of the
// controllers' (and currents 0 in the clock after it ends): n's duties and directions from the
// present jog registers in s (n may be s). False: no jog, the controllers' stores stand.
template <typename Registers>
bool jog_duties(const Registers& s, Registers& n) {
  if (!s.jog && !s.jog_tail) return false;
  for (int j = 0; j < kJoints; ++j) set_duty(n, j, s.jog ? jog_current(s, j) : std::uint16_t{0});
  return true;
}
// Whether the duty registers already hold what jog_duties writes (a clock that writes them again
// changes nothing).
template <typename Registers>
bool jog_duties_held(const Registers& s) {
  for (int j = 0; j < kJoints; ++j) {
    const std::uint16_t current = jog_current(s, j);
    if (s.duty[j] != duty_of(current) || ((s.direction >> j) & 1) != (static_cast<std::int16_t>(current) < 0 ? 1 : 0))
      return false;
  }
  return true;
}
// The direction pins: the stored signs while the drives are on, low while they are off.
template <typename Registers>
int direction_pins(const Registers& s) {
  return s.enable_out ? s.direction : 0;
}

// joint_controller and joint_pwm in the clock `elapsed` cycles after ap_start was seen: joint j's
// current stored with its duty at duty_cycle(j), the run's end with the third (n: the next values,
// whose next_current and overflow are the present ones here).
constexpr int kOverflowMax = 0xFFFF;  // joint_controller's overflow_count sticks at its 16-bit maximum
template <typename Registers>
void store_current(Registers& n, std::uint64_t elapsed) {
  for (int j = 0; j < kJoints; ++j) {
    if (elapsed == duty_cycle(j)) {
      n.current[j] = static_cast<std::uint16_t>(n.next_current[j]);
      n.peek_memory[j][kSlotCurrent] = static_cast<std::uint32_t>(static_cast<std::int32_t>(n.next_current[j]));
      n.overflow = static_cast<std::uint16_t>(std::min<int>(kOverflowMax, n.overflow + n.next_overflow[j]));
      set_duty(n, j, n.current[j]);
    }
  }
  if (elapsed == kRunCycles) {
    n.running = false;
    n.primed = true;
  }
}

std::int32_t sign_extend(std::uint32_t value, int bits) {
  const std::uint32_t m = 1u << (bits - 1);
  value &= (bits == 32) ? 0xFFFFFFFFu : ((1u << bits) - 1);
  return static_cast<std::int32_t>((value ^ m) - m);
}

// The network's model memories: 256 words each, addressed by frame number (delta_network.sv).
constexpr std::size_t kModelMemoryWords = 256;

// CRC-32/ISO-HDLC, reflected (model_loader.sv's bit-serial CRC).
constexpr std::uint32_t kCrc32Polynomial = 0xEDB88320u;

// Joint j's play word as the loader wrote it (frame ModelPlayFrame + j, docs/board_link.md, "The
// model"): H_j (Q.8 counts) and the play shift's ends and rounding, which the interpolator takes as
// they are (golden::model_words derives them from H_j; a word that came corrupted keeps its own).
constexpr int kHalfPlayBits = static_cast<int>(board::kHalfPlayBits);
constexpr int kPlayEndBits = golden::kShiftBits;  // above_j, below_j: a play shift each
constexpr int kPlayAboveShift = kHalfPlayBits;
constexpr int kPlayBelowShift = kPlayAboveShift + kPlayEndBits;
constexpr int kPlayRoundsBit = kPlayBelowShift + kPlayEndBits;
constexpr int kPlayWordBits = kPlayRoundsBit + 1;
static_assert(kPlayAboveShift == 17 && kPlayBelowShift == 27 && kPlayRoundsBit == 37,
              "the play word's fields are not docs/board_link.md's");
struct PlayWord {
  std::int32_t half_play = 0;          // H_j, unsigned
  std::uint32_t above = 0, below = 0;  // the ends, kPlayEndBits bits
  bool rounds = false;
};
PlayWord play_word(std::uint64_t word) {
  PlayWord p;
  p.half_play = static_cast<std::int32_t>(word & ((1u << kHalfPlayBits) - 1));
  p.above = static_cast<std::uint32_t>(word >> kPlayAboveShift) & ((1u << kPlayEndBits) - 1);
  p.below = static_cast<std::uint32_t>(word >> kPlayBelowShift) & ((1u << kPlayEndBits) - 1);
  p.rounds = ((word >> kPlayRoundsBit) & 1) != 0;
  return p;
}

// identify's weights CRC (model_loader.sv's crc_o): the checked CRC with a model, else 0.
template <typename Registers>
std::uint32_t identify_crc(const Registers& s) {
  return s.loaded ? ~s.load_crc : 0;
}

// Joint j's play word in the interpolator's RAM as of clock `cycle` (its content in that clock,
// before the clock's write): the word written at play_written[j] is there from the next clock.
// The interpolator reads it into a register every clock (play_q, the word of the joint it works
// on), and its pipeline takes H from that register a clock later: an update's step 4 (D) sees H
// as of two clocks before, its step 7 the play's ends as of a clock before and H (inside the
// play or not) as of two.
template <typename Registers>
PlayWord play_as_of(const Registers& s, int j, std::uint64_t cycle) {
  return play_word(cycle > s.play_written[j] ? s.play[j] : s.play_before[j]);
}

// reference_interpolator.sv, step 4: joint j's segment change D, the play taken out of the distance
// from the reference r to its answer (C), saturated; the held D unless a new answer is taken.
std::int32_t segment_delta(std::int32_t answer, std::int32_t r, const PlayWord& play, bool take, std::int32_t held,
                           bool* saturated) {
  const std::int64_t diff = golden::play(golden::interpolation::reference_counts(answer) - r, play.half_play);
  *saturated = diff > golden::interpolation::kDeltaMax || diff < golden::interpolation::kDeltaMin;
  if (!take) return held;
  return static_cast<std::int32_t>(
      *saturated ? (diff < 0 ? golden::interpolation::kDeltaMin : golden::interpolation::kDeltaMax) : diff);
}

// Bit j: joint j's count last stepped up (the telemetry's play sides).
template <typename Registers>
int rising_bits(const Registers& s) {
  return (s.rising[0] ? 1 : 0) | (s.rising[1] ? 2 : 0) | (s.rising[2] ? 4 : 0);
}

// Step 7: the play's shift of the reference r toward its answer once one has come since the
// enable, else the resting shift on the side joint j's count last stepped to (reference_interpolator.sv:
// an end of the play word, or inside the play floor((d + g) / 256), g = 128 where the word rounds;
// golden interpolation::play_shift and resting_shift for a word golden::model_words wrote).
// `ends`: the play word as the step sees its ends, `play`: as it sees H.
template <typename Registers>
std::int16_t reference_shift(const Registers& s, int j, const PlayWord& ends, const PlayWord& play) {
  const std::int64_t diff = std::int64_t{golden::interpolation::reference_counts(s.net_outputs[j])} - s.r[j];
  const std::int64_t played = diff < 0 ? diff + play.half_play : diff - play.half_play;
  const bool in_play = (played < 0) != (diff < 0);
  std::uint32_t shift = 0;
  if (!s.answered || !in_play) {
    const bool end_up = s.answered ? diff >= 0 : s.rising[j];
    shift = end_up ? ends.above : ends.below;
  } else {
    shift = static_cast<std::uint32_t>((diff >> 8) + ((ends.rounds && ((diff >> 7) & 1) != 0) ? 1 : 0));
  }
  return static_cast<std::int16_t>(sign_extend(shift, kPlayEndBits));
}

// Step 7: the reference's change over the period from weight K_phase to K_phase+1 of D.
std::int64_t reference_step(std::int32_t delta, int phase) {
  const int next = phase + 1;  // the RTL's k_next (K_10 after phase 9)
  const std::int64_t weight_now = golden::interpolation::kWeights[phase];
  const std::int64_t weight_next = next == board::kPeriodsPerSetpoint
                                       ? (std::int64_t{1} << golden::interpolation::kWeightShift)
                                       : golden::interpolation::kWeights[next];
  constexpr int shift = static_cast<int>(board::kInterpolationShift);
  return golden::round_shift(std::int64_t{delta} * weight_next, shift) -
         golden::round_shift(std::int64_t{delta} * weight_now, shift);
}

// Step 7 of joint j: its next reference r' (the count in Q24.8 with the drives off), the segment
// change kept for the next period d' (0 with the drives off and at a segment's end unless homing)
// and the play shift written for the next period.
template <typename Registers>
void reference_next(const Registers& s, int j, bool enabled, std::int32_t* r, std::int32_t* d, std::int16_t* shift) {
  const std::int64_t step = reference_step(s.delta, s.phase);
  *r = enabled ? static_cast<std::int32_t>(static_cast<std::uint32_t>(s.r[j]) + static_cast<std::uint32_t>(step))
               : static_cast<std::int32_t>(static_cast<std::int16_t>(s.count[j])) * (1 << kReferenceFractionBits);
  *d = (!enabled || (s.phase == kLastPhase && !s.homing)) ? 0 : s.delta;
  *shift = reference_shift(s, j, play_as_of(s, j, s.cycle - 1), play_as_of(s, j, s.cycle - 2));
}

// joint_safety.sv's pipeline registers of joint j from the period's reference r (Q24.8) and latched
// count: the following difference (17 bits) and the travel flag (the reference's 1024-count block).
template <typename Registers>
void safety_registers(const Registers& s, int j, std::int32_t* difference, bool* outside) {
  const std::int32_t reference_count = s.r[j] >> kReferenceFractionBits;  // bits 31..8 (24-bit signed)
  const std::int32_t reference17 = sign_extend(static_cast<std::uint32_t>(reference_count), kDifferenceBits);
  *difference =
      sign_extend(static_cast<std::uint32_t>(reference17 - static_cast<std::int16_t>(s.counts_q[j])), kDifferenceBits);
  const std::int32_t block =
      sign_extend(static_cast<std::uint32_t>(reference_count), kReferenceCountBits) >> kTravelBlockBits;
  *outside = block < board::kMinTravelBlock || block > board::kMaxTravelBlock;
}

// joint_safety.sv's conditions from its registers: bit j of *following, the difference outside
// the following limit; of *outside, the reference outside the travel.
template <typename Registers>
void safety_conditions(const Registers& s, int* following, int* outside) {
  *following = 0;
  *outside = 0;
  for (int j = 0; j < kJoints; ++j) {
    const std::int32_t high = s.difference_q[j] >> board::kFollowingBits;
    if (high != 0 && high != -1) *following |= 1 << j;
    if (s.outside_q[j]) *outside |= 1 << j;
  }
}

}  // namespace

// The block RAMs: written in place (never read in the cycle that writes the same word), not
// copied with the registers every clock.
struct ModelBoard::Memories {
  std::array<std::uint8_t, board::kRxRingBytes> ring{};                               // link_rx
  std::array<std::array<std::uint8_t, kPositionBytes>, board::kSetpointDepth> ram{};  // setpoint_buffer
  std::array<std::uint16_t, board::kLinkTxWords> words{};                             // link_tx: identify, telemetry
  // The model's words as the loader wrote them (frame n's at n; the scaling frames' are not kept).
  std::array<std::uint64_t, board::kModelCommitFrame> model{};
};

struct ModelBoard::State {
  golden::JointFixedCoefficients coefficients = golden::make_fixed_coefficients(golden::JointControllerParameters{});
  std::uint64_t cycle = 0;

  // uart_rx: its byte and valid (the line's bytes, their clocks in ModelBoard::rx_line_)
  std::uint8_t rx_shift = 0;
  bool rx_valid = false;
  // link_rx
  std::uint8_t ring_data = 0;
  int write = 0, read = 0, start = 0, index = 0, end = 0;
  bool fetched = false, crc_high_ok = false;
  std::uint8_t length = 0, type = 0, sequence = 0;
  std::uint16_t rx_crc = 0xFFFF;
  // commands
  std::uint8_t command = 0;
  bool enabled = false, holding = false, homed = false;
  bool homing = false;  // board_core's homing_q
  int referenced = 0;   // bit j: joint j homed at its switch
  // schedule
  int tick = 0, phase = kLastPhase;
  std::uint32_t period_count = 0;
  // setpoint buffer
  std::uint32_t sample_index = 0;
  int fill = 0;
  bool full_at_start = false, index_match = false, vetoed = false, starting = false;
  // model_loader: the model frame's payload as link_rx presents it (number_q, the frame number's
  // low byte; number_high_q, its high byte not zero; word_q, then shifted into the CRC), the load's
  // next frame (expected_q), loading_q, loaded_q (flag 7), the CRC register crc_q and the bits it
  // still takes (shift_count_q: link_rx's parser stalls meanwhile)
  int load_number = 0;
  bool load_number_high = false;
  std::uint64_t load_word = 0;
  int load_expected = 0;
  bool loading = false, loaded = false;
  std::uint32_t load_crc = 0;
  bool load_restart = false;  // restart_q: the word shifting is frame 0's (the CRC from all ones)
  int load_shift = 0;
  // reference_interpolator's play words (its block RAM, frames ModelPlayFrame + j), each word
  // before its last write and that write's clock (the interpolator's read register and pipeline
  // see a write a clock and two clocks late: play_as_of)
  std::array<std::uint64_t, 3> play{}, play_before{};
  std::array<std::uint64_t, 3> play_written{};
  // network (its answer, held) and the interpolator
  std::array<std::int32_t, 3> net_outputs{};
  bool answer_pending = false;
  bool answered = false;  // an answer came since the drives came on (the interpolator's answered_q)
  bool busy = false;
  int step = 0, joint = 0;
  std::array<std::int32_t, 3> r{}, d{};
  std::array<std::int16_t, 3> shift{};  // the play shifts written for the next period (state RAM slot 7)
  std::int32_t delta = 0;
  bool delta_saturated = false;
  bool slew_limited = false;
  // encoders
  int enc_a_meta = 0, enc_a = 0, enc_b_meta = 0, enc_b = 0;
  std::array<int, 3> previous{};
  int switch_previous = 0;  // the home switches' previous synchronised state
  std::array<std::uint16_t, 3> count{};
  std::array<bool, 3> rising{true, true, true};  // the count last stepped up (quadrature_counter's rising_q)
  std::array<bool, 3> step_error{};
  // joint_axes
  bool start_q = false;
  std::array<std::uint16_t, 3> counts_q{};
  int encoder_error = 0;
  // joint_safety
  int silent_periods = 0;
  bool check = false, checked = false, active = false;
  int fault_cause = 0;
  std::array<std::int32_t, 3> difference_q{};
  std::array<bool, 3> outside_q{};
  // the safety inputs (bit BoardFaultEstopInput, BoardFaultDrive + j): the two-flip-flop
  // synchroniser, each input's filter (stop-level samples in a row at tick 0, saturating at
  // BoardInputFilterPeriods), the latched board causes; the e-stop command's latch
  int safety_meta = 0, safety = 0;
  std::array<int, kBoardInputs> history{};
  int board_cause = 0;
  bool estop = false;
  // the bench jog: running (and a clock after it ran: jog_tail), its joint and sign, the tick 0s
  // it still runs to
  bool jog = false, jog_tail = false, jog_negative = false;
  int jog_joint = 0, jog_periods = 0;
  // joint_controller
  bool running = false, primed = false;
  // A quiet clock has recomputed the registers that only follow constant inputs in quiet clocks
  // (link_tx's RAM read, the peek, the safety pipeline): they hold until a full clock.
  bool settled = false;
  std::uint64_t run_start = 0;  // the cycle it saw ap_start
  std::array<golden::JointFixedState, 3> joint_state{};
  std::array<std::int16_t, 3> next_current{};
  std::array<int, 3> next_overflow{};
  std::array<std::uint16_t, 3> current{};  // current_q
  std::uint16_t overflow = 0;
  PeekMemory peek_memory{};  // the last run's slots
  std::uint32_t peek_data = 0;
  // joint_pwm
  int pwm_phase = 0;
  std::array<int, 3> duty{};
  int direction = 0, pwm = 0;
  bool enable_out = false;
  // counters
  std::uint16_t bad_frames = 0, underruns = 0, slew_limits = 0, refused = 0;
  std::uint8_t last_sequence = 0;
  // link_tx
  bool capturing = false, writing = false, telemetry_pending = false, identify_pending = false;
  int capture = 0, written = 0, word_index = 0;
  int tx_state = kTxIdle, tx_length = 0;  // kTxIdle, kTxSending (a frame scheduled on the TX line)
  bool is_identify = false;
  std::uint8_t telemetry_sequence = 0, tx_sequence = 0, identify_sequence = 0;
  std::uint64_t tx_last_load = 0;  // the frame's last byte to uart_tx (link_tx idle from the next clock)
  std::uint64_t uart_free = 0;     // the first clock uart_tx is ready after it
};

ModelBoard::ModelBoard(const std::string& identify_mem)
    : memories_(std::make_unique<Memories>()),
      state_(std::make_unique<State>()),
      next_state_(std::make_unique<State>()) {
  State& s = *state_;
  s.count.fill(static_cast<std::uint16_t>(board::kHomeCount));
  std::ifstream in(identify_mem);
  if (!in) throw std::runtime_error("model board: cannot read " + identify_mem);
  std::string line;
  for (int w = 0; w < board::kLinkTxWords && std::getline(in, line);) {
    if (line.empty() || line[0] == '/') continue;
    memories_->words[w++] = static_cast<std::uint16_t>(std::stoul(line, nullptr, 16));
  }
}

ModelBoard::~ModelBoard() = default;

// The registers that only follow inputs constant in quiet clocks (link_tx's RAM read, the peek,
// the safety pipeline), as the first quiet clock after a full one computes them; they hold then.
void ModelBoard::settle() {
  State& s = *state_;
  s.peek_data = peek_word(s.peek_memory, s.capture);
  s.word_index = s.capture;
  for (int j = 0; j < kJoints; ++j) safety_registers(s, j, &s.difference_q[j], &s.outside_q[j]);
  s.settled = true;
}

// Whether the next clock is quiet (see quiet_clock), whatever the encoder lines show.
bool ModelBoard::quiet() const {
  const State& s = *state_;
  const int tick = s.tick;
  if (tick == 0 || tick == kPlayTick || (tick == kSnapshotTick && s.phase == 0) || tick == kUpdateTick ||
      (tick == kLastTick && !s.enabled)) {
    return false;
  }
  // uart_rx: no byte for link_rx (a byte's valid is set at the end of a run, see skip).
  if (s.rx_valid) return false;
  // link_rx idle and settled; nothing pending in the setpoint buffer, interpolator or safety.
  if (s.fetched || s.read != s.write) return false;
  // The interpolator acts in steps kDeltaStep (the segment's change) and kReferenceStep (the
  // reference) of each joint; the steps between only count.
  const bool interpolating = s.busy && (s.step == kDeltaStep || s.step == kReferenceStep);
  if (s.starting || interpolating || s.slew_limited || s.check || s.checked) return false;
  if (s.load_shift != 0) return false;  // the loader's CRC (link_rx stalled)
  if (s.step_error[0] || s.step_error[1] || s.step_error[2]) return false;
  if (switch_edge(s) != 0) return false;
  if (!safety_settled()) return false;  // the safety inputs' synchroniser takes a change
  if (s.jog != s.jog_tail || (s.jog && !jog_duties_held(s))) return false;  // the jog writes the duties
  const bool fault = faulted(s);
  if (fault && (s.enabled || s.holding || s.homing || s.jog)) return false;  // a fault ends homing, enabled or not
  if (s.answered && (!s.enabled || fault)) return false;                     // the interpolator forgets the answer
  if (!s.enabled && s.silent_periods != 0) return false;
  if (s.enabled && s.silent_periods > board::kWatchdogPeriods) return false;
  if (s.running) {
    const std::uint64_t elapsed = s.cycle - s.run_start;
    if (elapsed == duty_cycle(0) || elapsed == duty_cycle(1) || elapsed == duty_cycle(2)) {
      return false;
    }
  }
  // link_tx idle or waiting for uart_tx inside a bit; no capture.
  if (s.capturing || s.writing) return false;
  if (s.tx_state == kTxIdle && (s.telemetry_pending || s.identify_pending)) return false;
  return true;
}

// The registers the run check compares (all but link_rx's idle ring read, which the model leaves to
// the fetch, and the joint states, which change only in full clocks).
#define DELTA_MODEL_BOARD_REGISTERS(X) \
  X(cycle)                             \
  X(rx_shift)                          \
  X(rx_valid)                          \
  X(write)                             \
  X(read)                              \
  X(start)                             \
  X(index)                             \
  X(end)                               \
  X(fetched)                           \
  X(crc_high_ok)                       \
  X(length)                            \
  X(type)                              \
  X(sequence)                          \
  X(rx_crc)                            \
  X(command)                           \
  X(enabled)                           \
  X(holding)                           \
  X(homed)                             \
  X(homing)                            \
  X(referenced)                        \
  X(switch_previous)                   \
  X(tick)                              \
  X(phase)                             \
  X(period_count)                      \
  X(sample_index)                      \
  X(fill)                              \
  X(full_at_start)                     \
  X(index_match)                       \
  X(vetoed)                            \
  X(starting)                          \
  X(net_outputs)                       \
  X(answer_pending)                    \
  X(answered)                          \
  X(busy)                              \
  X(step)                              \
  X(joint)                             \
  X(r)                                 \
  X(d)                                 \
  X(shift)                             \
  X(delta)                             \
  X(slew_limited)                      \
  X(load_number)                       \
  X(load_number_high)                  \
  X(load_word)                         \
  X(load_expected)                     \
  X(loading)                           \
  X(loaded)                            \
  X(load_crc)                          \
  X(load_restart)                      \
  X(load_shift)                        \
  X(play)                              \
  X(play_before)                       \
  X(play_written)                      \
  X(enc_a_meta)                        \
  X(enc_a)                             \
  X(enc_b_meta)                        \
  X(enc_b)                             \
  X(previous)                          \
  X(count)                             \
  X(rising)                            \
  X(step_error)                        \
  X(start_q)                           \
  X(counts_q)                          \
  X(encoder_error)                     \
  X(silent_periods)                    \
  X(check)                             \
  X(checked)                           \
  X(active)                            \
  X(fault_cause)                       \
  X(safety_meta)                       \
  X(safety)                            \
  X(history)                           \
  X(board_cause)                       \
  X(estop)                             \
  X(jog)                               \
  X(jog_tail)                          \
  X(jog_negative)                      \
  X(jog_joint)                         \
  X(jog_periods)                       \
  X(difference_q)                      \
  X(outside_q)                         \
  X(running)                           \
  X(primed)                            \
  X(run_start)                         \
  X(next_current)                      \
  X(next_overflow)                     \
  X(current)                           \
  X(overflow)                          \
  X(peek_memory)                       \
  X(peek_data)                         \
  X(pwm_phase)                         \
  X(duty)                              \
  X(direction)                         \
  X(pwm)                               \
  X(enable_out)                        \
  X(bad_frames)                        \
  X(underruns)                         \
  X(slew_limits)                       \
  X(refused)                           \
  X(last_sequence)                     \
  X(capturing)                         \
  X(writing)                           \
  X(telemetry_pending)                 \
  X(identify_pending)                  \
  X(capture)                           \
  X(written)                           \
  X(word_index)                        \
  X(tx_state)                          \
  X(tx_length)                         \
  X(is_identify)                       \
  X(telemetry_sequence)                \
  X(tx_sequence)                       \
  X(tx_last_load)                      \
  X(uart_free)                         \
  X(identify_sequence)

// The first register in which a and b differ (nullptr: none).
const char* ModelBoard::differing_register(const State& a, const State& b) {
#define DELTA_COMPARE(name) \
  if (!(a.name == b.name)) return #name;
  DELTA_MODEL_BOARD_REGISTERS(DELTA_COMPARE)
#undef DELTA_COMPARE
  if (a.fetched && a.ring_data != b.ring_data) return "ring_data";
  return nullptr;
}

std::uint64_t ModelBoard::skip(std::uint64_t limit, int encoder_a, int encoder_b, DrivePattern* pattern) {
  if (!check_runs_ || checking_) return skip_run(limit, encoder_a, encoder_b, pattern);
  // The run check: the same clocks again, one full clock each, from the same state.
  const State before = *state_;
  const Memories memories_before = *memories_;
  const auto rx_line_before = rx_line_;
  const auto tx_line_before = tx_line_;
  const std::uint64_t taken = skip_run(limit, encoder_a, encoder_b, pattern);
  if (taken == 0) return 0;
  const State after = *state_;
  const Memories memories_after = *memories_;
  const auto rx_line_after = rx_line_;
  const auto tx_line_after = tx_line_;
  const BoardPins pins_after = pins_;
  *state_ = before;
  *memories_ = memories_before;
  rx_line_ = rx_line_before;
  tx_line_ = tx_line_before;
  checking_ = true;
  auto fail = [&](const std::string& what) {
    checking_ = false;
    throw std::logic_error("model board: a run of " + std::to_string(taken) + " clocks from cycle " +
                           std::to_string(before.cycle) + " (tick " + std::to_string(before.tick) + ") differs from " +
                           "its full clocks: " + what);
  };
  for (std::uint64_t i = 0; i < taken; ++i) {
    clock(encoder_a, encoder_b);
    const DrivePins shown = pattern->pins(i, 1 << board::kPwmBits);
    if (shown.pwm != pins_.drive_pwm || shown.enable != pins_.drive_enable ||
        (shown.enable && shown.direction != pins_.drive_dir)) {
      fail("the drive pins in clock " + std::to_string(i));
    }
  }
  checking_ = false;
  if (const char* name = differing_register(*state_, after)) fail(std::string("register ") + name);
  if (memories_->ring != memories_after.ring || memories_->ram != memories_after.ram ||
      memories_->words != memories_after.words || memories_->model != memories_after.model) {
    fail("a block RAM");
  }
  if (tx_line_.size() != tx_line_after.size() || rx_line_.size() != rx_line_after.size()) fail("a serial line");
  if (pins_.drive_pwm != pins_after.drive_pwm || pins_.drive_dir != pins_after.drive_dir ||
      pins_.drive_enable != pins_after.drive_enable) {
    fail("the pins after the run");
  }
  return taken;
}

std::uint64_t ModelBoard::skip_run(std::uint64_t limit, int encoder_a, int encoder_b, DrivePattern* pattern) {
  State& s = *state_;
  pattern->phase = s.pwm_phase;
  for (int j = 0; j < kJoints; ++j) pattern->duty[j] = s.duty[j];
  pattern->direction = s.direction;
  pattern->enable = drives_on(s);
  std::uint64_t taken = 0;
  while (taken < limit) {
    if (quiet()) {
      taken += quiet_run(limit - taken, encoder_a, encoder_b);
    } else {
      // A clock that sets new duties shows the new directions and the old duties: a run of its own.
      const bool new_duty =
          s.running && (s.cycle - s.run_start == duty_cycle(0) || s.cycle - s.run_start == duty_cycle(1) ||
                        s.cycle - s.run_start == duty_cycle(2));
      if (new_duty && taken != 0) break;
      if (!micro_clock(encoder_a, encoder_b, limit - taken)) break;
      ++taken;
      if (new_duty) {
        pattern->direction = s.direction;
        break;
      }
    }
  }
  pins_.drive_pwm = s.pwm;
  pins_.drive_dir = direction_pins(s);
  pins_.drive_enable = s.enable_out;
  pins_.stage_sync = stage_sync(s.period_count);
  return taken;
}

// A run of quiet clocks (quiet() holds for the first), up to `limit`: to the next clock that is not.
std::uint64_t ModelBoard::quiet_run(std::uint64_t limit, int encoder_a, int encoder_b) {
  State& s = *state_;
  // Up to the next clock that is not quiet: the period's next event, a UART bit's end, the
  // controller's next store.
  std::uint64_t clocks = limit;
  // (A snapshot only in phase 0, the controllers' reset only with the drives off; tick 0 next.)
  for (int event : {kPlayTick, s.phase == 0 ? kSnapshotTick : 0, kUpdateTick, s.enabled ? kClocksPerPeriod : kLastTick,
                    kClocksPerPeriod}) {
    if (event > s.tick) {
      clocks = std::min<std::uint64_t>(clocks, static_cast<std::uint64_t>(event - s.tick));
      break;
    }
  }
  // uart_rx: up to the clock that hands link_rx the line's next byte; uart_tx: up to the clock its
  // last bit ends (link_tx sees it ready in the next) and the clock the line completes its byte.
  const bool rx_byte = !rx_line_.empty();
  if (rx_byte) clocks = std::min(clocks, rx_line_.front().valid_cycle - s.cycle + 1);
  if (s.tx_state != kTxIdle) clocks = std::min(clocks, s.tx_last_load - s.cycle + 1);

  if (s.running) {
    const std::uint64_t elapsed = s.cycle - s.run_start;
    for (std::uint64_t event : {duty_cycle(0), duty_cycle(1), duty_cycle(2)}) {
      if (event > elapsed) {
        clocks = std::min(clocks, event - elapsed);
        break;
      }
    }
  }

  if (s.busy) {
    const int next_step = s.step < kDeltaStep ? kDeltaStep : kReferenceStep;
    clocks = std::min<std::uint64_t>(clocks, static_cast<std::uint64_t>(next_step - s.step));
  }

  if (!s.settled) settle();
  // The synchronisers take the held encoder lines in three clocks, counting as they go; a clock
  // that meets a skipped state ends the run (the next one latches the error).
  for (std::uint64_t counted = 0; counted < clocks && !encoders_settled(s, encoder_a, encoder_b);) {
    if (counted != 0 && switch_edge(s) != 0) {  // a home switch's edge: the next clock is a full one
      clocks = counted;
      break;
    }
    ++counted;
    if (count_encoders(s, encoder_a, encoder_b)) clocks = counted;
  }

  const bool enabled = drives_on(s);
  const int period = 1 << board::kPwmBits;
  const int last_phase = static_cast<int>((static_cast<std::uint64_t>(s.pwm_phase) + clocks - 1) % period);
  int pwm = 0;
  for (int j = 0; j < kJoints; ++j) {
    if (enabled && last_phase < s.duty[j]) pwm |= 1 << j;
  }
  if (rx_byte && rx_line_.front().valid_cycle == s.cycle + clocks - 1) {  // the run's last clock
    s.rx_valid = true;
    s.rx_shift = rx_line_.front().byte;
    rx_line_.pop_front();
  }
  if (s.tx_state != kTxIdle && s.tx_last_load == s.cycle + clocks - 1) s.tx_state = kTxIdle;  // its last byte loaded
  s.pwm = pwm;
  s.enable_out = enabled;
  s.pwm_phase = (last_phase + 1) % period;
  if (s.busy) s.step += static_cast<int>(clocks);
  s.tick += static_cast<int>(clocks);
  if (s.tick == kClocksPerPeriod) s.tick = 0;  // (a run ends before tick 0 at the latest)
  s.cycle += clocks;
  return clocks;
}

// The values a micro clock reads before it writes (plan_micro_clock), then commits (micro_clock).
struct ModelBoard::MicroClock {
  bool update = false, whole_update = false, period_start = false, ap_idle = false;
  std::array<std::uint16_t, 3> counts{};
  int following = 0, outside = 0;
  bool checked = false;
  // link_rx
  bool ring_write = false, whole_byte = false, fetched = false, was_fetched = false;
  std::uint8_t ring_byte = 0, rx_byte = 0;
  int old_index = 0, old_read = 0, old_write = 0;
  // interpolator
  bool interpolating = false, take_answer = false, slew_limited = false;
  int j_interpolated = 0, old_step = 0;
  std::int32_t delta = 0, r = 0, d = 0;
  std::int16_t shift = 0;
  // joint controller, telemetry capture
  std::uint64_t elapsed = 0;
  bool capturing = false, writing = false;
  std::uint16_t word = 0;
};

// One clock that is not quiet but whose work is one of the frequent kinds below, none of them
// touching what another reads in the same clock: exactly the full clock's next values, without
// evaluating the rest. False (nothing done) for any other clock: the period's start (tick 0, 1)
// and a snapshot, a frame's end or a dropped frame, a command, a fault, the safety check, a
// skipped encoder state, the drives going off.
//   link_rx: a byte into the ring, a fetch, a header or payload byte, the ring's read;
//   link_tx: a byte to uart_tx (its header, payload, CRC), the wait after it;
//   telemetry: the capture of a word and its write;
//   interpolator: a joint's segment change (step 4) and reference (step 7), the update's start;
//   controller: the load's end, a joint's current stored, its PWM duty, the run's end.
bool ModelBoard::micro_clock(int encoder_a, int encoder_b, std::uint64_t lines_hold) {
  MicroClock c;
  if (!plan_micro_clock(encoder_a, encoder_b, lines_hold, c)) return false;
  State& s = *state_;

  // The registers that follow the present state every clock (RAM reads before this clock's writes).
  if (!s.settled) settle();
  count_clock(encoder_a, encoder_b);  // the counters, the drive pins (of the present duties)
  // What settle() follows changes below: the TX RAM read's address or word, the capture's word,
  // a stored current (the peek), a reference (the safety pipeline).
  bool stored = false;
  for (int j = 0; j < kJoints; ++j) stored |= c.elapsed == duty_cycle(j);
  if (c.writing || c.capturing || stored || (c.interpolating && c.old_step == kReferenceStep) || c.period_start) {
    s.settled = false;
  }

  // schedule, controller start request, watchdog count, safety check; the played setpoint taken
  if (c.period_start) {
    s.phase = next_phase(s.phase);
    s.period_count = s.period_count + 1;
    if (c.ap_idle) {
      s.start_q = true;
      s.counts_q = c.counts;
    }
    if (s.enabled && s.silent_periods != kWatchdogMax) ++s.silent_periods;
    s.check = c.ap_idle;
  }
  if (c.checked) {
    s.active = c.following != 0 || c.outside != 0;
    s.checked = false;
  }
  s.starting = false;

  micro_link_rx(c);
  micro_interpolator(c);

  // joint controller: a current stored with its PWM duty (the third ends the run)
  if (c.elapsed != 0) store_current(s, c.elapsed);
  jog_duties(s, s);  // (a jog's duties, held: the same values)

  // telemetry capture (the capture's word read before count_clock moved what it reads)
  telemetry_capture_next(s, s, c.word, false, false);
  return true;
}

// Whether the next clock is a micro clock (micro_clock) and, if so, the present values it reads
// in c (before any of them is written).
bool ModelBoard::plan_micro_clock(int encoder_a, int encoder_b, std::uint64_t lines_hold, MicroClock& c) const {
  const State& s = *state_;
  const bool fault = faulted(s);
  // (the safety inputs: a change in the synchroniser, a stop-level sample or a jog's count at tick 0)
  const bool sampled_at_stop = s.history != decltype(s.history){};  // (the samples kept shift at tick 0)
  if (!safety_settled() || (s.tick == 0 && (s.jog || s.safety != 0 || sampled_at_stop))) return false;
  if (s.jog != s.jog_tail || (s.jog && !jog_duties_held(s))) return false;
  if (s.step_error[0] || s.step_error[1] || s.step_error[2] || s.slew_limited || s.check || switch_edge(s) != 0 ||
      s.load_shift != 0 || (fault && (s.enabled || s.holding || s.homing || s.jog)) ||
      (s.answered && (!s.enabled || fault)) || (!s.enabled && s.silent_periods != 0) ||
      (s.enabled && s.silent_periods > board::kWatchdogPeriods) ||
      (s.tx_state == kTxIdle && (s.telemetry_pending || s.identify_pending))) {
    return false;
  }
  const int tick = s.tick;
  if (tick == kPlayTick || (tick == kSnapshotTick && s.phase == 0) || (tick == kUpdateTick && s.busy) ||
      (tick == kLastTick && !s.enabled)) {
    return false;
  }
  c.update = tick == kUpdateTick;
  // The whole update in its first clock, all three joints (the reference the controllers and the
  // safety check see next period, the slew-limit count telemetry reports next millisecond: the
  // same), where nothing can turn the drives off before it ends: the drives on, link_rx idle with
  // no byte for it before then, the encoder lines held and settled (no skipped state, no fault).
  // Not under the run check, which compares the RTL's register trace clock by clock.
  constexpr std::uint64_t kQuietAfter = kUpdateClocks + kWholeUpdateSlack;
  c.whole_update = c.update && !check_runs_ && s.enabled && !fault && lines_hold > kQuietAfter && !s.rx_valid &&
                   !s.fetched && s.read == s.write &&
                   (rx_line_.empty() || rx_line_.front().valid_cycle > s.cycle + kQuietAfter) &&
                   encoders_settled(s, encoder_a, encoder_b);

  // ---- the period's start (tick 0) and the safety check (a fault latching: the full clock) ----
  c.period_start = tick == 0;
  c.ap_idle = !s.running;
  c.counts = s.count;
  if (s.checked) {
    safety_conditions(s, &c.following, &c.outside);
    if (s.enabled && (c.following != 0 || c.outside != 0)) return false;
  }
  c.checked = s.checked;

  // ---- link_rx (a frame's end or a dropped frame: the full clock) ----
  // A byte into an idle ring is fetched and processed two clocks later, by link_rx alone: the
  // model takes the three clocks in the first (nothing else reads link_rx's registers; the window
  // keeps clear of tick 1, whose play moves the setpoint buffer's write address), unless the byte
  // ends or drops a frame, and not under the run check.
  c.ring_write = s.rx_valid;
  c.whole_byte = c.ring_write && !s.fetched && s.read == s.write && !check_runs_ && tick > kPlayTick &&
                 tick < kClocksPerPeriod - (kWholeByteClocks - 1) && !rx_byte_ends_frame(s, s.rx_shift);
  const std::uint8_t processed = c.whole_byte ? s.rx_shift : s.ring_data;
  if (!s.fetched && !c.whole_byte) {
    c.fetched = s.read != s.write;
  } else if (rx_byte_ends_frame(s, processed)) {
    return false;  // a frame's end or a dropped frame: the full clock
  }

  // ---- interpolator ----
  c.interpolating = s.busy && (s.step == kDeltaStep || s.step == kReferenceStep);
  const bool interpolator_enabled = s.enabled && !fault;
  c.take_answer = s.answer_pending && s.phase == 0;
  c.j_interpolated = s.joint;
  c.delta = s.delta;
  if (c.interpolating && s.step == kDeltaStep) {
    const int j = s.joint;
    bool saturated = false;
    c.delta = segment_delta(s.net_outputs[j], s.r[j], play_as_of(s, j, s.cycle - 2), c.take_answer, s.d[j], &saturated);
    c.slew_limited = c.take_answer && saturated && interpolator_enabled;
  } else if (c.interpolating) {
    reference_next(s, s.joint, interpolator_enabled, &c.r, &c.d, &c.shift);
  }

  // ---- joint controller ----
  if (s.running) c.elapsed = s.cycle - s.run_start;

  // ---- telemetry capture, link_tx ----
  c.capturing = s.capturing;
  c.writing = s.writing;
  c.word = c.writing ? telemetry_word_of(s) : std::uint16_t{0};

  // The present values the work writes over.
  c.was_fetched = s.fetched || c.whole_byte;
  c.ring_byte = processed;
  c.rx_byte = s.rx_shift;
  c.old_index = s.index;
  c.old_read = s.read;
  c.old_write = s.write;
  c.old_step = s.step;
  return true;
}

// The micro clock's link_rx: the ring's read (before this clock's write), the byte in, the byte
// processed (its command byte, setpoint index byte or position byte).
void ModelBoard::micro_link_rx(const MicroClock& c) {
  State& s = *state_;
  Memories& m = *memories_;
  s.ring_data = c.whole_byte ? c.ring_byte : m.ring[c.old_read];
  if (c.ring_write) {
    m.ring[c.old_write] = c.rx_byte;
    s.write = (c.old_write + 1) % kRingBytes;
  }
  s.fetched = c.fetched;
  if (c.was_fetched) {
    const RxProcessed rx = process_rx_byte(s, c.ring_byte, s);
    const int payload_index = (c.old_index - kHeaderBytes) & kFrameIndexMask;
    if (rx.payload_valid && s.type == board::kFrameTypeCommand) s.command = c.ring_byte;
    setpoint_payload_next(s, s, rx.frame_start, rx.payload_valid, payload_index, c.ring_byte);
    model_payload_next(s, s, rx.payload_valid, payload_index, c.ring_byte);
  }
}

// The micro clock's interpolator: a joint's step 4 or 7, the whole update, or the update's start.
void ModelBoard::micro_interpolator(const MicroClock& c) {
  State& s = *state_;
  if (c.interpolating && c.old_step == kDeltaStep) {
    s.delta = c.delta;
    s.slew_limited = c.slew_limited;
  } else if (c.interpolating) {
    const int j = c.j_interpolated;
    s.r[j] = c.r;
    s.d[j] = c.d;
    s.shift[j] = c.shift;
    s.step = 0;
    s.joint = j + 1;
    if (j == kJoints - 1) {
      s.busy = false;
      if (c.take_answer) s.answer_pending = false;
    }
  }
  if (c.whole_update) {
    const bool take = s.answer_pending && s.phase == 0;
    for (int j = 0; j < kJoints; ++j) {
      bool saturated = false;
      // (joint j's step 4 and 7 come 8 j + 5 and 8 j + 8 clocks after this one)
      const std::uint64_t step4 = s.cycle + static_cast<std::uint64_t>(kStepsPerJoint * j + kDeltaStep + 1);
      const std::uint64_t step7 = s.cycle + static_cast<std::uint64_t>(kStepsPerJoint * j + kReferenceStep + 1);
      s.delta = segment_delta(s.net_outputs[j], s.r[j], play_as_of(s, j, step4 - 2), take, s.d[j], &saturated);
      if (take && saturated) s.slew_limits = saturating_increment(s.slew_limits);
      const std::int64_t step = reference_step(s.delta, s.phase);
      s.shift[j] = reference_shift(s, j, play_as_of(s, j, step7 - 1), play_as_of(s, j, step7 - 2));
      s.r[j] = static_cast<std::int32_t>(static_cast<std::uint32_t>(s.r[j]) + static_cast<std::uint32_t>(step));
      s.d[j] = (s.phase == kLastPhase && !s.homing) ? 0 : s.delta;
    }
    if (take) s.answer_pending = false;
    s.busy = false;
    s.step = 0;
    s.joint = kJoints;
    s.settled = false;
  } else if (c.update) {
    s.busy = true;
    s.step = 0;
    s.joint = 0;
  }
}

// Most clocks change only counters: the UARTs counting out a bit, the PWM phase, the tick, the
// encoder synchronisers. Such a clock is skip()'s run of one, in place, with exactly the next
// values the full clock below would compute; any clock where something else could change (a byte,
// a frame, a command, the period's events, the controller's stores, a capture, an encoder error, a
// fault turning the drives off) returns false untouched and goes the full way.
bool ModelBoard::quiet_clock(int encoder_a, int encoder_b) {
  DrivePattern pattern;
  return skip(1, encoder_a, encoder_b, &pattern) == 1;
}

void ModelBoard::receive(const std::uint8_t* data, std::size_t size) {
  for (std::size_t i = 0; i < size; ++i) {
    // The start bit's first clock: now, or when the line has sent the byte before.
    const std::uint64_t start = std::max(state_->cycle, line_free_cycle_);
    line_free_cycle_ = start + kLineByteClocks;
    rx_line_.push_back({start + kRxValidDelay, data[i]});
    line_end_.push_back(line_free_cycle_);
  }
}

std::size_t ModelBoard::bytes_on_line() {
  while (!line_end_.empty() && line_end_.front() <= state_->cycle) line_end_.pop_front();
  return line_end_.size();
}

std::uint64_t ModelBoard::tx_byte_cycle(std::size_t k) const {
  return k < tx_line_.size() ? tx_line_[k].cycle : ~std::uint64_t{0};
}

bool ModelBoard::take_tx_byte(std::uint8_t* byte) {
  if (tx_line_.empty() || tx_line_.front().cycle >= state_->cycle) return false;
  *byte = tx_line_.front().byte;
  tx_line_.pop_front();
  return true;
}

// The telemetry word the capture writes in this clock (word_index, one clock behind the capture):
// board_core.sv's telemetry mux over the status registers and the peeked controller state.
std::uint16_t ModelBoard::telemetry_word_of(const State& s) {
  const int reference_word = static_cast<int>(board::kTelemetryReferencesOffset / 2);
  const int count_word = static_cast<int>(board::kTelemetryCountsOffset / 2);
  const int current_word = static_cast<int>(board::kTelemetryCurrentsOffset / 2);
  const bool fault = faulted(s);
  int flags = 0;
  if (drives_on(s)) flags |= 1 << board::kFlagDriveEnable;
  if (s.homed) flags |= 1 << board::kFlagHomed;
  if (s.holding) flags |= 1 << board::kFlagHolding;
  if (fault) flags |= 1 << board::kFlagFault;
  if (s.encoder_error != 0) flags |= 1 << board::kFlagEncoderError;
  if (s.referenced == kAllJoints) flags |= 1 << board::kFlagReferenced;
  if (s.homing) flags |= 1 << board::kFlagHoming;
  if (s.loaded) flags |= 1 << board::kFlagModel;
  const int w = s.word_index;
  if (w == board::kTelemetrySampleIndexOffset / 2)
    return s.sample_index & 0xFFFF;
  else if (w == board::kTelemetrySampleIndexOffset / 2 + 1)
    return s.sample_index >> 16;
  else if (w == board::kTelemetryTickOffset / 2)
    return s.period_count & 0xFFFF;
  else if (w == board::kTelemetryTickOffset / 2 + 1)
    return s.period_count >> 16;
  else if (w == board::kTelemetryFaultOffset / 2)
    return static_cast<std::uint16_t>((flags << 8) | ((s.estop ? 1 : 0) << board::kTelemetryEstopBit) |
                                      (rising_bits(s) << board::kTelemetryPlaySideShift) | s.fault_cause);
  else if (w == board::kTelemetryFillOffset / 2)
    return static_cast<std::uint16_t>(s.fill);
  else if (w == board::kTelemetryBadFramesOffset / 2)
    return s.bad_frames;
  else if (w == board::kTelemetryUnderrunsOffset / 2)
    return s.underruns;
  else if (w == board::kTelemetrySaturationsOffset / 2)
    return s.overflow;
  else if (w == board::kTelemetrySlewLimitsOffset / 2)
    return s.slew_limits;
  else if (w == board::kTelemetryRejectedOffset / 2)
    return static_cast<std::uint16_t>((s.board_cause << board::kBoardFaultShift) | s.refused);
  else if (w == board::kTelemetrySequenceOffset / 2)
    return static_cast<std::uint16_t>((((s.jog ? 1 : 0) << board::kTelemetryJogBit) | (s.referenced << kJoints) |
                                       ((s.enc_a >> kHomeSwitchShift) & kAllJoints))
                                          << 8 |
                                      s.last_sequence);
  else if (s.jog && w >= current_word && w < current_word + kJoints)
    return jog_current(s, w - current_word);  // a bench jog: the current it applies
  else if (w >= reference_word && w < count_word && (w & 1) != (reference_word & 1))
    return s.peek_data >> 16;
  else
    return s.peek_data & 0xFFFF;
}

// link_tx and uart_tx a frame at a time: link_tx starts a frame in clock `start` (n: its header
// fields set) and hands uart_tx byte k (sync, length, sequence, type, the payload's words low byte
// first from its RAM, the CRC high byte first) in the clock kTxByteClocks k after the first, which
// waits for the UART's last byte; the TX line completes each kTxByteDelay later. The words it
// reads hold still while it sends (a capture waits for a telemetry frame to end; an identify
// frame reads words no capture writes).
void ModelBoard::start_frame(State& n, std::uint64_t start) {
  const Memories& m = *memories_;
  link::Frame frame;  // the link's frame layout (link::encode_frame), the words as link_tx reads them
  frame.sequence = n.tx_sequence;
  frame.type = n.is_identify ? link::FrameType::kIdentify : link::FrameType::kTelemetry;
  frame.payload.resize(static_cast<std::size_t>(n.tx_length));
  constexpr int kCrcWord = static_cast<int>(board::kIdentifyWeightsCrcOffset / 2);
  for (int p = 0; p < n.tx_length; ++p) {
    const int w = p >> 1;
    std::uint16_t word = m.words[((n.is_identify ? 0 : kTelemetryWordBase) + w) & kTxWordMask];
    // identify's weights CRC: the loaded model's (0: none), not identify.mem's
    if (n.is_identify && (w == kCrcWord || w == kCrcWord + 1)) {
      word = static_cast<std::uint16_t>(identify_crc(n) >> (w == kCrcWord ? 0 : 16));
    }
    frame.payload[static_cast<std::size_t>(p)] = static_cast<std::uint8_t>((p & 1) ? word >> 8 : word & 0xFF);
  }
  const std::vector<std::uint8_t> bytes = link::encode_frame(frame);
  const std::uint64_t first = std::max(start + 1, n.uart_free);
  if (n.is_identify) {
    identify_frame_ = bytes;
    identify_first_load_ = first;
  }
  for (std::size_t k = 0; k < bytes.size(); ++k)
    tx_line_.push_back({first + kTxByteClocks * k + kTxByteDelay, bytes[k]});
  n.tx_last_load = first + kTxByteClocks * (bytes.size() - 1);
  n.uart_free = n.tx_last_load + kTxByteClocks;
}

// identify's CRC changed in clock s.cycle (a commit or a load's start) while link_tx sends an
// identify reply: the CRC bytes it hands uart_tx from the next clock on are the new CRC's, and the
// frame's CRC-16 (sent last) follows (link_tx.sv reads weights_crc_i as each byte goes out).
void ModelBoard::patch_identify_crc(const State& s, const State& n) {
  if (s.tx_state == kTxIdle || !s.is_identify || identify_frame_.empty()) return;
  const std::size_t crc_byte = board::kFrameHeaderBytes + board::kIdentifyWeightsCrcOffset;
  const std::uint32_t crc = identify_crc(n);
  auto load_cycle = [this](std::size_t k) { return identify_first_load_ + kTxByteClocks * k; };
  std::vector<std::uint8_t> bytes = identify_frame_;
  for (std::size_t i = 0; i < 4; ++i) {
    if (load_cycle(crc_byte + i) > s.cycle) bytes[crc_byte + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  }
  const std::size_t payload_end = board::kFrameHeaderBytes + board::kIdentifyPayloadBytes;
  const std::uint16_t frame_crc = link::crc16(bytes.data() + 1, payload_end - 1);
  bytes[payload_end] = static_cast<std::uint8_t>(frame_crc >> 8);
  bytes[payload_end + 1] = static_cast<std::uint8_t>(frame_crc & 0xFF);
  for (TxByte& b : tx_line_) {
    if (b.cycle < identify_first_load_ + kTxByteDelay) continue;
    const std::uint64_t k = (b.cycle - kTxByteDelay - identify_first_load_) / kTxByteClocks;
    if (k < bytes.size() && b.cycle == load_cycle(k) + kTxByteDelay) b.byte = bytes[k];
  }
  identify_frame_ = bytes;
}

// The counters of one clock (what a quiet run of one does), with the drive pins of the clock.
void ModelBoard::count_clock(int encoder_a, int encoder_b) {
  State& s = *state_;
  if (!encoders_settled(s, encoder_a, encoder_b)) count_encoders(s, encoder_a, encoder_b);
  joint_pwm_next(s, s);
  uart_rx_next(s, s);
  if (s.tx_state != kTxIdle && s.tx_last_load == s.cycle) s.tx_state = kTxIdle;
  if (s.busy) ++s.step;
  s.tick = s.tick == kLastTick ? 0 : s.tick + 1;
  ++s.cycle;
}

// The wires of one full clock between the modules (board_core.sv's nets), each set by the module
// that drives it before the modules that read it.
struct ModelBoard::Wires {
  // link_rx
  RxProcessed rx;
  int payload_index = 0;
  std::uint8_t payload_byte = 0;
  bool is_setpoint = false, is_command = false, is_identify_request = false, is_model = false;
  // the model loader
  bool model_refused = false;
  // joint_axes' fault latch, the commands, the home switches
  bool fault = false, command_ok = false;
  int edge = 0;  // bit j: joint j's home switch references it
  bool flush = false, home = false, home_start = false, clear_fault = false, command_refused = false;
  bool estop = false, jog_start = false;
  // the period schedule
  bool play = false, snapshot = false, update = false;
  // the setpoint buffer
  bool pop = false, underrun = false, setpoint_refused = false;
  // the quadrature counters
  int step_error_bits = 0;
};

void ModelBoard::clock(int encoder_a, int encoder_b) {
  if (!checking_ && quiet_clock(encoder_a, encoder_b)) return;
  const State& s = *state_;
  State& n = *next_state_;  // the next values, committed at the end (the buffers swap)
  n = s;
  n.settled = false;
  Wires w;
  uart_rx_next(s, n);
  link_rx_next(s, n, w);
  commands_next(s, n, w);
  board_inputs_next(s, n, w);
  model_loader_next(s, n, w);
  schedule_next(s, n, w);
  setpoint_buffer_next(s, n, w);
  interpolator_next(s, n, w);
  encoders_next(s, n, encoder_a, encoder_b, w);
  joint_controller_next(s, n);
  joint_safety_next(s, n, w);
  joint_pwm_next(s, n);
  counters_next(s, n, w);
  link_tx_next(s, n, w);
  n.tick = s.tick == kLastTick ? 0 : s.tick + 1;
  n.cycle = s.cycle + 1;
  std::swap(state_, next_state_);

  const State& q = *state_;
  pins_.drive_pwm = q.pwm;
  pins_.drive_dir = direction_pins(q);
  pins_.drive_enable = q.enable_out;
  pins_.encoder_error_bits = q.encoder_error;
  pins_.joint_limited = q.overflow != 0;
  pins_.fault_cause_bits = q.fault_cause;
  pins_.board_fault_bits = q.board_cause;
  pins_.estop_latched = q.estop;
  pins_.stage_sync = stage_sync(q.period_count);
}

// ---- uart_rx (the line's bytes at their clocks: ModelBoard::receive); n may be s ----
void ModelBoard::uart_rx_next(const State& s, State& n) {
  const std::uint64_t cycle = s.cycle;
  n.rx_valid = false;
  if (!rx_line_.empty() && rx_line_.front().valid_cycle == cycle) {
    n.rx_valid = true;
    n.rx_shift = rx_line_.front().byte;
    rx_line_.pop_front();
  }
}

// ---- link_rx ----
void ModelBoard::link_rx_next(const State& s, State& n, Wires& w) {
  Memories& m = *memories_;
  n.fetched = false;
  if (s.load_shift != 0) {
    n.fetched = s.fetched;  // the loader's CRC runs: the parser holds (the ring keeps receiving)
  } else if (!s.fetched) {
    n.fetched = s.read != s.write;
  } else {
    w.rx = process_rx_byte(s, s.ring_data, n);
  }
  n.ring_data = m.ring[s.read];  // read before this edge's write (the RTL never reads the slot written)
  if (s.rx_valid) {
    m.ring[s.write] = s.rx_shift;
    n.write = (s.write + 1) % kRingBytes;
  }
  w.payload_index = (s.index - kHeaderBytes) & kFrameIndexMask;
  w.payload_byte = s.ring_data;
  w.is_setpoint = s.type == board::kFrameTypeSetpoint;
  w.is_command = s.type == board::kFrameTypeCommand;
  w.is_identify_request = s.type == board::kFrameTypeIdentifyRequest;
  w.is_model = s.type == board::kFrameTypeModel;
}

// ---- joint_axes: fault, commands (board_core.sv's commands and home switches) ----
void ModelBoard::commands_next(const State& s, State& n, Wires& w) {
  w.fault = faulted(s);
  w.command_ok = w.rx.frame_ok && w.is_command;
  w.edge = switch_edge(s);
  w.flush = (w.fault && s.enabled) || w.edge != 0;
  const int jog_command = static_cast<int>(s.command) - static_cast<int>(board::kCommandJogBase);
  if (w.command_ok && jog_command >= 0 && jog_command < kJogCommands) {
    // A bench jog: only with the drives off, no cause latched, not homing (homed or not, model or not).
    w.command_refused = s.enabled || s.jog || w.fault || s.homing;
    w.jog_start = !w.command_refused;
  } else if (w.command_ok) {
    switch (s.command) {
      case board::kCommandEnable:
        w.command_refused = w.fault || !s.homed || !s.loaded || (s.enabled && !s.holding) || s.jog;
        break;
      case board::kCommandDisable:
        w.flush = true;
        break;
      case board::kCommandHold:
        w.command_refused = !s.enabled;
        break;
      case board::kCommandClearFault:  // refused while a cause persists (a joint's, a safety input at stop)
        w.command_refused = s.active || input_active(s);
        w.clear_fault = !w.command_refused;
        break;
      case board::kCommandEstop:  // in every state: the e-stop latched (the fault turns the drives off)
        w.estop = true;
        break;
      case board::kCommandSetHome:  // (refused with the drives on: enabled or a jog)
        w.command_refused = s.enabled || s.jog;
        w.home = !w.command_refused;
        break;
      case board::kCommandHomeStart:
        w.command_refused = s.enabled || s.jog;
        w.home_start = !w.command_refused;
        break;
      default:
        w.command_refused = true;
    }
  }
  if (w.rx.payload_valid && w.is_command) n.command = w.payload_byte;
  if (w.command_ok && !w.command_refused) {
    if (s.command == board::kCommandEnable) {
      n.enabled = true;
      n.holding = false;
    }
    if (s.command == board::kCommandDisable) {
      n.enabled = false;
      n.holding = false;
    }
    if (s.command == board::kCommandHold) n.holding = true;
  }
  if (w.home) n.homed = true;
  if (w.home_start) n.homing = true;
  n.referenced = (w.home_start ? 0 : s.referenced) | w.edge;
  if ((!w.home_start && (s.referenced | w.edge) == kAllJoints) || (w.command_ok && s.command == board::kCommandHold)) {
    n.homing = false;
  }
  if (w.fault || w.edge != 0) {
    n.enabled = false;
    n.holding = false;
  }
  if (w.fault) n.homing = false;
  // The bench jog: started by its command, to the JogPeriods-th tick 0 after it (its counter
  // loaded with JogPeriods, counted down at tick 0); a fault (the e-stop's too) or a disable ends it
  // at once.
  n.jog_tail = s.jog;
  if (w.jog_start) {
    n.jog = true;
    n.jog_joint = jog_command / 2;
    n.jog_negative = (jog_command & 1) != 0;
    n.jog_periods = static_cast<int>(board::kJogPeriods);
  } else if (s.jog) {
    if (s.tick == 0) n.jog_periods = s.jog_periods - 1;
    const bool disabled = w.command_ok && s.command == board::kCommandDisable;
    if (w.fault || disabled || (s.tick == 0 && s.jog_periods == 1)) n.jog = false;
  }
}

void ModelBoard::set_safety_inputs(bool estop_open, int drive_fault) {
  safety_in_ =
      (estop_open ? 1 << board::kBoardFaultEstopInput : 0) | ((drive_fault & kAllJoints) << board::kBoardFaultDrive);
}

bool ModelBoard::safety_settled() const { return state_->safety_meta == safety_in_ && state_->safety == safety_in_; }

// ---- the safety inputs and the e-stop command (board_core.sv) ----
// Each input through a two-flip-flop synchroniser, sampled at tick 0 of every control period:
// BoardInputFilterPeriods samples in a row at the stop level latch its cause. The causes and the
// e-stop latch hold until a clear-fault is taken (commands_next: refused while an input samples at
// the stop level).
void ModelBoard::board_inputs_next(const State& s, State& n, const Wires& w) const {
  n.safety_meta = safety_in_;
  n.safety = s.safety_meta;
  int cause = w.clear_fault ? 0 : s.board_cause;
  if (s.tick == 0) {
    for (int i = 0; i < kBoardInputs; ++i) {
      const int stop = (s.safety >> i) & 1;
      n.history[i] = ((s.history[i] << 1) | stop) & kHistoryMask;
      if (stop != 0 && s.history[i] == kHistoryMask) cause |= 1 << i;  // (a latch beats a clear)
    }
  }
  n.board_cause = cause;
  n.estop = (s.estop && !w.clear_fault) || w.estop;
  // (the history and causes as board_safety_inputs.sv's history_q, cause_q; the latch board_core's)
}

// ---- model_loader (docs/board_link.md, "The model") ----
// A model frame's payload byte (tentative: its frame number, low byte then whether the high one is
// zero, then its word, low byte first). n may be s.
void ModelBoard::model_payload_next(const State& s, State& n, bool payload_valid, int payload_index,
                                    std::uint8_t byte) {
  if (!payload_valid || s.type != board::kFrameTypeModel) return;
  const int word_byte = payload_index - static_cast<int>(board::kModelWordOffset);
  if (payload_index == board::kModelFrameOffset) {
    n.load_number = byte;
  } else if (payload_index == board::kModelFrameOffset + 1) {
    n.load_number_high = byte != 0;
  } else if (word_byte >= 0 && word_byte < board::kModelWordBits / 8) {
    const int shift = 8 * word_byte;
    n.load_word = (s.load_word & ~(std::uint64_t{0xFF} << shift)) | (std::uint64_t{byte} << shift);
  }
}

// A model frame taken (its frame_ok): refused with the drives on or out of order; n = 0 starts a
// load (no model from now on), the next frame's word is written into the memories and then shifts
// through the CRC, a bit a clock for ModelCrcClocks clocks (link_rx's parser stalls); the commit
// ends the load, the model loaded if the board's CRC equals the commit's word. identify's CRC
// (the checked one, 0 without a model) changes with a commit or a start: a reply on the TX line
// takes it in the bytes link_tx has not yet handed uart_tx (patch_identify_crc).
void ModelBoard::model_loader_next(const State& s, State& n, Wires& w) {
  model_payload_next(s, n, w.rx.payload_valid, w.payload_index, w.payload_byte);
  if (s.load_shift != 0) {
    const std::uint32_t base = s.load_restart ? ~std::uint32_t{0} : s.load_crc;
    const bool feedback = ((base ^ static_cast<std::uint32_t>(s.load_word)) & 1) != 0;
    n.load_crc = (base >> 1) ^ (feedback ? kCrc32Polynomial : 0);
    n.load_restart = false;
    n.load_word = s.load_word >> 1;
    n.load_shift = s.load_shift - 1;
  }
  if (!(w.rx.frame_ok && w.is_model)) return;
  const bool start = !s.load_number_high && s.load_number == 0;
  const bool take = !s.enabled && !s.jog &&  // refused with the drives on (enabled or a jog)
                    (start || (s.loading && !s.load_number_high && s.load_number == s.load_expected));
  if (!take) {
    w.model_refused = true;
    return;
  }
  if (s.load_number == board::kModelCommitFrame) {
    n.loading = false;
    n.loaded = ~s.load_crc == static_cast<std::uint32_t>(s.load_word);
  } else {
    n.loading = true;
    n.loaded = false;
    n.load_expected = (s.load_number + 1) & 0xFF;
    n.load_shift = static_cast<int>(board::kModelCrcClocks);
    n.load_restart = start;
    const std::size_t address = static_cast<std::size_t>(s.load_number);
    if (address < memories_->model.size()) {
      memories_->model[address] = s.load_word & ((std::uint64_t{1} << board::kModelWordBits) - 1);
      network_stale_ = true;
    }
    if (address >= board::kModelPlayFrame && address < board::kModelPlayFrame + kJoints) {
      const std::size_t j = address - static_cast<std::size_t>(board::kModelPlayFrame);
      n.play_before[j] = s.play[j];
      n.play[j] = s.load_word & ((std::uint64_t{1} << kPlayWordBits) - 1);
      n.play_written[j] = s.cycle;
    }
  }
  if (identify_crc(n) != identify_crc(s)) patch_identify_crc(s, n);
}

// ---- period schedule ----
void ModelBoard::schedule_next(const State& s, State& n, Wires& w) {
  if (s.tick == 0) {
    n.phase = next_phase(s.phase);
    n.period_count = s.period_count + 1;
  }
  w.play = s.tick == kPlayTick && s.phase == 0 && s.enabled && !s.holding && !w.fault;
  w.snapshot = s.tick == kSnapshotTick && s.phase == 0;
  w.update = s.tick == kUpdateTick;
}

// ---- setpoint buffer (and the network on a play) ----
void ModelBoard::setpoint_buffer_next(const State& s, State& n, Wires& w) {
  const Memories& m = *memories_;
  const bool accept = s.enabled && !w.fault;  // setpoints only with the drives on
  const bool commit =
      w.rx.frame_ok && w.is_setpoint && accept && s.index_match && !s.full_at_start && !s.vetoed && !w.flush;
  w.setpoint_refused = w.rx.frame_ok && w.is_setpoint && !commit;
  w.pop = w.play && !s.starting && s.fill != 0;
  w.underrun = w.play && s.fill == 0;
  if (w.flush) {
    n.fill = 0;
  } else if (commit && !w.pop) {
    n.fill = s.fill + 1;
  } else if (w.pop && !commit) {
    n.fill = s.fill - 1;
  }
  if (w.pop) {
    n.sample_index = s.sample_index + 1;
    n.starting = true;
    // The network (golden, bit for bit): its answer arrives long before the update reads it.
    const auto& entry = m.ram[s.sample_index % kDepth];
    std::array<std::int64_t, 3> scaled{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t code = 0;
      for (int b = 0; b < kPositionCodeBytes; ++b) {
        code |= static_cast<std::uint32_t>(entry[kPositionCodeBytes * k + b]) << (8 * b);
      }
      scaled[k] = static_cast<std::int16_t>(code);
    }
    // The network the memories hold (a load wrote them since the last play: rebuilt).
    if (network_stale_) {
      network_ = golden::network_of_model_words({m.model.begin(), m.model.end()});
      network_stale_ = false;
    }
    const golden::RawOutput answer = golden::evaluate_scaled(network_, scaled);
    for (int j = 0; j < kJoints; ++j) {
      n.net_outputs[j] = sign_extend(static_cast<std::uint32_t>(answer.alpha[j]), kNetworkOutputBits);
    }
    n.answer_pending = true;
  } else if (s.starting) {
    n.starting = false;  // the network takes it (ready) long before the next play
  }
  // After the pop's read: a full buffer takes no write, so the slot written is never the one read.
  setpoint_payload_next(s, n, w.rx.frame_start, w.rx.payload_valid, w.payload_index, w.payload_byte);
  if (w.flush) n.vetoed = true;
}

// A frame's start and a setpoint payload byte (its sample index, checked against the next free
// one; a position byte, written unless the buffer was full at the frame's start). n may be s.
void ModelBoard::setpoint_payload_next(const State& s, State& n, bool frame_start, bool payload_valid,
                                       int payload_index, std::uint8_t byte) {
  const bool is_setpoint = s.type == board::kFrameTypeSetpoint;
  const bool full_at_start = s.full_at_start;
  const std::uint32_t next_index = s.sample_index + static_cast<std::uint32_t>(s.fill);
  if (frame_start) {
    n.full_at_start = s.fill == kDepth;
    n.index_match = true;
    n.vetoed = false;
  }
  if (!payload_valid || !is_setpoint) return;
  if (payload_index < kIndexBytes && byte != ((next_index >> (8 * (payload_index & 3))) & 0xFF)) {
    n.index_match = false;
  }
  if (payload_index >= kIndexBytes && !full_at_start) {
    memories_->ram[next_index % kDepth][(payload_index - kIndexBytes) % kPositionBytes] = byte;
  }
}

// ---- reference interpolator ----
void ModelBoard::interpolator_next(const State& s, State& n, const Wires& w) const {
  const bool interpolator_enabled = s.enabled && !w.fault;
  // An answer since the enable: the network's answer to a pop arrives before the next update reads it.
  n.answered = interpolator_enabled && (s.answered || w.pop);
  n.slew_limited = false;
  const bool take_answer = s.answer_pending && s.phase == 0;
  if (w.update && !s.busy) {
    n.busy = true;
    n.step = 0;
    n.joint = 0;
  } else if (s.busy) {
    const int j = s.joint;
    n.step = s.step + 1;
    if (s.step == kDeltaStep) {
      bool saturated = false;
      n.delta = segment_delta(s.net_outputs[j], s.r[j], play_as_of(s, j, s.cycle - 2), take_answer, s.d[j], &saturated);
      if (take_answer && saturated && interpolator_enabled) n.slew_limited = true;
    }
    if (s.step == kReferenceStep) {
      reference_next(s, j, interpolator_enabled, &n.r[j], &n.d[j], &n.shift[j]);
      n.step = 0;
      n.joint = j + 1;
      if (j == kJoints - 1) {
        n.busy = false;
        if (take_answer) n.answer_pending = false;
      }
    }
  }
}

// ---- encoders (synchronisers, quadrature counters) ----
void ModelBoard::encoders_next(const State& s, State& n, int encoder_a, int encoder_b, Wires& w) {
  n.switch_previous = (s.enc_a >> kHomeSwitchShift) & kAllJoints;
  n.enc_a_meta = encoder_a;
  n.enc_a = s.enc_a_meta;
  n.enc_b_meta = encoder_b;
  n.enc_b = s.enc_b_meta;
  for (int j = 0; j < kJoints; ++j) {
    const int ab = (((s.enc_a >> j) & 1) << 1) | ((s.enc_b >> j) & 1);
    const int move = quadrature_move(s.previous[j], ab);
    const bool error = move == kSkippedState;
    const std::uint16_t count = static_cast<std::uint16_t>(s.count[j] + (error ? 0 : move));
    n.previous[j] = ab;
    n.step_error[j] = error;
    if (!error && move != 0) n.rising[j] = move > 0;
    const bool load = (w.home && ((s.referenced >> j) & 1) == 0) || ((w.edge >> j) & 1) != 0;
    n.count[j] = load ? static_cast<std::uint16_t>(board::kHomeCount) : count;
    if (s.step_error[j]) w.step_error_bits |= 1 << j;
  }
  n.encoder_error = s.encoder_error | w.step_error_bits;
}

// ---- joint controller ----
void ModelBoard::joint_controller_next(const State& s, State& n) {
  const bool ap_idle = !s.running;
  if (s.start_q && ap_idle) {
    n.running = true;
    n.start_q = false;  // (the RTL clears it at ap_ready, kLoadCycles later: nothing reads it before)
    n.run_start = s.cycle;
    for (int j = 0; j < kJoints; ++j) {
      golden::JointFixedInput input;
      input.reference = s.r[j];
      input.encoder = static_cast<std::int16_t>(s.counts_q[j]);
      input.shift = s.shift[j];
      if (!s.primed) n.joint_state[j] = golden::fixed_rest_state(input);
      golden::JointFixedStatus status;
      n.next_current[j] = golden::fixed_update(s.coefficients, n.joint_state[j], input, status);
      n.next_overflow[j] = status.overflow_count;
      n.peek_memory[j][kSlotReference] = static_cast<std::uint32_t>(input.reference);
      n.peek_memory[j][kSlotEncoder] = static_cast<std::uint32_t>(static_cast<std::int32_t>(input.encoder));
    }
  }
  if (s.running) store_current(n, s.cycle - s.run_start);  // elapsed 1 .. kRunCycles
  if (s.tick == 0 && ap_idle) {
    n.start_q = true;
    n.counts_q = s.count;
  }
  // Drives off: the controller restarts from rest (a reset in the period's last cycle).
  if (!s.enabled && s.tick == kLastTick) {
    n.running = false;
    n.primed = false;
    n.current = {0, 0, 0};
    n.overflow = 0;
  }
}

// ---- joint_safety ----
void ModelBoard::joint_safety_next(const State& s, State& n, const Wires& w) {
  if (w.rx.frame_ok || !s.enabled) {
    n.silent_periods = 0;
  } else if (s.tick == 0 && s.silent_periods != kWatchdogMax) {
    n.silent_periods = s.silent_periods + 1;
  }
  for (int j = 0; j < kJoints; ++j) safety_registers(s, j, &n.difference_q[j], &n.outside_q[j]);
  int following = 0, outside = 0;
  safety_conditions(s, &following, &outside);
  int cause = w.clear_fault ? 0 : s.fault_cause;
  if (w.step_error_bits != 0) cause |= 1 << board::kFaultEncoderSkip;
  if (s.checked && s.enabled) {
    if (following) cause |= 1 << board::kFaultFollowing;
    if (outside) cause |= 1 << board::kFaultTravel;
  }
  if (s.enabled && s.silent_periods > board::kWatchdogPeriods) cause |= 1 << board::kFaultWatchdog;
  n.fault_cause = cause;
  n.check = s.tick == 0 && !s.running;
  n.checked = s.check;
  if (s.checked) n.active = following != 0 || outside != 0;
}

// ---- joint_pwm (n may be s) ----
void ModelBoard::joint_pwm_next(const State& s, State& n) {
  jog_duties(s, n);  // over the controllers' stores in this clock (joint_controller_next before)
  const bool enabled = drives_on(s);
  const int phase = s.pwm_phase;
  int pwm = 0;
  for (int j = 0; j < kJoints; ++j) {
    if (enabled && phase < s.duty[j]) pwm |= 1 << j;
  }
  n.pwm = pwm;
  n.enable_out = enabled;
  n.pwm_phase = (phase + 1) & ((1 << board::kPwmBits) - 1);
}

// ---- counters ----
void ModelBoard::counters_next(const State& s, State& n, const Wires& w) {
  if (w.rx.frame_bad) n.bad_frames = saturating_increment(s.bad_frames);
  if (w.underrun && !s.homing) n.underruns = saturating_increment(s.underruns);
  if (s.slew_limited) n.slew_limits = saturating_increment(s.slew_limits);
  if (w.command_refused || w.setpoint_refused || w.model_refused) n.refused = saturating_increment(s.refused);
  if (w.rx.frame_ok) n.last_sequence = s.sequence;
}

// ---- telemetry words and link_tx ----
void ModelBoard::link_tx_next(const State& s, State& n, const Wires& w) {
  // peek: the state word asked for in this cycle, one cycle later (the controller is idle then).
  n.peek_data = peek_word(s.peek_memory, s.capture);
  n.word_index = s.capture;
  const bool sending_telemetry = s.tx_state != kTxIdle && !s.is_identify;
  telemetry_capture_next(s, n, telemetry_word_of(s), w.snapshot, sending_telemetry);
  bool start_identify = false, start_telemetry = false;
  if (s.tx_state == kTxIdle) {
    if (s.telemetry_pending) {
      start_telemetry = true;
      n.is_identify = false;
      n.tx_length = static_cast<int>(board::kTelemetryPayloadBytes);
      n.tx_sequence = s.telemetry_sequence;
    } else if (s.identify_pending) {
      start_identify = true;
      n.is_identify = true;
      n.tx_length = static_cast<int>(board::kIdentifyPayloadBytes);
      n.tx_sequence = s.identify_sequence;
    }
    if (start_telemetry || start_identify) {
      n.tx_state = kTxSending;
      start_frame(n, s.cycle);
    }
  } else if (s.cycle == s.tx_last_load) {
    n.tx_state = kTxIdle;  // the frame's last byte goes to uart_tx
  }
  if (w.rx.frame_ok && w.is_identify_request) {
    n.identify_pending = true;
    n.identify_sequence = s.sequence;
  } else if (start_identify) {
    n.identify_pending = false;
  }
  if (start_telemetry) {
    n.telemetry_pending = false;
    n.telemetry_sequence = static_cast<std::uint8_t>(s.telemetry_sequence + 1);
  }
}

// link_tx's snapshot: the word asked for a clock before written to its RAM, the capture's next
// word, the telemetry frame queued after the last; a snapshot starts one unless a capture, a
// queued or a sending telemetry frame is under way (skipped: the host sees the gap). n may be s.
void ModelBoard::telemetry_capture_next(const State& s, State& n, std::uint16_t word, bool snapshot,
                                        bool sending_telemetry) {
  const bool writing = s.writing, capturing = s.capturing, telemetry_pending = s.telemetry_pending;
  const int capture = s.capture, written = s.written;
  if (writing) memories_->words[(kTelemetryWordBase + written) & kTxWordMask] = word;
  n.writing = capturing;
  n.written = capture;
  if (writing && !capturing) n.telemetry_pending = true;
  if (snapshot && !capturing && !writing && !telemetry_pending && !sending_telemetry) {
    n.capturing = true;
    n.capture = 0;
  } else if (capturing) {
    n.capture = (capture + 1) & kCaptureMask;
    if (capture == kTelemetryWords - 1) n.capturing = false;
  }
}

// ---- the test probe (model_board.hpp): the model's registers under the RTL's names, read-only ----

std::uint64_t ModelBoard::cycle() const { return state_->cycle; }

// The RTL's register map, instance by instance: a row per register (name, the model's value).
// house: table
std::vector<ModelBoard::ProbedRegister> ModelBoard::probe_registers(const std::string& instance) const {
  const State& s = *state_;
  std::vector<ProbedRegister> out;
  auto add = [&out](std::string name, std::uint64_t value) { out.push_back({std::move(name), value}); };
  // A signed value as the RTL's `bits` wide register holds it.
  auto bits = [](std::int64_t value, int width) {
    return static_cast<std::uint64_t>(value) & ((std::uint64_t{1} << width) - 1);
  };
  auto indexed = [](const char* name, int k) { return std::string(name) + "[" + std::to_string(k) + "]"; };
  constexpr int kShiftBits = golden::kShiftBits;  // delta_joint_pkg::ShiftBits
  constexpr int kDutyBits = static_cast<int>(board::kPwmBits) + 1;
  if (instance == "board_core") {
    add("command_q", s.command);
    add("enabled_q", s.enabled);
    add("holding_q", s.holding);
    add("homed_q", s.homed);
    add("homing_q", s.homing);
    add("referenced_q", static_cast<std::uint64_t>(s.referenced));
    add("switch_meta_q", static_cast<std::uint64_t>((s.enc_a_meta >> kHomeSwitchShift) & kAllJoints));
    add("switch_q", static_cast<std::uint64_t>((s.enc_a >> kHomeSwitchShift) & kAllJoints));
    add("switch_previous_q", static_cast<std::uint64_t>(s.switch_previous));
    add("encoder_a_meta_q", static_cast<std::uint64_t>(s.enc_a_meta & kAllJoints));
    add("encoder_a_q", static_cast<std::uint64_t>(s.enc_a & kAllJoints));
    add("encoder_b_meta_q", static_cast<std::uint64_t>(s.enc_b_meta & kAllJoints));
    add("encoder_b_q", static_cast<std::uint64_t>(s.enc_b & kAllJoints));
    add("phase_q", static_cast<std::uint64_t>(s.phase));
    add("period_count_q", s.period_count);
    add("bad_frames_q", s.bad_frames);
    add("underruns_q", s.underruns);
    add("slew_limits_q", s.slew_limits);
    add("refused_q", s.refused);
    add("last_sequence_q", s.last_sequence);
    add("word_index_q", static_cast<std::uint64_t>(s.word_index));
    add("estop_q", s.estop);
    add("jog_q", s.jog);
    add("jog_was_q", s.jog_tail);
    add("jog_joint_q", static_cast<std::uint64_t>(s.jog_joint));
    add("jog_negative_q", s.jog_negative);
    add("jog_left_q", static_cast<std::uint64_t>(s.jog_periods));
    for (int j = 0; j < kJoints; ++j) add(indexed("net_outputs", j), bits(s.net_outputs[j], kNetworkOutputBits));
  } else if (instance == "u_uart_rx") {
    add("valid_q", s.rx_valid);
    if (s.rx_valid) add("shift_q", s.rx_shift);
  } else if (instance == "u_link_rx") {
    add("write_q", static_cast<std::uint64_t>(s.write));
    add("read_q", static_cast<std::uint64_t>(s.read));
    add("start_q", static_cast<std::uint64_t>(s.start));
    add("index_q", static_cast<std::uint64_t>(s.index));
    add("end_q", static_cast<std::uint64_t>(s.end));
    add("fetched_q", s.fetched);
    add("crc_high_ok_q", s.crc_high_ok);
    add("length_q", s.length);
    add("type_q", s.type);
    add("sequence_q", s.sequence);
    add("u_crc.crc_q", s.rx_crc);
    if (s.fetched) add("ring_data_q", s.ring_data);
  } else if (instance == "u_setpoints") {
    add("sample_index_q", s.sample_index);
    add("fill_q", static_cast<std::uint64_t>(s.fill));
    add("full_at_start_q", s.full_at_start);
    add("index_match_q", s.index_match);
    add("vetoed_q", s.vetoed);
    add("starting_q", s.starting);
  } else if (instance == "u_interpolator") {
    add("busy_q", s.busy);
    add("step_q", static_cast<std::uint64_t>(s.step));
    add("joint_q", static_cast<std::uint64_t>(s.joint & 3));
    add("answer_pending_q", s.answer_pending);
    add("answered_q", s.answered);
    add("slew_limited_o", s.slew_limited);
    add("delta_q", bits(s.delta, static_cast<int>(board::kSegmentDeltaBits)));
    // r_q and d_q rotate through the update: r_q[i] holds joint (i + joints done) mod 3.
    for (int i = 0; i < kJoints; ++i) {
      const int j = (i + s.joint) % kJoints;
      add(indexed("r_q", i), static_cast<std::uint32_t>(s.r[j]));
      add(indexed("d_q", i), bits(s.d[j], static_cast<int>(board::kSegmentDeltaBits)));
    }
    // The play shift last written for joint j (shift_o at its shift_write_o).
    for (int j = 0; j < kJoints; ++j) add(indexed("shift_o", j), bits(s.shift[j], kShiftBits));
  } else if (instance == "u_joint_axes") {
    add("tick_q", static_cast<std::uint64_t>(s.tick));
    add("start_q", s.start_q);
    add("encoder_error_q", static_cast<std::uint64_t>(s.encoder_error));
    for (int j = 0; j < kJoints; ++j) {
      add(indexed("counts_q", j), s.counts_q[j]);
      const std::string counter = "g_encoder[" + std::to_string(j) + "].u_counter.";
      add(counter + "previous_q", static_cast<std::uint64_t>(s.previous[j]));
      add(counter + "count_q", s.count[j]);
      add(counter + "error_q", s.step_error[j]);
      add(counter + "rising_q", s.rising[j]);
    }
    add("u_safety.silent_periods_q", static_cast<std::uint64_t>(s.silent_periods));
    add("u_safety.check_q", s.check);
    add("u_safety.checked_q", s.checked);
    add("u_safety.fault_cause_q", static_cast<std::uint64_t>(s.fault_cause));
    add("u_safety.active_q", s.active);
    for (int j = 0; j < kJoints; ++j) {
      const std::string check = "u_safety.g_check[" + std::to_string(j) + "].";
      add(check + "difference_q", bits(s.difference_q[j], kDifferenceBits));
      add(check + "outside_q", s.outside_q[j]);
    }
    // joint_pwm counts the period down: pwm_remaining_q = 2^PwmBits - 1 - phase.
    add("u_pwm.pwm_remaining_q", static_cast<std::uint64_t>(((1 << board::kPwmBits) - 1) - s.pwm_phase));
    std::uint64_t duty = 0;
    for (int j = 0; j < kJoints; ++j) duty |= static_cast<std::uint64_t>(s.duty[j]) << (kDutyBits * j);
    add("u_pwm.duty_q", duty);
    add("u_pwm.direction_q", static_cast<std::uint64_t>(s.direction));
    add("u_pwm.pwm_q", static_cast<std::uint64_t>(s.pwm));
    add("u_pwm.enable_q", s.enable_out);
    add("u_pwm.dir_q", static_cast<std::uint64_t>(direction_pins(s)));
    add("u_controller.ap_idle", !s.running);
    add("u_controller.primed_q", s.primed);
    add("u_controller.overflow_q", s.overflow);
    for (int j = 0; j < kJoints; ++j) add(indexed("u_controller.current_q", j), s.current[j]);
    add("peek_data_o", s.peek_data);
  } else if (instance == "u_link_tx") {
    add("capturing_q", s.capturing);
    add("writing_q", s.writing);
    add("telemetry_pending_q", s.telemetry_pending);
    add("capture_q", static_cast<std::uint64_t>(s.capture));
    add("written_q", static_cast<std::uint64_t>(s.written));
    add("identify_pending_q", s.identify_pending);
    add("identify_sequence_q", s.identify_sequence);
    add("telemetry_sequence_q", s.telemetry_sequence);
    add("is_identify_q", s.is_identify);
    add("length_q", static_cast<std::uint64_t>(s.tx_length));
    add("sequence_q", s.tx_sequence);
    add("state_q", static_cast<std::uint64_t>(s.tx_state));  // Idle, or Send (the model folds Fetch into it)
  } else if (instance == "u_safety_inputs") {                // board_safety_inputs.sv
    add("meta_q", static_cast<std::uint64_t>(s.safety_meta));
    add("sync_q", static_cast<std::uint64_t>(s.safety));
    std::uint64_t history = 0;
    const int history_bits = static_cast<int>(board::kBoardInputFilterPeriods - 1);
    for (int i = 0; i < kBoardInputs; ++i) history |= static_cast<std::uint64_t>(s.history[i]) << (history_bits * i);
    add("history_q", history);
    add("cause_q", static_cast<std::uint64_t>(s.board_cause));
  } else if (instance == "u_model_loader") {
    add("word_q", s.load_word);
    add("number_q", static_cast<std::uint64_t>(s.load_number));
    add("number_high_q", s.load_number_high);
    add("expected_q", static_cast<std::uint64_t>(s.load_expected));
    add("loading_q", s.loading);
    add("loaded_q", s.loaded);
    add("crc_q", s.load_crc);
    add("restart_q", s.load_restart);
    add("shift_count_q", static_cast<std::uint64_t>(s.load_shift));
  } else {
    throw std::invalid_argument("model board probe: no instance " + instance);
  }
  return out;
}

std::vector<std::uint64_t> ModelBoard::probe_memory(const std::string& memory) const {
  const Memories& m = *memories_;
  if (memory == "u_link_rx.ring_q") return {m.ring.begin(), m.ring.end()};
  if (memory == "u_link_tx.words") return {m.words.begin(), m.words.end()};
  // The network's memories (delta_network.sv's model port): every word of a load at its frame
  // number in each, in the memory's width (each reads its own frames); 256 words.
  auto model_words = [&m](int width) {
    std::vector<std::uint64_t> out(kModelMemoryWords, 0);
    const std::uint64_t mask = (std::uint64_t{1} << width) - 1;
    for (std::size_t n = 0; n < m.model.size(); ++n) out[n] = m.model[n] & mask;
    return out;
  };
  const golden::Formats formats;
  if (memory == "u_network.u_weight1_ram.words") return model_words(formats.input_weight_bits);
  if (memory == "u_network.u_bias1_ram.words") {
    return model_words(formats.tanh_input_bits +
                       (formats.hidden_accumulator_fraction_bits() - formats.tanh_input_fraction_bits));
  }
  if (memory == "u_network.u_weight2_ram.words") return model_words(formats.output_weight_bits);
  if (memory == "u_network.u_bias2_ram.words") return model_words(static_cast<int>(board::kModelWordBits));
  if (memory == "u_interpolator.play_words") {
    const State& s = *state_;
    return {s.play[0], s.play[1], s.play[2], 0};
  }
  if (memory == "u_setpoints.ram_q") {
    std::vector<std::uint64_t> out;
    for (const auto& entry : m.ram) {
      for (int w = 0; w < kPositionBytes / 2; ++w) out.push_back(entry[2 * w] | (entry[2 * w + 1] << 8));
    }
    return out;
  }
  throw std::invalid_argument("model board probe: no memory " + memory);
}

}  // namespace delta::cosim
