// The board at model fidelity: board_core's behaviour in C++ without Verilator, one board clock
// per step with the RTL's event times, for the virtual board (virtual_board.hpp, --fidelity
// model). The small control logic (uart_rx/tx, link_rx with its ring and rescan, the setpoint
// buffer, commands, counters, the model loader, link_tx, quadrature counters, joint_safety,
// joint_pwm) is stepped per clock as a register-level translation; the arithmetic runs once per
// event on the golden models, bit for bit what the RTL computes:
//   the model as data (docs/board_link.md, "The model"): no model at start; model_loader.sv's
//     registers (its bit-serial CRC-32 with link_rx's parser stalled for ModelCrcClocks clocks),
//     the words it writes into the network's memories and the interpolator's play words;
//   network (golden::evaluate_scaled on golden::network_of_model_words of those memories) when a
//     setpoint is played (tick PlayTick = 1 of phase 0),
//   reference interpolation (setpoint_interpolation.hpp's rule) at tick ClocksPerPeriod -
//     InterpolationLeadClocks (2225), joint j's reference written in its step
//     InterpolatorReferenceStep (8 clocks a joint),
//   joint controllers (golden::fixed_update, fixed_rest_state after a period with the drives
//     off) started at tick 1, joint j's PWM duty stored JointControllerLoadCycles +
//     JointControllerJointCycles (j + 1) + 1 clocks later (shown from tick 364 + 355 j;
//     joint_controller.sv's 1072-cycle schedule stores the current a clock before, the model
//     stores both at once); the play shift (interpolation::play_shift) written with each
//     joint's reference update, for the next period.
// Every schedule fact is a board fact (delta/board_facts.hpp, from rtl/board/delta_board_pkg.sv).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "delta/cosim/board_model.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/robot_world.hpp"

namespace delta::cosim {

class ModelBoard final : public BoardModel {
 public:
  // identify_mem: the path of identify.mem (12 lines of one 16-bit hex word). The board starts
  // with no model, as the RTL's: a host loads one over the link (docs/board_link.md, "The model").
  explicit ModelBoard(const std::string& identify_mem);
  ~ModelBoard();
  ModelBoard(const ModelBoard&) = delete;
  ModelBoard& operator=(const ModelBoard&) = delete;

  // The serial line at the RX pin, byte by byte (8N1, kLinkClocksPerBit clocks a bit): the bytes
  // go onto the line behind what it still sends, the first now (before the next clock), and
  // uart_rx hands each to link_rx in the clock the RTL's does.
  void receive(const std::uint8_t* data, std::size_t size) override;
  std::size_t bytes_on_line() override;  // received and not yet fully on the line
  // The line at the TX pin: the next byte it completed in a clock already run (at the stop bit's
  // middle, as rtl::UartLine decodes the pin), once.
  bool take_tx_byte(std::uint8_t* byte) override;
  // The clock in which the line completes the k-th byte not yet taken (k = 0: the next), as far as
  // link_tx has started its frame; ~0 if not yet known. A run of clocks (skip) goes past
  // completions: the caller bounds it where it needs a byte.
  std::uint64_t tx_byte_cycle(std::size_t k) const override;

  // One board clock edge with the encoder lines as the board samples them: bit j of encoder_a and
  // encoder_b joint j's A and B line, bit 3 + j of encoder_a joint j's home switch (board_core's
  // home_switch_i).
  void clock(int encoder_a, int encoder_b);
  void clock(const BoardLines& lines) override {
    set_safety_inputs(lines);
    clock(lines_a(lines), lines.encoder_b);
  }
  BoardPins pins() const override { return pins_; }

  // Up to `limit` clocks at once with the pins held, if they are clocks that only count: the
  // UARTs inside a byte (a run ends at the clock uart_rx hands over a byte, uart_tx's last bit
  // ends or the TX line completes a byte), the tick between the period's events, the controller
  // between its stores, the PWM phase, the synchronisers taking the held pins (the quadrature
  // counters counting a change of the encoder lines; a skipped state ends the run). Returns how
  // many it took (0: none, clock() the next one) and the drive pins it showed in them
  // (`pattern`); the state after them is exactly what as many clock() calls leave.
  std::uint64_t skip(std::uint64_t limit, int encoder_a, int encoder_b, DrivePattern* pattern);
  bool takes_runs() const override { return true; }
  std::uint64_t skip(std::uint64_t limit, const BoardLines& lines, DrivePattern* pattern) override {
    set_safety_inputs(lines);
    return skip(limit, lines_a(lines), lines.encoder_b, pattern);
  }
  // The safety inputs the next clocks sample (board_core's estop_open_i, drive_fault_i; 1 = stop),
  // held until set again.
  void set_safety_inputs(bool estop_open, int drive_fault);
  void set_safety_inputs(const BoardLines& lines) { set_safety_inputs(lines.estop_open, lines.drive_fault); }

  // The run check (tests): every skip() runs its clocks again as full clocks from the same state
  // and throws std::logic_error naming the first register, block RAM, drive pin or line byte that
  // differs (the quiet runs and micro clocks must be exactly the full clocks they stand for).
  void check_runs(bool on) { check_runs_ = on; }

