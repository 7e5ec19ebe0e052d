// The virtual board at RTL fidelity: the Verilated board core as built for the iCEBreaker (link v2
// at 23 board clocks per bit, 2325 board clocks per 10 kHz control period, the network on its own
// clock at twice the board's) in closed loop with the robot world (sim/robot_world.hpp: PWM
// averaging, three joint plants, the virtual robot's sensor effects, quadrature encoders, the
// plate), behind a serial line: bytes from the host go onto the board's RX pin at the board's bit
// timing, the bytes on its TX pin come back. Time is simulated and advances only when asked.
//
//   host bytes -> UART line (8N1, 23 clocks/bit) -> board_core (RTL) -> PWM + direction + enable
//     -> robot world (currents, plants, sensors) -> quadrature A/B -> board_core -> UART line -> bytes
//
// One board clock (43 ns) is one step: both clocks in their true ratio (rtl/board/sim
// board_clock.hpp), the world's plants solved once per control period (35 clocks before it). The truth (true joint
// angles, the plate as the measuring stage sees it, drive enable) is offered every 1 ms of board
// time to an observer. VirtualBoardStream makes it an io::ByteStream for a host in the same
// process (the co-simulation); `deltactl virtual-board` puts it behind a pseudo-terminal.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/cosim/board_model.hpp"
#include "delta/effects.hpp"
#include "delta/geometry.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/io/byte_stream.hpp"
#include "delta/joint_plant.hpp"
#include "delta/robot_world.hpp"

