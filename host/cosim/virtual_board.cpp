// The virtual board at RTL fidelity: Verilated board core + robot world + UART line (see virtual_board.hpp).
#include "delta/cosim/virtual_board.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <vector>

#include "Vboard_core.h"
#include "Vboard_core___024root.h"
#include "delta/cosim/model_board.hpp"
#include "delta/rtl/board_clock.hpp"
#include "delta/rtl/uart_line.hpp"
#include "verilated.h"

namespace delta::cosim {

namespace {
// The model board's A lines carry the home switches above the three encoder lines (model_board.hpp).
int model_lines_a(const RobotWorld& world, int skipped) {
  return (world.encoder_a() ^ skipped) | (world.home_switches() << 3);
}
}  // namespace

// The Verilated model, its context (one per board: the plusarg names this board's .mem files)
// and the serial line at its pins.
// At model fidelity only `board` is set.
class VirtualBoard::Core {
 public:
  explicit Core(const VirtualBoardOptions& options) : line(kClocksPerBit), network_clock(options.skip_idle_network) {
    if (options.fidelity == BoardFidelity::kModel) {
      if (options.network == nullptr) throw std::invalid_argument("the model board needs the network's weights");
      board = std::make_unique<ModelBoard>(*options.network, options.mem_dir + "/identify.mem");
      board->check_runs(options.check_model_runs);
      return;
    }
    context = std::make_unique<VerilatedContext>();
    const std::string plusarg = "+delta_mem_dir=" + options.mem_dir;
    const char* argv[] = {"virtual_board", plusarg.c_str()};
    context->commandArgs(2, argv);
    model = std::make_unique<Vboard_core>(context.get(), "board");
  }
  ~Core() {
    if (model) model->final();
  }
  std::unique_ptr<VerilatedContext> context;
  std::unique_ptr<Vboard_core> model;
  std::unique_ptr<ModelBoard> board;
  rtl::UartLine line;
  rtl::IdleNetworkSkip network_clock;  // the board clock without an idle network's edges
  std::size_t bytes_on_line = 0;       // written and not yet fully sent
  std::uint64_t bits_sent = 0;
};

VirtualBoard::VirtualBoard(const VirtualBoardOptions& options) : core_(std::make_unique<Core>(options)) {
  BoardInterface board_interface;
  board_interface.board_clock_hz = kBoardClockHz;
  board_interface.pwm_period_cycles = static_cast<int>(board::kPwmPeriodCycles);
  board_interface.current_full_scale_a = kCurrentFullScaleA;
  board_interface.home_count = kHomeCount;
  board_interface.count_deg = kCountDeg;
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
  if (core_->board) return;  // the model starts in its reset state

  Vboard_core& core = *core_->model;
  core.uart_rx_i = 1;
  core.encoder_a_i = 0;
  core.encoder_b_i = 0;
  core.home_switch_i = 0;
  core.rst_ni = 0;
  core.rst_network_ni = 0;
  for (int i = 0; i < 4; ++i) rtl::clock_board(core);
  core.rst_ni = 1;
  core.rst_network_ni = 1;
}

VirtualBoard::~VirtualBoard() = default;

const RobotWorld& VirtualBoard::world() const { return *world_; }

std::uint64_t VirtualBoard::idle_network_clocks() const { return core_->network_clock.skipped(); }

void VirtualBoard::write(const std::uint8_t* data, std::size_t size) {
  if (core_->board) {  // the model board's line takes bytes
    core_->board->receive(data, size);
    return;
  }
  core_->line.send(std::vector<std::uint8_t>(data, data + size));
  core_->bytes_on_line += size;
}

std::size_t VirtualBoard::bytes_to_board() const {
  return core_->board ? core_->board->bytes_on_line() : core_->bytes_on_line;
}

std::size_t VirtualBoard::read(std::uint8_t* data, std::size_t capacity) {
  const std::size_t n = std::min(capacity, from_board_.size());
  std::copy_n(from_board_.begin(), n, data);
  from_board_.erase(from_board_.begin(), from_board_.begin() + static_cast<std::ptrdiff_t>(n));
  return n;
}

void VirtualBoard::clock() {
  if (period_observer_ && period_phase_ == 0) {
    observed([&] { period_observer_(clocks_, pins(), *world_); });
  }
  if (core_->board) {
    clock_model();
    if (++period_phase_ == kClocksPerTick) period_phase_ = 0;
    if (++millisecond_phase_ == kClocksPerMillisecond) millisecond_phase_ = 0;
    return;
  }
  Vboard_core& core = *core_->model;
  if (truth_observer_ && millisecond_phase_ == 0) observe(core.drive_enable_o);
  const bool sending = core_->line.sending();
  core.uart_rx_i = core_->line.rx_pin();
  if (sending && ++core_->bits_sent % (10 * kClocksPerBit) == 0) --core_->bytes_on_line;
  const int skipped = clocks_ >= encoder_skip_clock_ ? 1 : 0;  // joint 1's lines inverted
  core.encoder_a_i = world_->encoder_a() ^ skipped;
  core.encoder_b_i = world_->encoder_b() ^ skipped;
  core.home_switch_i = world_->home_switches();
  core_->network_clock.clock(core);
  if (core_->line.sample_tx_pin(core.uart_tx_o)) from_board_.push_back(core_->line.byte());
  world_->step({core.drive_pwm_o, core.drive_dir_o, static_cast<bool>(core.drive_enable_o)});
  ++clocks_;
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
  observed([&] { truth_observer_(truth, *world_); });
}

void VirtualBoard::clock_model() {
  flush_world();
  ModelBoard& board = *core_->board;
  if (truth_observer_ && millisecond_phase_ == 0) observe(board.pins().drive_enable);
  const int skipped = clocks_ >= encoder_skip_clock_ ? 1 : 0;
  board.clock(model_lines_a(*world_, skipped), world_->encoder_b() ^ skipped);
  const ModelBoardPins& pins = board.pins();
  std::uint8_t byte = 0;
  while (board.take_tx_byte(&byte)) from_board_.push_back(byte);
  world_->step({pins.drive_pwm, pins.drive_dir, pins.drive_enable});
  ++clocks_;
}

// The world's runs not yet advanced (consecutive runs of one drive pattern go in one advance).
void VirtualBoard::flush_world() {
  if (world_cycles_ == 0) return;
  world_->advance(world_cycles_, world_pattern_);
  world_cycles_ = 0;
}

// Model fidelity: runs of clocks in which nothing but counters move on either side of the pins
// (ModelBoard::skip, RobotWorld::advance) go at once; a run ends where the board or the world has
// an event (the board's include its serial lines' bytes), or a control period ends (its first
// clock, with the observers, goes one by one). The world takes the runs when the drive pattern
// changes, at its own event, and before anything looks at it.
bool VirtualBoard::skip_model(std::uint64_t limit, std::size_t needed_bytes) {
  Core& core = *core_;
  const std::uint64_t to_world_event = world_->cycles_to_event() - world_cycles_;
  // The observers see the start of each period (1 ms) they watch in clock().
  std::uint64_t clocks = std::min(limit, to_world_event);
  if (period_observer_) clocks = std::min(clocks, kClocksPerTick - period_phase_);
  if (truth_observer_) clocks = std::min(clocks, kClocksPerMillisecond - millisecond_phase_);
  if (needed_bytes != 0) {  // up to the clock the line completes the byte the caller waits for
    const std::uint64_t completes = core.board->tx_byte_cycle(needed_bytes - 1);
    if (completes != ~std::uint64_t{0}) clocks = std::min(clocks, completes - clocks_ + 1);
  }
  if (clocks_ < encoder_skip_clock_) clocks = std::min(clocks, encoder_skip_clock_ - clocks_);
  const int skipped = clocks_ >= encoder_skip_clock_ ? 1 : 0;
  DrivePattern pattern;
  const std::uint64_t taken =
      core.board->skip(clocks, model_lines_a(*world_, skipped), world_->encoder_b() ^ skipped, &pattern);
  if (taken == 0) return false;
  std::uint8_t byte = 0;
  while (core.board->take_tx_byte(&byte)) from_board_.push_back(byte);
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
    if (!core_->board || observed || !skip_model(end - clocks_, needed)) clock();
  }
  if (core_->board) flush_world();
  busy_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() -
             (observer_s_ - observers_before);
}