  // Test probe (tests/rtl/test_model_board_modules.cpp), read-only: the registers of one of
  // board_core's module instances as this model holds them now, each under the RTL's name inside
  // that instance (`instance`: "board_core" for board_core's own registers, else the instance name,
  // e.g. "u_link_rx"; a register of a sub-instance with its path, "u_safety.check_q"; array element
  // k as "name[k]"), the value as the RTL's bits (two's complement within the register's width).
  // Where the model keeps a register in another form, the RTL's is derived from it (the
  // interpolator's rotating r_q, d_q: by joint_q; the packed duties); a register the model does
  // not hold in every clock is listed only in the clocks it holds it (uart_rx's shift_q with
  // valid_q, link_rx's ring_data_q while fetched_q). Throws std::invalid_argument for an unknown
  // instance.
  struct ProbedRegister {
    std::string name;
    std::uint64_t value;
  };
  std::vector<ProbedRegister> probe_registers(const std::string& instance) const;
  // Test probe, read-only: a block RAM's words by address, as the RTL's memory holds them:
  // "u_link_rx.ring_q" (bytes), "u_setpoints.ram_q" (entry e's 16-bit lane w at 6 e + w),
  // "u_link_tx.words"; the model's (every word of a load at its frame number in each of the
  // network's, in its width): "u_network.u_weight1_ram.words" (IW'), "u_network.u_bias1_ram.words"
  // (b1'), "u_network.u_weight2_ram.words" (LW'), "u_network.u_bias2_ram.words" (b2' + 2^19), and
  // "u_interpolator.play_words" (4 words, the fourth never written).
  std::vector<std::uint64_t> probe_memory(const std::string& memory) const;
  // The clocks run since reset (the model's cycle).
  std::uint64_t cycle() const;

 private:
  // The A lines carry the home switches above the three encoder lines.
  static int lines_a(const BoardLines& lines) { return lines.encoder_a | (lines.home_switches << 3); }
  bool safety_settled() const;  // the safety synchroniser holds safety_in_
  int safety_in_ = 0;
  struct State;
  std::uint64_t skip_run(std::uint64_t limit, int encoder_a, int encoder_b, DrivePattern* pattern);
  static const char* differing_register(const State& a, const State& b);
  void settle();
  bool quiet() const;
  bool quiet_clock(int encoder_a, int encoder_b);
  std::uint64_t quiet_run(std::uint64_t limit, int encoder_a, int encoder_b);
  void count_clock(int encoder_a, int encoder_b);
  struct MicroClock;
  bool micro_clock(int encoder_a, int encoder_b, std::uint64_t lines_hold);
  bool plan_micro_clock(int encoder_a, int encoder_b, std::uint64_t lines_hold, MicroClock& c) const;
  void micro_link_rx(const MicroClock& c);
  void micro_interpolator(const MicroClock& c);
  static std::uint16_t telemetry_word_of(const State& s);
  void start_frame(State& n, std::uint64_t start);

  // The full clock by module, in board_core's order: each module's next values in n from the
  // present ones in s and the wires the modules before it set this clock (board_core's nets).
  struct Wires;
  void uart_rx_next(const State& s, State& n);
  void link_rx_next(const State& s, State& n, Wires& w);
  static void commands_next(const State& s, State& n, Wires& w);
  void board_inputs_next(const State& s, State& n, const Wires& w) const;
  static void schedule_next(const State& s, State& n, Wires& w);
  void setpoint_buffer_next(const State& s, State& n, Wires& w);
  void interpolator_next(const State& s, State& n, const Wires& w) const;
  static void encoders_next(const State& s, State& n, int encoder_a, int encoder_b, Wires& w);
  static void joint_controller_next(const State& s, State& n);
  static void joint_safety_next(const State& s, State& n, const Wires& w);
  static void joint_pwm_next(const State& s, State& n);
  static void counters_next(const State& s, State& n, const Wires& w);
  void link_tx_next(const State& s, State& n, const Wires& w);
  void telemetry_capture_next(const State& s, State& n, std::uint16_t word, bool snapshot, bool sending_telemetry);
  void setpoint_payload_next(const State& s, State& n, bool frame_start, bool payload_valid, int payload_index,
                             std::uint8_t byte);
  static void model_payload_next(const State& s, State& n, bool payload_valid, int payload_index, std::uint8_t byte);
  void model_loader_next(const State& s, State& n, Wires& w);
  void patch_identify_crc(const State& s, const State& n);

  struct Memories;
  // The network the model memories hold (golden::network_of_model_words), rebuilt at a play after
  // a load wrote them.
  golden::QuantisedNetwork network_;
  bool network_stale_ = true;
  std::unique_ptr<Memories> memories_;
  std::unique_ptr<State> state_;
  std::unique_ptr<State> next_state_;  // clock()'s next values
  BoardPins pins_;
  bool check_runs_ = false;
  bool checking_ = false;  // replaying a run as full clocks
  // The RX line: each byte with the clock in which uart_rx sets valid; when each leaves the line.
  struct RxByte {
    std::uint64_t valid_cycle;
    std::uint8_t byte;
  };
  std::deque<RxByte> rx_line_;
  std::deque<std::uint64_t> line_end_;
  std::uint64_t line_free_cycle_ = 0;
  // The TX line: the bytes of the frames link_tx sends and the clock in which the line completes each.
  struct TxByte {
    std::uint64_t cycle;
    std::uint8_t byte;
  };
  std::deque<TxByte> tx_line_;
  // The identify reply link_tx sends or sent last, and the clock it handed uart_tx its first byte.
  std::vector<std::uint8_t> identify_frame_;
  std::uint64_t identify_first_load_ = 0;
};

}  // namespace delta::cosim