namespace delta::cosim {

constexpr double kBoardClockHz = static_cast<double>(board::kBoardClockHz);
constexpr int kClocksPerBit = static_cast<int>(board::kLinkClocksPerBit);
constexpr std::uint64_t kClocksPerTick = static_cast<std::uint64_t>(board::kClocksPerPeriod);  // 100 us
constexpr std::uint64_t kClocksPerMillisecond = kClocksPerTick * board::kPeriodsPerSetpoint;
constexpr int kHomeCount = static_cast<int>(board::kHomeCount);
constexpr double kCurrentFullScaleA = board::kCurrentFullScaleMilliamp / 1000.0;

// BoardFidelity (board_model.hpp) rtl: the Verilated board core; model: the same board in C++
// (model_board.hpp), bit-exact at its pins.

// A safety input of the board (board_core's estop_open_i, drive_fault_i) at its stop level over a
// window of board time: from from_s until until_s (infinite: to the end).
struct SafetyInputWindow {
  int input = 0;  // 0: the e-stop chain open; 1..3: drive j's fault line (joint j - 1)
  double from_s = 0.0;
  double until_s = std::numeric_limits<double>::infinity();
};

struct VirtualBoardOptions {
  BoardFidelity fidelity = BoardFidelity::kRtl;
  // The model the board holds when the host starts: at start, before any host byte, its load
  // (golden::model_frames, docs/board_link.md "The model") goes onto the board's RX line as
  // `deltactl host load` sends it, and the board runs until it has taken it (an identify confirms
  // the CRC; the bytes the board sent meanwhile are dropped, as nobody read them). nullptr: the
  // board starts with no model, as after power-up.
  const golden::QuantisedNetwork* network = nullptr;
  std::string mem_dir;  // the gateware's .mem files and identify.mem (golden::write_export)
  EffectSet effects;    // the virtual robot
  Geometry nominal = Geometry::nominal();
  JointPlantParameters plant;
  // From this board time on, joint 1's encoder lines A and B are both inverted: the board sees its
  // quadrature state jump by two (a skipped state, fault cause 0) once, then counts on, 2 counts
  // off. Negative: never (a test's fault injection).
  double inject_encoder_skip_at_s = -1.0;
  // RTL fidelity: board clocks in which the network is idle and provably stays so go without its
  // clock's edges, and a rising edge is one evaluation (rtl::IdleNetworkSkip; the same board, about
  // 2 x as fast). False: rtl::clock_board, every edge of both clocks evaluated.
  bool skip_idle_network = true;
  // Model fidelity: check every run of clocks the model board takes at once against as many full
  // clocks (ModelBoard::check_runs; tests, about 50 x slower).
  bool check_model_runs = false;
  // A measuring stage that drags the plate (RobotWorld::set_drag; measuring_stage.hpp); empty: none.
  RobotWorld::Drag drag;
  // The true shaft angles [deg] the arms rest at when the board starts (RobotWorld::place_arms);
  // empty: the home pose (the encoders read the home count there).
  std::optional<Vec3> start_true_alpha_deg;
  // Fault injection (0-based joint, -1: none): an arm that never moves, a home switch that never closes.
  int inject_seized_joint = -1;
  int inject_missing_home_switch = -1;
  // Joint inject_slip_joint's encoder silently gains inject_slip_counts at board time
  // inject_slip_at_s (RobotWorld::slip_encoder); -1: none.
  int inject_slip_joint = -1;
  int inject_slip_counts = 0;
  double inject_slip_at_s = 0.0;
  // The board's safety inputs at the stop level over these windows (`--estop-open-at`,
  // `--drive-fault-at`). A drive in fault also stops its torque from the window's start (its motor's
  // current zero, as a real drive's output stage turns off), whatever the board's pins.
  std::vector<SafetyInputWindow> safety_inputs;
};

// Whether this build's Verilated board core has the safety input ports (estop_open_i,
// drive_fault_i): the RTL fidelity applies SafetyInputWindow only then.
bool rtl_board_has_safety_inputs();

// What the world is, every 1 ms of board time (ground truth: no sensor saw it).
struct TruthSample {
  double t_s = 0.0;                    // board time since reset
  Vec3 position_m = Vec3::Zero();      // plate centre as the measuring stage sees it (frame misalignment applied)
  Vec3 true_alpha_deg = Vec3::Zero();  // plant angles
  Vec3 encoder_deg = Vec3::Zero();     // what the encoder lines show (0.01 deg counts)
  Vec3 current_a = Vec3::Zero();       // drive currents (PWM averaged)
  bool drives_enabled = false;         // the board's drive enable pin
  bool estop_open = false;             // the board's e-stop input at the stop level (the chain open)
  int drive_fault = 0;                 // bit j: drive j's fault line at the stop level
};

class VirtualBoard {
 public:
  // Reads identify.mem (and the RTL's tables) from options.mem_dir (through the model's plusarg
  // +delta_mem_dir), resets the board, places the robot at rest where the encoders read the home
  // count, loads options.network if given. Throws std::invalid_argument if the robot has no such
  // pose, std::runtime_error if the board did not take the model.
  explicit VirtualBoard(const VirtualBoardOptions& options);
  ~VirtualBoard();
  VirtualBoard(const VirtualBoard&) = delete;
  VirtualBoard& operator=(const VirtualBoard&) = delete;

  // Host -> board: queued behind what is still on the line (10 bits of 23 board clocks a byte).
  void write(const std::uint8_t* data, std::size_t size);
  std::size_t bytes_to_board() const;  // queued or on the line
  // Board -> host: bytes the line has received so far, oldest first.
  std::size_t read(std::uint8_t* data, std::size_t capacity);
  std::size_t bytes_from_board() const { return from_board_.size(); }

  void step(std::uint64_t board_clocks);
  // Steps until `bytes` bytes from the board are waiting (at least one) or `board_clocks` have
  // passed; true if one is.
  bool step_until_byte(std::uint64_t board_clocks, std::size_t bytes = 1);
  std::uint64_t clocks() const { return clocks_; }
  std::uint64_t idle_network_clocks() const { return board_->idle_network_clocks(); }
  // Wall time spent advancing the board and the world (step, step_until_byte), the observers'
  // calls excluded: the board's own speed inside a co-simulation [s].
  double busy_s() const { return busy_s_; }
  double time_s() const { return static_cast<double>(clocks_) / kBoardClockHz; }