void VirtualBoard::step(std::uint64_t board_clocks) { run(board_clocks, 0); }

bool VirtualBoard::step_until_byte(std::uint64_t board_clocks, std::size_t bytes) {
  run(board_clocks, std::max<std::size_t>(bytes, 1));
  return !from_board_.empty();
}

BoardPins VirtualBoard::pins() const {
  if (core_->board) {
    const ModelBoardPins& model = core_->board->pins();
    BoardPins pins;
    pins.encoder_error_bits = model.encoder_error;
    pins.joint_limited = model.joint_limited;
    pins.fault_cause_bits = model.fault_cause;
    pins.drive_enable = model.drive_enable;
    return pins;
  }
  const Vboard_core& core = *core_->model;
  BoardPins pins;
  pins.encoder_error_bits = core.encoder_error_o;
  pins.joint_limited = core.joint_limited_o;
  pins.fault_cause_bits = core.joint_fault_cause_o;
  pins.drive_enable = core.drive_enable_o;
  return pins;
}

bool VirtualBoardStream::wait_readable(int timeout_ms, std::size_t bytes) {
  const auto clocks = static_cast<std::uint64_t>(std::max(timeout_ms, 0)) * kClocksPerMillisecond;
  return board_.step_until_byte(std::max<std::uint64_t>(clocks, 1), bytes);
}

}  // namespace delta::cosim
