// The virtual board: the board (Verilated core or model board, one BoardModel) + robot world + UART line (see
// virtual_board.hpp).
#include "delta/cosim/virtual_board.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "Vboard_core.h"
#include "Vboard_core___024root.h"
#include "delta/cosim/model_board.hpp"
#include "delta/crc32.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"
#include "delta/rtl/board_clock.hpp"
#include "delta/rtl/uart_line.hpp"
#include "verilated.h"

namespace delta::cosim {

namespace {

// Whether a Verilated core has the safety input ports (estop_open_i, drive_fault_i).
template <typename Core, typename = void>
struct HasSafetyPorts : std::false_type {};
template <typename Core>
struct HasSafetyPorts<
    Core, std::void_t<decltype(std::declval<Core&>().estop_open_i), decltype(std::declval<Core&>().drive_fault_i)>>
    : std::true_type {};

// Whether it has the board causes' outputs (board_fault_cause_o, estop_latched_o).
template <typename Core, typename = void>
struct HasBoardCauseOutputs : std::false_type {};
template <typename Core>
struct HasBoardCauseOutputs<Core, std::void_t<decltype(std::declval<const Core&>().board_fault_cause_o),
                                              decltype(std::declval<const Core&>().estop_latched_o)>> : std::true_type {
};
template <typename Core>
void read_board_causes(const Core& core, BoardPins& pins) {
  if constexpr (HasBoardCauseOutputs<Core>::value) {
    pins.board_fault_bits = core.board_fault_cause_o;
    pins.estop_latched = core.estop_latched_o != 0;
  }
}

// The safety inputs onto the Verilated core's ports, where it has them.
template <typename Core>
void set_safety_ports(Core& core, const BoardLines& lines) {
  if constexpr (HasSafetyPorts<Core>::value) {
    core.estop_open_i = lines.estop_open ? 1 : 0;
    core.drive_fault_i = static_cast<std::uint8_t>(lines.drive_fault & 7);
  }
}

// The Verilated board core as a BoardModel: its context (one per board: the plusarg names this
// board's .mem files), the serial line at its pins, and the network's clock skipped while idle.
class RtlBoardModel final : public BoardModel {
 public:
  explicit RtlBoardModel(const VirtualBoardOptions& options)
      : context_(std::make_unique<VerilatedContext>()),
        line_(kClocksPerBit),
        network_clock_(options.skip_idle_network) {
    const std::string plusarg = "+delta_mem_dir=" + options.mem_dir;
    const char* argv[] = {"virtual_board", plusarg.c_str()};
    context_->commandArgs(2, argv);
    core_ = std::make_unique<Vboard_core>(context_.get(), "board");
    rtl::reset_board(*core_);
  }
  ~RtlBoardModel() override { core_->final(); }

  void receive(const std::uint8_t* data, std::size_t size) override {
    line_.send(std::vector<std::uint8_t>(data, data + size));
    bytes_on_line_ += size;
  }
  std::size_t bytes_on_line() override { return bytes_on_line_; }
  void clock(const BoardLines& lines) override {
    Vboard_core& core = *core_;
    const bool sending = line_.sending();
    core.uart_rx_i = line_.rx_pin();
    if (sending && ++bits_sent_ % (10 * kClocksPerBit) == 0) --bytes_on_line_;
    core.encoder_a_i = lines.encoder_a;
    core.encoder_b_i = lines.encoder_b;
    core.home_switch_i = lines.home_switches;
    set_safety_ports(core, lines);
    network_clock_.clock(core);
    if (line_.sample_tx_pin(core.uart_tx_o)) tx_.push_back(line_.byte());
  }
  bool take_tx_byte(std::uint8_t* byte) override {
    if (tx_.empty()) return false;
    *byte = tx_.front();
    tx_.pop_front();
    return true;
  }
  BoardPins pins() const override {
    const Vboard_core& core = *core_;
    BoardPins pins;
    pins.drive_pwm = core.drive_pwm_o;
    pins.drive_dir = core.drive_dir_o;
    pins.drive_enable = core.drive_enable_o;
    pins.encoder_error_bits = core.encoder_error_o;
    pins.joint_limited = core.joint_limited_o;
    pins.fault_cause_bits = core.joint_fault_cause_o;
    pins.stage_sync = core.stage_sync_o != 0;
    read_board_causes(core, pins);
    return pins;
  }
  std::uint64_t idle_network_clocks() const override { return network_clock_.skipped(); }

