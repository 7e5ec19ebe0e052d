// The board behind the virtual board's pins, at either fidelity: one interface (the host's bytes
// onto the RX line, the bytes the TX line completed, one clock with the encoder and home-switch
// lines, a run of clocks that only count, the output pins) with two implementations: the
// Verilated board core (virtual_board.cpp) and the model board (model_board.hpp). The virtual
// board (virtual_board.hpp) drives either without asking which.
#pragma once

#include <cstddef>
#include <cstdint>

#include "delta/robot_world.hpp"

namespace delta::cosim {

enum class BoardFidelity { kRtl, kModel };

// The board's output pins: the drives, and the sticky status flags for diagnostics beside the link.
struct BoardPins {
  int drive_pwm = 0;  // bit j: joint j's PWM
  int drive_dir = 0;  // bit j: joint j's direction
  bool drive_enable = false;
  int encoder_error_bits = 0;  // bit j: encoder j skipped a quadrature state
  bool joint_limited = false;  // a joint controller saturated an operand or state
  int fault_cause_bits = 0;    // delta_board_pkg Fault* bits, latched
  int board_fault_bits = 0;    // bit BoardFaultEstopInput, BoardFaultDrive + j: the safety inputs' causes, latched
  bool estop_latched = false;  // the e-stop command latched (telemetry fault byte bit TelemetryEstopBit)
  bool stage_sync = false;     // stage_sync_o: bit StageSyncBit of the periods since reset
};

// The input lines as the board samples them at a clock edge: bit j of each is joint j's.
struct BoardLines {
  int encoder_a = 0;
  int encoder_b = 0;
  int home_switches = 0;
  // The safety inputs (1 = stop): the e-stop chain open, bit j drive j's fault line.
  bool estop_open = false;
  int drive_fault = 0;
};

class BoardModel {
 public:
  virtual ~BoardModel() = default;
  // Host -> board: queued behind what is still on the RX line (8N1, kLinkClocksPerBit clocks a bit).
  virtual void receive(const std::uint8_t* data, std::size_t size) = 0;
  virtual std::size_t bytes_on_line() = 0;  // received and not yet fully on the line
  // One board clock edge.
  virtual void clock(const BoardLines& lines) = 0;
  // The next byte the TX line completed in a clock already run, once.
  virtual bool take_tx_byte(std::uint8_t* byte) = 0;
  virtual BoardPins pins() const = 0;
  // Runs of clocks (a board that can take them, the model board): up to `limit` clocks at once
  // with the lines held, if they only count; returns how many it took (0: clock() the next one) and
  // the drive pins it showed in them. tx_byte_cycle(k): the clock in which the TX line completes the
  // k-th byte not yet taken, ~0 if not yet known.
  virtual bool takes_runs() const { return false; }
  virtual std::uint64_t skip(std::uint64_t /*limit*/, const BoardLines& /*lines*/, DrivePattern* /*pattern*/) {
    return 0;
  }
  virtual std::uint64_t tx_byte_cycle(std::size_t /*k*/) const { return ~std::uint64_t{0}; }
  // The Verilated board: board clocks run without the idle network's edges (rtl::IdleNetworkSkip).
  virtual std::uint64_t idle_network_clocks() const { return 0; }
};

}  // namespace delta::cosim
