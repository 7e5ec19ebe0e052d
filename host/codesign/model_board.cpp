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
#include "delta/golden/joint_fixed.hpp"
#include "delta/golden/setpoint_interpolation.hpp"
#include "delta/link/frame_codec.hpp"

namespace delta::cosim {
namespace {

constexpr int kClocksPerBit = static_cast<int>(board::kLinkClocksPerBit);
constexpr int kClocksPerPeriod = static_cast<int>(board::kClocksPerPeriod);
constexpr int kRingBytes = static_cast<int>(board::kRxRingBytes);
constexpr int kDepth = static_cast<int>(board::kSetpointDepth);
constexpr int kTelemetryWords = static_cast<int>(board::kTelemetryPayloadBytes / 2);
// joint_safety.sv's silent-period counter saturates at all ones: $clog2(WatchdogPeriods + 2) bits.
constexpr int watchdog_max() {
  int bits = 0;
  while ((1LL << bits) < board::kWatchdogPeriods + 2) ++bits;
  return (1 << bits) - 1;
}
constexpr int kWatchdogMax = watchdog_max();
constexpr int kJointCycles = 355;  // joint_controller.sv: a joint's datapath run
constexpr int kLoadCycles = 6;     // ap_start seen (idle) to ap_ready; the currents stored at 6 + 355 (j + 1)
// The clock (cycles after ap_start was seen) in which joint j's PWM duty is set: the RTL stores
// current_q a clock before, which nothing but joint_pwm reads; the model stores both here.
constexpr std::uint64_t duty_cycle(int j) {
  return static_cast<std::uint64_t>(kLoadCycles + kJointCycles * (j + 1) + 1);
}
constexpr std::uint64_t kRunCycles = duty_cycle(2);  // ap_done (the RTL's, too)
// Registers the model folds where the RTL spends a clock nothing else can see:
//   link_tx's state 1 (a clock for the RAM read after a payload byte): the model's read is settled;
//   the controller's start_q, cleared at ap_ready in the RTL: here when the run starts (nothing
//   reads it while the controller runs); current_q, stored a clock before its duty (above);
//   link_rx's ring read while idle: the fetch that precedes every use of it reads it again.
// The serial line, 8N1 at kClocksPerBit (B) clocks a bit. uart_rx: the start bit's first clock e
// reaches the synchroniser's output at e + 2; it waits B/2 + 1 clocks to the start bit's middle,
// samples the data bits B clocks apart and sets valid in the clock at the stop bit's middle:
// e + 3 + B/2 + 9 B. The line at the TX pin (rtl::UartLine) sees the start bit after the clock
// uart_tx loads the byte and completes the byte B/2 + 9 B clocks later, at the stop bit's middle.
constexpr std::uint64_t kRxValidDelay = 3 + kClocksPerBit / 2 + 9 * kClocksPerBit;
constexpr std::uint64_t kTxByteDelay = kClocksPerBit / 2 + 9 * kClocksPerBit;
// link_tx hands uart_tx a byte in the first clock it finds it ready, which is 10 B + 1 clocks after
// the last: a frame's bytes load that far apart from the first (which waits for the UART's last).
constexpr std::uint64_t kTxByteClocks = 10 * kClocksPerBit + 1;

// board_core's status counters (bad frames, underruns, slew limits, refused): StatusCounterBits wide.
constexpr std::uint16_t kCounterMax = (1u << board::kStatusCounterBits) - 1;
std::uint16_t saturating_increment(std::uint16_t value) { return value == kCounterMax ? value : value + 1; }

// The link CRC-16 register after one more byte (link_crc16.sv; the host's link::crc16).
std::uint16_t crc_byte(std::uint16_t crc, std::uint8_t data) { return link::crc16(&data, 1, crc); }

int payload_size(std::uint8_t type, bool* known) {
  *known = true;
  if (type == board::kFrameTypeIdentifyRequest) return 0;
  if (type == board::kFrameTypeSetpoint) return static_cast<int>(board::kSetpointPayloadBytes);
  if (type == board::kFrameTypeCommand) return static_cast<int>(board::kCommandPayloadBytes);
  *known = false;
  return 0;
}

// What link_rx did with the byte it processed (link_rx.sv's frame parser).
struct RxProcessed {
  bool frame_start = false;    // a known type with its length: the payload follows
  bool payload_valid = false;  // a payload byte (at index - 4)
  bool frame_ok = false;       // the CRC's low byte matched: the frame ends, taken
  bool frame_bad = false;      // dropped (unknown type, wrong length, CRC): rescanned from after its sync
};

// Whether link_rx processing `byte` ends a frame or drops one.
template <typename Registers>
bool rx_byte_ends_frame(const Registers& s, std::uint8_t byte) {
  if (s.index == 3) {
    bool known = false;
    const int size = payload_size(byte, &known);
    return !(known && s.length == size);
  }
  return s.index >= 4 && s.index > s.end;
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
  } else if (index < 4) {
    n.rx_crc = crc_byte(crc, byte);
    n.index = index + 1;
    if (index == 1) n.length = byte;
    if (index == 2) n.sequence = byte;
    if (index == 3) {
      n.type = byte;
      bool known = false;
      const int size = payload_size(byte, &known);
      n.end = (size + 4) & 63;
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

// The home switches ride in bits kHomeSwitchShift.. of the A lines (ModelBoard::clock): board_core's
// synchronisers and previous state. A rising edge while homing with the drives on references its
// joint (switch_edge: a full clock's work, never a quiet one's).
constexpr int kHomeSwitchShift = 3;
template <typename Registers>
int switch_edge(const Registers& s) {
  if (!s.homing || !s.enabled || s.fault_cause != 0) return 0;
  return ((s.enc_a >> kHomeSwitchShift) & 7) & ~s.switch_previous & ~s.referenced & 7;
}

// One quiet clock (no set-home, no switch edge) of the encoder synchronisers and quadrature
// counters, in place. True if a joint skipped a state (its step error is set).
template <typename Registers>
bool count_encoders(Registers& s, int encoder_a, int encoder_b) {
  bool skipped = false;
  s.switch_previous = (s.enc_a >> kHomeSwitchShift) & 7;
  for (int j = 0; j < 3; ++j) {
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
      s.switch_previous != ((encoder_a >> kHomeSwitchShift) & 7)) {
    return false;
  }
  for (int j = 0; j < 3; ++j) {
    if (s.previous[j] != ((((encoder_a >> j) & 1) << 1) | ((encoder_b >> j) & 1))) return false;
  }
  return true;
}

// joint_pwm: joint j's duty and direction from its stored current (Q1.15 A).
template <typename Registers>
void set_duty(Registers& n, int j, std::uint16_t current) {
  const std::int16_t c = static_cast<std::int16_t>(current);
  const int magnitude = c < 0 ? static_cast<std::uint16_t>(-c) : c;
  n.duty[j] = (magnitude >> (14 - board::kPwmBits)) & ((1 << (board::kPwmBits + 1)) - 1);
  n.direction = (n.direction & ~(1 << j)) | ((c < 0 ? 1 : 0) << j);
}

// joint_controller and joint_pwm in the clock `elapsed` cycles after ap_start was seen: joint j's
// current stored with its duty at duty_cycle(j), the run's end with the third (n: the next values,
// whose next_current and overflow are the present ones here).
template <typename Registers>
void store_current(Registers& n, std::uint64_t elapsed) {
  for (int j = 0; j < 3; ++j) {
    if (elapsed == duty_cycle(j)) {
      n.current[j] = static_cast<std::uint16_t>(n.next_current[j]);
      n.peek_memory[j][kSlotCurrent] = static_cast<std::uint32_t>(static_cast<std::int32_t>(n.next_current[j]));
      n.overflow = static_cast<std::uint16_t>(std::min<int>(0xFFFF, n.overflow + n.next_overflow[j]));
      set_duty(n, j, n.current[j]);
    }
  }
  if (elapsed == kRunCycles) {
    n.running = false;
    n.primed = true;
  }
}

// reference_interpolator.sv, step 4: joint j's segment change D, the play taken out of the distance
// from the reference r to its answer (C), saturated; the held D unless a new answer is taken.
std::int32_t segment_delta(std::int32_t answer, std::int32_t r, std::int32_t half_play, bool take, std::int32_t held,
                           bool* saturated) {
  const std::int64_t diff = golden::play(golden::interpolation::reference_counts(answer) - r, half_play);
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
// enable, else the resting shift on the side joint j's count last stepped to (reference_interpolator.sv).
template <typename Registers>
std::int16_t reference_shift(const Registers& s, int j, std::int32_t half_play) {
  if (!s.answered) return golden::interpolation::resting_shift(s.rising[j], half_play);
  return golden::interpolation::play_shift(
      std::int64_t{golden::interpolation::reference_counts(s.net_outputs[j])} - s.r[j], half_play);
}

// Step 7: the reference's change over the period from weight K_phase to K_phase+1 of D.
std::int64_t reference_step(std::int32_t delta, int phase) {
  const int next = phase == 9 ? 10 : phase + 1;
  const std::int64_t weight_now = golden::interpolation::kWeights[phase];
  const std::int64_t weight_next =
      next == 10 ? (std::int64_t{1} << golden::interpolation::kWeightShift) : golden::interpolation::kWeights[next];
  return golden::round_shift(std::int64_t{delta} * weight_next, 14) -
         golden::round_shift(std::int64_t{delta} * weight_now, 14);
}

std::int32_t sign_extend(std::uint32_t value, int bits) {
  const std::uint32_t m = 1u << (bits - 1);
  value &= (bits == 32) ? 0xFFFFFFFFu : ((1u << bits) - 1);
  return static_cast<std::int32_t>((value ^ m) - m);
}

}  // namespace

// The block RAMs: written in place (never read in the cycle that writes the same word), not
// copied with the registers every clock.
struct ModelBoard::Memories {
  std::array<std::uint8_t, board::kRxRingBytes> ring{};                   // link_rx
  std::array<std::array<std::uint8_t, 12>, board::kSetpointDepth> ram{};  // setpoint_buffer
  std::array<std::uint16_t, 256> words{};                                 // link_tx: identify, telemetry
};

struct ModelBoard::State {
  const golden::QuantisedNetwork* network = nullptr;
  control::JointFixedCoefficients coefficients = control::make_fixed_coefficients(control::JointControllerParameters{});
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
  int tick = 0, phase = 9;
  std::uint32_t period_count = 0;
  // setpoint buffer
  std::uint32_t sample_index = 0;
  int fill = 0;
  bool full_at_start = false, index_match = false, vetoed = false, starting = false;
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
  // joint_controller
  bool running = false, primed = false;
  // A quiet clock has recomputed the registers that only follow constant inputs in quiet clocks
  // (link_tx's RAM read, the peek, the safety pipeline): they hold until a full clock.
  bool settled = false;
  std::uint64_t run_start = 0;  // the cycle it saw ap_start
  std::array<control::JointFixedState, 3> joint_state{};
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
  int tx_state = 0, tx_length = 0;  // 0 idle, 2 sending (a frame scheduled on the TX line)
  bool is_identify = false;
  std::uint8_t telemetry_sequence = 0, tx_sequence = 0, identify_sequence = 0;
  std::uint64_t tx_last_load = 0;  // the frame's last byte to uart_tx (link_tx idle from the next clock)
  std::uint64_t uart_free = 0;     // the first clock uart_tx is ready after it
};

ModelBoard::ModelBoard(const golden::QuantisedNetwork& network, const std::string& identify_mem)
    : memories_(std::make_unique<Memories>()),
      state_(std::make_unique<State>()),
      next_state_(std::make_unique<State>()) {
  State& s = *state_;
  network_ = network;
  s.network = &network_;
  half_plays_ = golden::interpolation::half_play_counts(network_.compensation);
  s.count.fill(static_cast<std::uint16_t>(board::kHomeCount));
  std::ifstream in(identify_mem);
  if (!in) throw std::runtime_error("model board: cannot read " + identify_mem);
  std::string line;
  for (int w = 0; w < 256 && std::getline(in, line);) {
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
  for (int j = 0; j < 3; ++j) {
    const std::int32_t reference_count = s.r[j] >> 8;
    const std::int32_t reference17 = sign_extend(static_cast<std::uint32_t>(reference_count), 17);
    s.difference_q[j] =
        sign_extend(static_cast<std::uint32_t>(reference17 - static_cast<std::int16_t>(s.counts_q[j])), 17);
    const std::int32_t block = sign_extend(static_cast<std::uint32_t>(reference_count), 24) >> 10;
    s.outside_q[j] = block < board::kMinTravelBlock || block > board::kMaxTravelBlock;
  }
  s.settled = true;
}

// Whether the next clock is quiet (see quiet_clock), whatever the encoder lines show.
bool ModelBoard::quiet() const {
  const State& s = *state_;
  const int tick = s.tick;
  if (tick == 0 || tick == 1 || (tick == kClocksPerPeriod / 2 && s.phase == 0) || tick == kClocksPerPeriod - 100 ||
      (tick == kClocksPerPeriod - 1 && !s.enabled)) {
    return false;
  }
  // uart_rx: no byte for link_rx (a byte's valid is set at the end of a run, see skip).
  if (s.rx_valid) return false;
  // link_rx idle and settled; nothing pending in the setpoint buffer, interpolator or safety.
  if (s.fetched || s.read != s.write) return false;
  // The interpolator acts in steps 4 (the segment's change) and 7 (the reference) of each joint;
  // the steps between only count.
  const bool interpolating = s.busy && (s.step == 4 || s.step == 7);
  if (s.starting || interpolating || s.slew_limited || s.check || s.checked) return false;
  if (s.step_error[0] || s.step_error[1] || s.step_error[2]) return false;
  if (switch_edge(s) != 0) return false;
  const bool fault = s.fault_cause != 0;
  if (fault && (s.enabled || s.holding)) return false;
  if (s.answered && (!s.enabled || fault)) return false;  // the interpolator forgets the answer
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
  if (s.tx_state == 0 && (s.telemetry_pending || s.identify_pending)) return false;
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
  const ModelBoardPins pins_after = pins_;
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
      memories_->words != memories_after.words) {
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
  for (int j = 0; j < 3; ++j) pattern->duty[j] = s.duty[j];
  pattern->direction = s.direction;
  pattern->enable = s.enabled && s.fault_cause == 0;
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
  pins_.drive_dir = s.direction;
  pins_.drive_enable = s.enable_out;
  return taken;
}

// A run of quiet clocks (quiet() holds for the first), up to `limit`: to the next clock that is not.
std::uint64_t ModelBoard::quiet_run(std::uint64_t limit, int encoder_a, int encoder_b) {
  State& s = *state_;
  // Up to the next clock that is not quiet: the period's next event, a UART bit's end, the
  // controller's next store.
  std::uint64_t clocks = limit;
  // (A snapshot only in phase 0, the controllers' reset only with the drives off; tick 0 next.)
  for (int event : {1, s.phase == 0 ? kClocksPerPeriod / 2 : 0, kClocksPerPeriod - 100,
                    s.enabled ? kClocksPerPeriod : kClocksPerPeriod - 1, kClocksPerPeriod}) {
    if (event > s.tick) {
      clocks = std::min<std::uint64_t>(clocks, static_cast<std::uint64_t>(event - s.tick));
      break;
    }
  }
  // uart_rx: up to the clock that hands link_rx the line's next byte; uart_tx: up to the clock its
  // last bit ends (link_tx sees it ready in the next) and the clock the line completes its byte.
  const bool rx_byte = !rx_line_.empty();
  if (rx_byte) clocks = std::min(clocks, rx_line_.front().valid_cycle - s.cycle + 1);
  if (s.tx_state != 0) clocks = std::min(clocks, s.tx_last_load - s.cycle + 1);

  if (s.running) {
    const std::uint64_t elapsed = s.cycle - s.run_start;
    for (std::uint64_t event : {duty_cycle(0), duty_cycle(1), duty_cycle(2)}) {
      if (event > elapsed) {
        clocks = std::min(clocks, event - elapsed);
        break;
      }
    }
  }

  if (s.busy) clocks = std::min<std::uint64_t>(clocks, static_cast<std::uint64_t>((s.step < 4 ? 4 : 7) - s.step));

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

  const bool enabled = s.enabled && s.fault_cause == 0;
  const int period = 1 << board::kPwmBits;
  const int last_phase = static_cast<int>((static_cast<std::uint64_t>(s.pwm_phase) + clocks - 1) % period);
  int pwm = 0;
  for (int j = 0; j < 3; ++j) {
    if (enabled && last_phase < s.duty[j]) pwm |= 1 << j;
  }
  if (rx_byte && rx_line_.front().valid_cycle == s.cycle + clocks - 1) {  // the run's last clock
    s.rx_valid = true;
    s.rx_shift = rx_line_.front().byte;
    rx_line_.pop_front();
  }
  if (s.tx_state != 0 && s.tx_last_load == s.cycle + clocks - 1) s.tx_state = 0;  // the frame's last byte loaded
  s.pwm = pwm;
  s.enable_out = enabled;
  s.pwm_phase = (last_phase + 1) % period;
  if (s.busy) s.step += static_cast<int>(clocks);
  s.tick += static_cast<int>(clocks);
  if (s.tick == kClocksPerPeriod) s.tick = 0;  // (a run ends before tick 0 at the latest)
  s.cycle += clocks;
  return clocks;
}

// The counters of one clock (what a quiet run of one does), with the drive pins of the clock.
void ModelBoard::count_clock(int encoder_a, int encoder_b) {
  State& s = *state_;
  if (!encoders_settled(s, encoder_a, encoder_b)) count_encoders(s, encoder_a, encoder_b);
  const bool enabled = s.enabled && s.fault_cause == 0;
  int pwm = 0;
  for (int j = 0; j < 3; ++j) {
    if (enabled && s.pwm_phase < s.duty[j]) pwm |= 1 << j;
  }
  s.pwm = pwm;
  s.enable_out = enabled;
  s.pwm_phase = (s.pwm_phase + 1) & ((1 << board::kPwmBits) - 1);
  s.rx_valid = false;
  if (!rx_line_.empty() && rx_line_.front().valid_cycle == s.cycle) {
    s.rx_valid = true;
    s.rx_shift = rx_line_.front().byte;
    rx_line_.pop_front();
  }
  if (s.tx_state != 0 && s.tx_last_load == s.cycle) s.tx_state = 0;
  if (s.busy) ++s.step;
  s.tick = s.tick == kClocksPerPeriod - 1 ? 0 : s.tick + 1;
  ++s.cycle;
}

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
  State& s = *state_;
  Memories& m = *memories_;
  const bool fault = s.fault_cause != 0;
  if (s.step_error[0] || s.step_error[1] || s.step_error[2] || s.slew_limited || s.check || switch_edge(s) != 0 ||
      (fault && (s.enabled || s.holding)) || (s.answered && (!s.enabled || fault)) ||
      (!s.enabled && s.silent_periods != 0) || (s.enabled && s.silent_periods > board::kWatchdogPeriods) ||
      (s.tx_state == 0 && (s.telemetry_pending || s.identify_pending))) {
    return false;
  }
  const int tick = s.tick;
  if (tick == 1 || (tick == kClocksPerPeriod / 2 && s.phase == 0) || (tick == kClocksPerPeriod - 100 && s.busy) ||
      (tick == kClocksPerPeriod - 1 && !s.enabled)) {
    return false;
  }
  const bool update = tick == kClocksPerPeriod - 100;
  // The whole update in its first clock, all three joints (the reference the controllers and the
  // safety check see next period, the slew-limit count telemetry reports next millisecond: the
  // same), where nothing can turn the drives off before it ends: the drives on, link_rx idle with
  // no byte for it before then, the encoder lines held and settled (no skipped state, no fault).
  // Not under the run check, which compares the RTL's register trace clock by clock.
  constexpr std::uint64_t kUpdateClocks = 8 * 3;
  const bool whole_update = update && !check_runs_ && s.enabled && !fault && lines_hold > kUpdateClocks + 4 &&
                            !s.rx_valid && !s.fetched && s.read == s.write &&
                            (rx_line_.empty() || rx_line_.front().valid_cycle > s.cycle + kUpdateClocks + 4) &&
                            encoders_settled(s, encoder_a, encoder_b);

  // ---- the period's start (tick 0) and the safety check (a fault latching: the full clock) ----
  const bool period_start = tick == 0;
  const bool ap_idle = !s.running;
  const std::array<std::uint16_t, 3> counts = s.count;
  int following = 0, outside = 0;
  if (s.checked) {
    for (int j = 0; j < 3; ++j) {
      const std::int32_t high = s.difference_q[j] >> board::kFollowingBits;
      if (high != 0 && high != -1) following |= 1 << j;
      if (s.outside_q[j]) outside |= 1 << j;
    }
    if (s.enabled && (following != 0 || outside != 0)) return false;
  }
  const bool checked = s.checked;

  // ---- link_rx (a frame's end or a dropped frame: the full clock) ----
  // A byte into an idle ring is fetched and processed two clocks later, by link_rx alone: the
  // model takes the three clocks in the first (nothing else reads link_rx's registers; the window
  // keeps clear of tick 1, whose play moves the setpoint buffer's write address), unless the byte
  // ends or drops a frame, and not under the run check.
  const bool ring_write = s.rx_valid;
  const bool whole_byte = ring_write && !s.fetched && s.read == s.write && !check_runs_ && tick > 1 &&
                          tick < kClocksPerPeriod - 2 && !rx_byte_ends_frame(s, s.rx_shift);
  const std::uint8_t processed = whole_byte ? s.rx_shift : s.ring_data;
  bool fetched = false;
  if (!s.fetched && !whole_byte) {
    fetched = s.read != s.write;
  } else if (rx_byte_ends_frame(s, processed)) {
    return false;  // a frame's end or a dropped frame: the full clock
  }

  // ---- interpolator ----
  const bool interpolating = s.busy && (s.step == 4 || s.step == 7);
  const bool interpolator_enabled = s.enabled && !fault;
  const bool take_answer = s.answer_pending && s.phase == 0;
  const int k_next = s.phase == 9 ? 10 : s.phase + 1;
  const int j_interpolated = s.joint;
  std::int32_t delta = s.delta, r = 0, d = 0;
  std::int16_t shift = 0;
  bool slew_limited = false;
  if (interpolating && s.step == 4) {
    const int j = s.joint;
    bool saturated = false;
    delta = segment_delta(s.net_outputs[j], s.r[j], half_plays_[j], take_answer, s.d[j], &saturated);
    slew_limited = take_answer && saturated && interpolator_enabled;
  } else if (interpolating) {
    const int j = s.joint;
    const std::int64_t step = reference_step(s.delta, s.phase);
    r = interpolator_enabled
            ? static_cast<std::int32_t>(static_cast<std::uint32_t>(s.r[j]) + static_cast<std::uint32_t>(step))
            : static_cast<std::int32_t>(static_cast<std::int16_t>(s.count[j])) * 256;
    d = (!interpolator_enabled || (k_next == 10 && !s.homing)) ? 0 : s.delta;
    shift = reference_shift(s, j, half_plays_[j]);
  }

  // ---- joint controller ----
  std::uint64_t elapsed = 0;
  if (s.running) elapsed = s.cycle - s.run_start;

  // ---- telemetry capture, link_tx ----
  const bool capturing = s.capturing, writing = s.writing;
  const std::uint16_t word = writing ? telemetry_word_of(s) : std::uint16_t{0};

  // The present values the work below writes over.
  const bool was_fetched = s.fetched || whole_byte;
  const std::uint8_t ring_byte = processed, rx_byte = s.rx_shift;
  const int old_index = s.index, old_read = s.read, old_write = s.write;
  const int old_step = s.step, capture = s.capture;
  const std::uint32_t next_index = s.sample_index + static_cast<std::uint32_t>(s.fill);

  // The registers that follow the present state every clock (RAM reads before this clock's writes).
  if (!s.settled) settle();
  count_clock(encoder_a, encoder_b);  // the counters, the drive pins (of the present duties)
  // What settle() follows changes below: the TX RAM read's address or word, the capture's word,
  // a stored current (the peek), a reference (the safety pipeline).
  bool stored = false;
  for (int j = 0; j < 3; ++j) stored |= elapsed == duty_cycle(j);
  if (writing || capturing || stored || (interpolating && old_step == 7) || period_start) s.settled = false;

  // schedule, controller start request, watchdog count, safety check; the played setpoint taken
  if (period_start) {
    s.phase = s.phase == 9 ? 0 : s.phase + 1;
    s.period_count = s.period_count + 1;
    if (ap_idle) {
      s.start_q = true;
      s.counts_q = counts;
    }
    if (s.enabled && s.silent_periods != kWatchdogMax) ++s.silent_periods;
    s.check = ap_idle;
  }
  if (checked) {
    s.active = following != 0 || outside != 0;
    s.checked = false;
  }
  s.starting = false;

  // link_rx: the ring's read (before this clock's write), the byte in, the byte processed.
  s.ring_data = whole_byte ? ring_byte : m.ring[old_read];
  if (ring_write) {
    m.ring[old_write] = rx_byte;
    s.write = (old_write + 1) % kRingBytes;
  }
  s.fetched = fetched;
  if (was_fetched) {
    const RxProcessed rx = process_rx_byte(s, ring_byte, s);
    if (rx.frame_start) {
      s.full_at_start = s.fill == kDepth;
      s.index_match = true;
      s.vetoed = false;
    }
    if (rx.payload_valid) {
      const int payload_index = (old_index - 4) & 63;
      if (s.type == board::kFrameTypeCommand) s.command = ring_byte;
      if (s.type == board::kFrameTypeSetpoint) {
        if (payload_index < 4 && ring_byte != ((next_index >> (8 * (payload_index & 3))) & 0xFF)) {
          s.index_match = false;
        }
        if (payload_index >= 4 && !s.full_at_start) m.ram[next_index % kDepth][(payload_index - 4) % 12] = ring_byte;
      }
    }
  }

  // interpolator
  if (interpolating && old_step == 4) {
    s.delta = delta;
    s.slew_limited = slew_limited;
  } else if (interpolating) {
    const int j = j_interpolated;
    s.r[j] = r;
    s.d[j] = d;
    s.shift[j] = shift;
    s.step = 0;
    s.joint = j + 1;
    if (j == 2) {
      s.busy = false;
      if (take_answer) s.answer_pending = false;
    }
  }
  if (whole_update) {
    const bool take = s.answer_pending && s.phase == 0;
    for (int j = 0; j < 3; ++j) {
      bool saturated = false;
      s.delta = segment_delta(s.net_outputs[j], s.r[j], half_plays_[j], take, s.d[j], &saturated);
      if (take && saturated) s.slew_limits = saturating_increment(s.slew_limits);
      const std::int64_t step = reference_step(s.delta, s.phase);
      s.shift[j] = reference_shift(s, j, half_plays_[j]);
      s.r[j] = static_cast<std::int32_t>(static_cast<std::uint32_t>(s.r[j]) + static_cast<std::uint32_t>(step));
      s.d[j] = (s.phase == 9 && !s.homing) ? 0 : s.delta;
    }
    if (take) s.answer_pending = false;
    s.busy = false;
    s.step = 0;
    s.joint = 3;
    s.settled = false;
  } else if (update) {
    s.busy = true;
    s.step = 0;
    s.joint = 0;
  }

  // joint controller: a current stored with its PWM duty (the third ends the run)
  if (elapsed != 0) store_current(s, elapsed);

  // telemetry capture and link_tx
  if (writing) m.words[(16 + s.written) & 255] = word;
  s.writing = capturing;
  s.written = capture;
  if (writing && !capturing) s.telemetry_pending = true;
  if (capturing) {
    s.capture = (capture + 1) & 31;
    if (capture == kTelemetryWords - 1) s.capturing = false;
  }
  return true;
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
  const std::uint64_t byte_clocks = 10 * static_cast<std::uint64_t>(kClocksPerBit);
  for (std::size_t i = 0; i < size; ++i) {
    // The start bit's first clock: now, or when the line has sent the byte before.
    const std::uint64_t start = std::max(state_->cycle, line_free_cycle_);
    line_free_cycle_ = start + byte_clocks;
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
  const bool fault = s.fault_cause != 0;
  int flags = 0;
  if (s.enabled && !fault) flags |= 1 << board::kFlagDriveEnable;
  if (s.homed) flags |= 1 << board::kFlagHomed;
  if (s.holding) flags |= 1 << board::kFlagHolding;
  if (fault) flags |= 1 << board::kFlagFault;
  if (s.encoder_error != 0) flags |= 1 << board::kFlagEncoderError;
  if (s.referenced == 7) flags |= 1 << board::kFlagReferenced;
  if (s.homing) flags |= 1 << board::kFlagHoming;
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
    return static_cast<std::uint16_t>((flags << 8) | (rising_bits(s) << board::kTelemetryPlaySideShift) |
                                      s.fault_cause);
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
    return s.refused;
  else if (w == board::kTelemetrySequenceOffset / 2)
    return static_cast<std::uint16_t>((((s.referenced << 3) | ((s.enc_a >> kHomeSwitchShift) & 7)) << 8) |
                                      s.last_sequence);
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
  for (int p = 0; p < n.tx_length; ++p) {
    const std::uint16_t word = m.words[((n.is_identify ? 0 : 16) + (p >> 1)) & 255];
    frame.payload[static_cast<std::size_t>(p)] = static_cast<std::uint8_t>((p & 1) ? word >> 8 : word & 0xFF);
  }
  const std::vector<std::uint8_t> bytes = link::encode_frame(frame);
  const std::uint64_t first = std::max(start + 1, n.uart_free);
  for (std::size_t k = 0; k < bytes.size(); ++k)
    tx_line_.push_back({first + kTxByteClocks * k + kTxByteDelay, bytes[k]});
  n.tx_last_load = first + kTxByteClocks * (bytes.size() - 1);
  n.uart_free = n.tx_last_load + kTxByteClocks;
}

void ModelBoard::clock(int encoder_a, int encoder_b) {
  if (!checking_ && quiet_clock(encoder_a, encoder_b)) return;
  State& s = *state_;
  Memories& m = *memories_;
  State& n = *next_state_;  // the next values, committed at the end (the buffers swap)
  n = s;
  n.settled = false;
  // ---- uart_rx (the line's bytes at their clocks: ModelBoard::receive) ----
  n.rx_valid = false;
  if (!rx_line_.empty() && rx_line_.front().valid_cycle == s.cycle) {
    n.rx_valid = true;
    n.rx_shift = rx_line_.front().byte;
    rx_line_.pop_front();
  }

  // ---- link_rx ----
  n.fetched = false;
  RxProcessed rx;
  if (!s.fetched) {
    n.fetched = s.read != s.write;
  } else {
    rx = process_rx_byte(s, s.ring_data, n);
  }
  const bool frame_start = rx.frame_start, payload_valid = rx.payload_valid;
  const bool frame_ok = rx.frame_ok, frame_bad = rx.frame_bad;
  n.ring_data = m.ring[s.read];  // read before this edge's write (the RTL never reads the slot written)
  if (s.rx_valid) {
    m.ring[s.write] = s.rx_shift;
    n.write = (s.write + 1) % kRingBytes;
  }
  const int payload_index = (s.index - 4) & 63;
  const std::uint8_t payload_byte = s.ring_data;
  const bool is_setpoint = s.type == board::kFrameTypeSetpoint;
  const bool is_command = s.type == board::kFrameTypeCommand;
  const bool is_identify_request = s.type == board::kFrameTypeIdentifyRequest;

  // ---- joint_axes: fault, commands ----
  const bool fault = s.fault_cause != 0;
  const bool command_ok = frame_ok && is_command;
  const int edge = switch_edge(s);
  bool flush = (fault && s.enabled) || edge != 0, home = false, home_start = false, clear_fault = false,
       command_refused = false;
  if (command_ok) {
    switch (s.command) {
      case board::kCommandEnable:
        command_refused = fault || !s.homed || (s.enabled && !s.holding);
        break;
      case board::kCommandDisable:
        flush = true;
        break;
      case board::kCommandHold:
        command_refused = !s.enabled;
        break;
      case board::kCommandClearFault:
        command_refused = s.active;
        clear_fault = !s.active;
        break;
      case board::kCommandSetHome:
        command_refused = s.enabled;
        home = !s.enabled;
        break;
      case board::kCommandHomeStart:
        command_refused = s.enabled;
        home_start = !s.enabled;
        break;
      default:
        command_refused = true;
    }
  }
  if (payload_valid && is_command) n.command = payload_byte;
  if (command_ok && !command_refused) {
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
  if (home) n.homed = true;
  if (home_start) n.homing = true;
  n.referenced = (home_start ? 0 : s.referenced) | edge;
  if ((!home_start && (s.referenced | edge) == 7) || (command_ok && s.command == board::kCommandHold)) n.homing = false;
  if (fault || edge != 0) {
    n.enabled = false;
    n.holding = false;
  }
  if (fault) n.homing = false;

  // ---- period schedule ----
  if (s.tick == 0) {
    n.phase = s.phase == 9 ? 0 : s.phase + 1;
    n.period_count = s.period_count + 1;
  }
  const bool play = s.tick == 1 && s.phase == 0 && s.enabled && !s.holding && !fault;
  const bool snapshot = s.tick == kClocksPerPeriod / 2 && s.phase == 0;
  const bool update = s.tick == kClocksPerPeriod - 100;

  // ---- setpoint buffer ----
  const std::uint32_t next_index = s.sample_index + static_cast<std::uint32_t>(s.fill);
  const bool write_enable = is_setpoint && payload_valid && payload_index >= 4 && !s.full_at_start;
  const bool accept = s.enabled && !fault;  // setpoints only with the drives on
  const bool commit = frame_ok && is_setpoint && accept && s.index_match && !s.full_at_start && !s.vetoed && !flush;
  const bool setpoint_refused = frame_ok && is_setpoint && !commit;
  const bool pop = play && !s.starting && s.fill != 0;
  const bool underrun = play && s.fill == 0;
  if (frame_start) {
    n.full_at_start = s.fill == kDepth;
    n.index_match = true;
    n.vetoed = false;
  }
  if (flush) n.vetoed = true;
  if (is_setpoint && payload_valid && payload_index < 4 &&
      payload_byte != ((next_index >> (8 * (payload_index & 3))) & 0xFF)) {
    n.index_match = false;
  }
  if (flush) {
    n.fill = 0;
  } else if (commit && !pop) {
    n.fill = s.fill + 1;
  } else if (pop && !commit) {
    n.fill = s.fill - 1;
  }
  if (pop) {
    n.sample_index = s.sample_index + 1;
    n.starting = true;
    // The network (golden, bit for bit): its answer arrives long before the update reads it.
    const auto& entry = m.ram[s.sample_index % kDepth];
    std::array<std::int64_t, 3> position{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t code = 0;
      for (int b = 0; b < 4; ++b) code |= static_cast<std::uint32_t>(entry[4 * k + b]) << (8 * b);
      position[k] = static_cast<std::int32_t>(code);
    }
    const golden::RawOutput answer = golden::evaluate_raw(*s.network, position);
    for (int j = 0; j < 3; ++j) n.net_outputs[j] = sign_extend(static_cast<std::uint32_t>(answer.alpha[j]), 24);
    n.answer_pending = true;
  } else if (s.starting) {
    n.starting = false;  // the network takes it (ready) long before the next play
  }

  // After the pop's read: a full buffer takes no write, so the slot written is never the one read.
  if (write_enable) m.ram[next_index % kDepth][(payload_index - 4) % 12] = payload_byte;

  // ---- reference interpolator ----
  const bool interpolator_enabled = s.enabled && !fault;
  // An answer since the enable: the network's answer to a pop arrives before the next update reads it.
  n.answered = interpolator_enabled && (s.answered || pop);
  n.slew_limited = false;
  const bool take_answer = s.answer_pending && s.phase == 0;
  const int k_next = s.phase == 9 ? 10 : s.phase + 1;
  if (update && !s.busy) {
    n.busy = true;
    n.step = 0;
    n.joint = 0;
  } else if (s.busy) {
    const int j = s.joint;
    n.step = s.step + 1;
    if (s.step == 4) {
      bool saturated = false;
      n.delta = segment_delta(s.net_outputs[j], s.r[j], half_plays_[j], take_answer, s.d[j], &saturated);
      if (take_answer && saturated && interpolator_enabled) n.slew_limited = true;
    }
    if (s.step == 7) {
      const std::int64_t step = reference_step(s.delta, s.phase);
      n.r[j] = interpolator_enabled
                   ? static_cast<std::int32_t>(static_cast<std::uint32_t>(s.r[j]) + static_cast<std::uint32_t>(step))
                   : static_cast<std::int32_t>(static_cast<std::int16_t>(s.count[j])) * 256;
      n.d[j] = (!interpolator_enabled || (k_next == 10 && !s.homing)) ? 0 : s.delta;
      n.shift[j] = reference_shift(s, j, half_plays_[j]);
      n.step = 0;
      n.joint = j + 1;
      if (j == 2) {
        n.busy = false;
        if (take_answer) n.answer_pending = false;
      }
    }
  }
  if (s.slew_limited) n.slew_limits = saturating_increment(s.slew_limits);

  // ---- encoders (synchronisers, quadrature counters) ----
  n.switch_previous = (s.enc_a >> kHomeSwitchShift) & 7;
  n.enc_a_meta = encoder_a;
  n.enc_a = s.enc_a_meta;
  n.enc_b_meta = encoder_b;
  n.enc_b = s.enc_b_meta;
  int step_error_bits = 0;
  for (int j = 0; j < 3; ++j) {
    const int ab = (((s.enc_a >> j) & 1) << 1) | ((s.enc_b >> j) & 1);
    const int move = quadrature_move(s.previous[j], ab);
    const bool error = move == kSkippedState;
    const std::uint16_t count = static_cast<std::uint16_t>(s.count[j] + (error ? 0 : move));
    n.previous[j] = ab;
    n.step_error[j] = error;
    if (!error && move != 0) n.rising[j] = move > 0;
    const bool load = (home && ((s.referenced >> j) & 1) == 0) || ((edge >> j) & 1) != 0;
    n.count[j] = load ? static_cast<std::uint16_t>(board::kHomeCount) : count;
    if (s.step_error[j]) step_error_bits |= 1 << j;
  }
  n.encoder_error = s.encoder_error | step_error_bits;

  // ---- joint controller ----
  const bool ap_idle = !s.running;
  std::array<std::int32_t, 3> references = s.r;
  if (s.start_q && ap_idle) {
    n.running = true;
    n.start_q = false;  // (the RTL clears it at ap_ready, kLoadCycles later: nothing reads it before)
    n.run_start = s.cycle;
    for (int j = 0; j < 3; ++j) {
      control::JointFixedInput input;
      input.reference = references[j];
      input.encoder = static_cast<std::int16_t>(s.counts_q[j]);
      input.shift = s.shift[j];
      if (!s.primed) n.joint_state[j] = control::fixed_rest_state(input);
      control::JointFixedStatus status;
      n.next_current[j] = control::fixed_update(s.coefficients, n.joint_state[j], input, status);
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
  if (!s.enabled && s.tick == kClocksPerPeriod - 1) {
    n.running = false;
    n.primed = false;
    n.current = {0, 0, 0};
    n.overflow = 0;
  }

  // ---- joint_safety ----
  if (frame_ok || !s.enabled) {
    n.silent_periods = 0;
  } else if (s.tick == 0 && s.silent_periods != kWatchdogMax) {
    n.silent_periods = s.silent_periods + 1;
  }
  int following = 0, outside = 0;
  for (int j = 0; j < 3; ++j) {
    const std::int32_t reference_count = s.r[j] >> 8;  // bits 31..8 (24-bit signed)
    const std::int32_t reference17 = sign_extend(static_cast<std::uint32_t>(reference_count), 17);
    n.difference_q[j] =
        sign_extend(static_cast<std::uint32_t>(reference17 - static_cast<std::int16_t>(s.counts_q[j])), 17);
    const std::int32_t block = sign_extend(static_cast<std::uint32_t>(reference_count), 24) >> 10;
    n.outside_q[j] = block < board::kMinTravelBlock || block > board::kMaxTravelBlock;
    const std::int32_t high = s.difference_q[j] >> board::kFollowingBits;
    if (high != 0 && high != -1) following |= 1 << j;
    if (s.outside_q[j]) outside |= 1 << j;
  }
  int cause = clear_fault ? 0 : s.fault_cause;
  if (step_error_bits != 0) cause |= 1 << board::kFaultEncoderSkip;
  if (s.checked && s.enabled) {
    if (following) cause |= 1 << board::kFaultFollowing;
    if (outside) cause |= 1 << board::kFaultTravel;
  }
  if (s.enabled && s.silent_periods > board::kWatchdogPeriods) cause |= 1 << board::kFaultWatchdog;
  n.fault_cause = cause;
  n.check = s.tick == 0 && ap_idle;
  n.checked = s.check;
  if (s.checked) n.active = following != 0 || outside != 0;

  // ---- joint_pwm ----
  int pwm = 0;
  for (int j = 0; j < 3; ++j) {
    if (s.enabled && !fault && s.pwm_phase < s.duty[j]) pwm |= 1 << j;
  }
  n.pwm = pwm;
  n.enable_out = s.enabled && !fault;
  n.pwm_phase = (s.pwm_phase + 1) & ((1 << board::kPwmBits) - 1);

  // ---- counters ----
  if (frame_bad) n.bad_frames = saturating_increment(s.bad_frames);
  if (underrun && !s.homing) n.underruns = saturating_increment(s.underruns);
  if (command_refused || setpoint_refused) n.refused = saturating_increment(s.refused);
  if (frame_ok) n.last_sequence = s.sequence;

  // ---- telemetry words and link_tx ----
  // peek: the state word asked for in this cycle, one cycle later (the controller is idle then).
  n.peek_data = peek_word(s.peek_memory, s.capture);
  n.word_index = s.capture;
  const std::uint16_t telemetry_word = telemetry_word_of(s);
  {
    if (s.writing) m.words[(16 + s.written) & 255] = telemetry_word;
    const bool sending_telemetry = s.tx_state != 0 && !s.is_identify;
    bool start_identify = false, start_telemetry = false;
    if (s.tx_state == 0) {
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
        n.tx_state = 2;
        start_frame(n, s.cycle);
      }
    } else if (s.cycle == s.tx_last_load) {
      n.tx_state = 0;  // the frame's last byte goes to uart_tx
    }
    n.writing = s.capturing;
    n.written = s.capture;
    if (s.writing && !s.capturing) n.telemetry_pending = true;
    if (frame_ok && is_identify_request) {
      n.identify_pending = true;
      n.identify_sequence = s.sequence;
    } else if (start_identify) {
      n.identify_pending = false;
    }
    if (start_telemetry) {
      n.telemetry_pending = false;
      n.telemetry_sequence = static_cast<std::uint8_t>(s.telemetry_sequence + 1);
    }
    if (snapshot && !s.capturing && !s.writing && !s.telemetry_pending && !sending_telemetry) {
      n.capturing = true;
      n.capture = 0;
    } else if (s.capturing) {
      n.capture = (s.capture + 1) & 31;
      if (s.capture == kTelemetryWords - 1) n.capturing = false;
    }
  }
  n.tick = s.tick == kClocksPerPeriod - 1 ? 0 : s.tick + 1;
  n.cycle = s.cycle + 1;
  std::swap(state_, next_state_);

  const State& q = *state_;
  pins_.drive_pwm = q.pwm;
  pins_.drive_dir = q.direction;
  pins_.drive_enable = q.enable_out;
  pins_.encoder_error = q.encoder_error;
  pins_.joint_limited = q.overflow != 0;
  pins_.fault_cause = q.fault_cause;
}

}  // namespace delta::cosim