 private:
  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Vboard_core> core_;
  rtl::UartLine line_;
  rtl::IdleNetworkSkip network_clock_;  // the board clock without an idle network's edges
  std::size_t bytes_on_line_ = 0;       // written and not yet fully sent
  std::uint64_t bits_sent_ = 0;
  std::deque<std::uint8_t> tx_;
};

std::unique_ptr<BoardModel> make_board(const VirtualBoardOptions& options) {
  if (options.fidelity == BoardFidelity::kRtl) return std::make_unique<RtlBoardModel>(options);
  auto board = std::make_unique<ModelBoard>(options.mem_dir + "/identify.mem");
  board->check_runs(options.check_model_runs);
  return board;
}

}  // namespace

bool rtl_board_has_safety_inputs() { return HasSafetyPorts<Vboard_core>::value; }

VirtualBoard::VirtualBoard(const VirtualBoardOptions& options) : board_(make_board(options)) {
  BoardInterface board_interface;
  board_interface.board_clock_hz = kBoardClockHz;
  board_interface.pwm_period_cycles = static_cast<int>(board::kPwmPeriodCycles);
  board_interface.current_full_scale_a = kCurrentFullScaleA;
  board_interface.home_count = kHomeCount;
  board_interface.count_deg = board::kEncoderCountDeg;
  // The plants step once per control period, 35 cycles before it starts: up to 8 counts (4 cycles
  // each) and the synchronisers' 3 cycles reach the counters the controllers sample at tick 0.
  board_interface.plant_divider = static_cast<int>(kClocksPerTick);
  board_interface.plant_lead = 3 + 8 * board_interface.quadrature_dwell;
  if (options.inject_encoder_skip_at_s >= 0.0) {
    encoder_skip_clock_ = static_cast<std::uint64_t>(options.inject_encoder_skip_at_s * kBoardClockHz);
  }
  world_ = std::make_unique<RobotWorld>(board_interface, options.effects, options.nominal, options.plant);
  world_->set_drag(options.drag);
  if (options.start_true_alpha_deg) world_->place_arms(*options.start_true_alpha_deg);
  if (options.inject_seized_joint >= 0) world_->seize_joint(options.inject_seized_joint);
  if (options.inject_missing_home_switch >= 0) world_->remove_home_switch(options.inject_missing_home_switch);
  if (options.inject_slip_joint >= 0) {
    world_->slip_encoder(options.inject_slip_joint, options.inject_slip_counts,
                         static_cast<std::uint64_t>(options.inject_slip_at_s * kBoardClockHz));
  }
  for (const SafetyInputWindow& window : options.safety_inputs) {
    const auto clock_of = [](double t_s) {
      return std::isfinite(t_s) ? static_cast<std::uint64_t>(std::llround(t_s * kBoardClockHz)) : ~std::uint64_t{0};
    };
    safety_windows_.push_back({1 << window.input, clock_of(window.from_s), clock_of(window.until_s)});
  }
  safety_now_ = safety_inputs_at(0);
  if (options.network != nullptr) load_at_start(*options.network);
}

int VirtualBoard::safety_inputs_at(std::uint64_t clock) const {
  int bits = 0;
  for (const SafetyClocks& w : safety_windows_)
    if (clock >= w.from && clock < w.until) bits |= w.bit;
  return bits;
}

std::uint64_t VirtualBoard::next_safety_change(std::uint64_t clock) const {
  std::uint64_t next = ~std::uint64_t{0};
  for (const SafetyClocks& w : safety_windows_) {
    if (w.from > clock) next = std::min(next, w.from);
    if (w.until > clock) next = std::min(next, w.until);
  }
  return next;
}

// The model's load as a host sends it (`deltactl host load`: its frames in order, then an
// identify), before any host byte; the board runs until the identify's answer has come and the
// line from it is between frames, so a host starts on a whole frame.
void VirtualBoard::load_at_start(const golden::QuantisedNetwork& network) {
  std::vector<std::uint8_t> bytes;
  std::uint8_t sequence = 0;
  for (const link::ModelPayload& payload : golden::model_frames(network)) {
    const std::vector<std::uint8_t> frame = link::encode_frame(link::make_frame(sequence++, payload));
    bytes.insert(bytes.end(), frame.begin(), frame.end());
  }
  const std::vector<std::uint8_t> identify =
      link::encode_frame(link::Frame{sequence, link::FrameType::kIdentifyRequest, {}});
  bytes.insert(bytes.end(), identify.begin(), identify.end());
  write(bytes.data(), bytes.size());
  const std::uint32_t crc = weights_crc(network);
  link::FrameDecoder decoder(link::Receiver::kHost);
  std::optional<std::uint32_t> board_crc;
  // The load's line time and the identify's answer, with a margin (a telemetry frame before it).
  const std::uint64_t limit = clocks_ + (bytes.size() + 4 * link::kMaxFrameBytes) * 10 * kClocksPerBit;
  while (!(board_crc && decoder.bytes_to_decide() == 1) && clocks_ < limit) {
    step(kClocksPerTick);
    std::uint8_t buffer[256];
    for (std::size_t n; (n = read(buffer, sizeof buffer)) > 0;) {
      for (const link::Frame& frame : decoder.feed(buffer, n)) {
        if (frame.type == link::FrameType::kIdentify && frame.sequence == sequence) {
          board_crc = link::decode_identify(frame.payload).weights_crc;
        }
      }
    }
  }
  if (!board_crc || *board_crc != crc) {
    throw std::runtime_error("virtual board: the board did not take the model (" +
                             (board_crc ? "its CRC " + golden::hex_word(*board_crc, 32) : std::string("no identify")) +
                             ", the model's " + golden::hex_word(crc, 32) + ")");
  }
}

VirtualBoard::~VirtualBoard() = default;

const RobotWorld& VirtualBoard::world() const { return *world_; }

void VirtualBoard::write(const std::uint8_t* data, std::size_t size) { board_->receive(data, size); }

std::size_t VirtualBoard::bytes_to_board() const { return board_->bytes_on_line(); }

std::size_t VirtualBoard::read(std::uint8_t* data, std::size_t capacity) {
  const std::size_t n = std::min(capacity, from_board_.size());
  std::copy_n(from_board_.begin(), n, data);
  from_board_.erase(from_board_.begin(), from_board_.begin() + static_cast<std::ptrdiff_t>(n));
  return n;
}

BoardLines VirtualBoard::lines() const {
  const int skipped = clocks_ >= encoder_skip_clock_ ? 1 : 0;  // joint 1's lines inverted
  BoardLines lines{world_->encoder_a() ^ skipped, world_->encoder_b() ^ skipped, world_->home_switches()};
  lines.estop_open = (safety_now_ & 1) != 0;
  lines.drive_fault = safety_now_ >> 1;
  return lines;
}

void VirtualBoard::take_bytes() {
  std::uint8_t byte = 0;
  while (board_->take_tx_byte(&byte)) from_board_.push_back(byte);
}

void VirtualBoard::clock() {
  if (period_observer_ && period_phase_ == 0) {
    observed([&] { period_observer_(clocks_, pins(), *world_); });
  }
  flush_world();
  if (truth_observer_ && millisecond_phase_ == 0) observe(board_->pins().drive_enable);
  board_->clock(lines());
  take_bytes();
  const BoardPins pins = board_->pins();
  // A drive in fault gives no current, whatever its PWM input.
  world_->step({pins.drive_pwm & ~(safety_now_ >> 1), pins.drive_dir, pins.drive_enable});
  ++clocks_;
  if (!safety_windows_.empty()) safety_now_ = safety_inputs_at(clocks_);
  if (++period_phase_ == kClocksPerTick) period_phase_ = 0;
  if (++millisecond_phase_ == kClocksPerMillisecond) millisecond_phase_ = 0;
}

void VirtualBoard::observe(bool drives_enabled) {
  TruthSample truth;
  truth.t_s = time_s();
  truth.position_m = world_->measured_position_m();
  truth.true_alpha_deg = world_->true_alpha_deg();
  truth.encoder_deg = world_->encoder_deg();
  truth.current_a = world_->current_a();
  truth.drives_enabled = drives_enabled;
  truth.estop_open = (safety_now_ & 1) != 0;
  truth.drive_fault = safety_now_ >> 1;
  observed([&] { truth_observer_(truth, *world_); });
}

// The world's runs not yet advanced (consecutive runs of one drive pattern go in one advance).
void VirtualBoard::flush_world() {
  if (world_cycles_ == 0) return;
  world_->advance(world_cycles_, world_pattern_);
  world_cycles_ = 0;
}

// A board that takes runs (the model board): runs of clocks in which nothing but counters move on
// either side of the pins (BoardModel::skip, RobotWorld::advance) go at once; a run ends where the board or the world
// has an event (the board's include its serial lines' bytes), or a control period ends (its first clock, with the
// observers, goes one by one). The world takes the runs when the drive pattern changes, at its own event, and before
// anything looks at it.
bool VirtualBoard::skip_run(std::uint64_t limit, std::size_t needed_bytes) {
  const std::uint64_t to_world_event = world_->cycles_to_event() - world_cycles_;
  // The observers see the start of each period (1 ms) they watch in clock().
  std::uint64_t clocks = std::min(limit, to_world_event);
  if (period_observer_) clocks = std::min(clocks, kClocksPerTick - period_phase_);
  if (truth_observer_) clocks = std::min(clocks, kClocksPerMillisecond - millisecond_phase_);
  if (needed_bytes != 0) {  // up to the clock the line completes the byte the caller waits for
    const std::uint64_t completes = board_->tx_byte_cycle(needed_bytes - 1);
    if (completes != ~std::uint64_t{0}) clocks = std::min(clocks, completes - clocks_ + 1);
  }
  if (clocks_ < encoder_skip_clock_) clocks = std::min(clocks, encoder_skip_clock_ - clocks_);
  const std::uint64_t safety_change = next_safety_change(clocks_);  // (the inputs held over the run)
  if (safety_change != ~std::uint64_t{0}) clocks = std::min(clocks, safety_change - clocks_);
  DrivePattern pattern;
  const std::uint64_t taken = board_->skip(clocks, lines(), &pattern);
  if (taken == 0) return false;
  take_bytes();
  for (int j = 0; j < 3; ++j)
    if (((safety_now_ >> (j + 1)) & 1) != 0) pattern.duty[j] = 0;  // a drive in fault: no current
  const int period = static_cast<int>(board::kPwmPeriodCycles);
  const bool continues = world_cycles_ != 0 && pattern.enable == world_pattern_.enable &&
                         pattern.direction == world_pattern_.direction && pattern.duty == world_pattern_.duty &&
                         static_cast<std::uint64_t>(pattern.phase) ==
                             (static_cast<std::uint64_t>(world_pattern_.phase) + world_cycles_) % period;
  if (!continues) {
    flush_world();
    world_pattern_ = pattern;
  }
  world_cycles_ += taken;
  if (taken == to_world_event) flush_world();  // the world's event: its plant step or an encoder line
  clocks_ += taken;
  if (!safety_windows_.empty()) safety_now_ = safety_inputs_at(clocks_);
  period_phase_ += taken;  // (a run crosses a period's start only where nothing observes it)
  if (period_phase_ >= kClocksPerTick) period_phase_ %= kClocksPerTick;
  millisecond_phase_ += taken;
  if (millisecond_phase_ >= kClocksPerMillisecond) millisecond_phase_ %= kClocksPerMillisecond;
  return true;
}

void VirtualBoard::run(std::uint64_t board_clocks, std::size_t until_bytes) {
  const auto start = std::chrono::steady_clock::now();
  const double observers_before = observer_s_;
  const std::uint64_t end = clocks_ + board_clocks;
  while (clocks_ < end && !(until_bytes != 0 && from_board_.size() >= until_bytes)) {
    const std::size_t needed = until_bytes > from_board_.size() ? until_bytes - from_board_.size() : 0;
    const bool observed = (period_observer_ && period_phase_ == 0) || (truth_observer_ && millisecond_phase_ == 0);
    if (!board_->takes_runs() || observed || !skip_run(end - clocks_, needed)) clock();
  }
  flush_world();
  busy_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() -
             (observer_s_ - observers_before);
}

void VirtualBoard::step(std::uint64_t board_clocks) { run(board_clocks, 0); }

bool VirtualBoard::step_until_byte(std::uint64_t board_clocks, std::size_t bytes) {
  run(board_clocks, std::max<std::size_t>(bytes, 1));
  return !from_board_.empty();
}

bool VirtualBoardStream::wait_readable(int timeout_ms, std::size_t bytes) {
  const auto clocks = static_cast<std::uint64_t>(std::max(timeout_ms, 0)) * kClocksPerMillisecond;
  return board_.step_until_byte(std::max<std::uint64_t>(clocks, 1), bytes);
}

}  // namespace delta::cosim