  // Called at every 1 ms of board time (t = 0, 1 ms, ...) with the truth and the world.
  using TruthObserver = std::function<void(const TruthSample&, const RobotWorld&)>;
  void observe_truth(TruthObserver observer) { truth_observer_ = std::move(observer); }

  // Called at the start of every control period of board time (t = 0, 100 us, ...) with the board's
  // clock count, its pins and the world.
  using PeriodObserver = std::function<void(std::uint64_t clocks, const BoardPins&, const RobotWorld&)>;
  void observe_periods(PeriodObserver observer) { period_observer_ = std::move(observer); }

  const RobotWorld& world() const;
  BoardPins pins() const { return board_->pins(); }

 private:
  void clock();
  BoardLines lines() const;  // the world's encoder and home-switch lines (an injected skip applied)
  void take_bytes();
  bool skip_run(std::uint64_t limit, std::size_t needed_bytes);
  void flush_world();
  void run(std::uint64_t board_clocks, std::size_t until_bytes);  // until_bytes 0: all board_clocks
  void observe(bool drives_enabled);
  int safety_inputs_at(std::uint64_t clock) const;  // bit 0: the e-stop chain open, bit j + 1: drive j's fault
  std::uint64_t next_safety_change(std::uint64_t clock) const;  // the first clock after `clock` they change in
  void load_at_start(const golden::QuantisedNetwork& network);
  // Calls an observer, its wall time counted in observer_s_ (not the board's).
  template <typename Call>
  void observed(Call&& call) {
    const auto start = std::chrono::steady_clock::now();
    call();
    observer_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  std::unique_ptr<BoardModel> board_;  // the Verilated board core or the model board
  std::unique_ptr<RobotWorld> world_;
  std::deque<std::uint8_t> from_board_;
  TruthObserver truth_observer_;
  PeriodObserver period_observer_;
  std::uint64_t clocks_ = 0;
  std::uint64_t period_phase_ = 0;       // clocks_ mod kClocksPerTick
  std::uint64_t millisecond_phase_ = 0;  // clocks_ mod kClocksPerMillisecond
  std::uint64_t encoder_skip_clock_ = ~std::uint64_t{0};
  struct SafetyClocks {
    int bit;  // in safety_inputs_at's word
    std::uint64_t from, until;
  };
  std::vector<SafetyClocks> safety_windows_;
  int safety_now_ = 0;  // safety_inputs_at(clocks_)
  double busy_s_ = 0.0;
  double observer_s_ = 0.0;         // (inside runs, taken out of busy_s_)
  DrivePattern world_pattern_;      // a board that takes runs: the drive pattern of the runs the world has not taken
  std::uint64_t world_cycles_ = 0;  // (their cycles)
};

// The virtual board as a byte stream for a host in the same process: write_all queues onto the
// line, read_some takes what the board sent, and wait_readable advances the board (its timeout is
// board time). No descriptor: fd() is -1.
class VirtualBoardStream : public io::ByteStream {
 public:
  explicit VirtualBoardStream(VirtualBoard& board, std::string name = "virtual board")
      : board_(board), name_(std::move(name)) {}
  std::size_t read_some(std::uint8_t* data, std::size_t capacity) override { return board_.read(data, capacity); }
  void write_all(const std::uint8_t* data, std::size_t size, int /*timeout_ms*/) override { board_.write(data, size); }
  bool wait_readable(int timeout_ms) override { return wait_readable(timeout_ms, 1); }
  bool wait_readable(int timeout_ms, std::size_t bytes) override;
  int fd() const override { return -1; }
  const std::string& name() const override { return name_; }

 private:
  VirtualBoard& board_;
  std::string name_;
};

}  // namespace delta::cosim
