// The model board (host/cosim/include/delta/cosim/model_board.hpp) module by module: the model and
// the Verilated board core with its registers readable (Vboard_core_probe, rtl/board_core_probe.vlt)
// run in lockstep from reset with the same pins (the RX line at kLinkClocksPerBit clocks a bit, the
// encoder lines, the home switches), and after every clock the registers of the module under test
// must be equal in both: the model's (ModelBoard::probe_registers, probe_memory) against the same
// instance's inside board_core. One test per module, each with random stimulus aimed at it; the
// model runs its full clocks (check_runs: every run it takes is replayed as full clocks, compared).
// A divergence names the module, the register, the clock and the seed (DELTA_TEST_SEED replays it).
#include <gtest/gtest.h>

#include <Vboard_core_probe.h>
#include <Vboard_core_probe___024root.h>
#include <verilated.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/cosim/model_board.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/rtl/board_clock.hpp"
#include "delta/rtl/uart_line.hpp"
#include "rtl_fixture.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

using Root = Vboard_core_probe___024root;
using Reader = std::function<std::uint64_t(const Root&)>;

constexpr int kClocksPerBit = static_cast<int>(board::kLinkClocksPerBit);
constexpr std::uint64_t kPeriod = static_cast<std::uint64_t>(board::kClocksPerPeriod);
constexpr std::uint64_t kByteClocks = 10 * static_cast<std::uint64_t>(kClocksPerBit);
constexpr int kDeltaStep = static_cast<int>(board::kInterpolatorDeltaStep);
constexpr int kShiftBits = golden::kShiftBits;  // delta_joint_pkg::ShiftBits
// Ticks 0 .. kDenseTicks - 1 of every period are compared in full in a long run's sparse
// comparison (Lockstep::set_register_stride): the safety inputs' samples, the play, a jog's count.
constexpr int kDenseTicks = 4;
static_assert(board::kPlayTick + 1 < kDenseTicks, "the play's clocks are compared in full");

// The deployed model (its backlash compensation runs in the interpolators).
const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";

std::uint64_t test_seed() {
  static const std::uint64_t seed = [] {
    const char* env = std::getenv("DELTA_TEST_SEED");
    const std::uint64_t s = env != nullptr ? std::strtoull(env, nullptr, 0) : std::random_device{}();
    return s;
  }();
  return seed;
}

std::uint64_t wide_bits(const VlWide<3>& w, int low, int width) {
  std::uint64_t value = 0;
  for (int b = 0; b < width; ++b)
    value |= static_cast<std::uint64_t>((w[(low + b) / 32] >> ((low + b) % 32)) & 1u) << b;
  return value;
}

// The RTL's register of each name the model's probe lists ("instance.name").
std::unordered_map<std::string, Reader> rtl_registers() {
  std::unordered_map<std::string, Reader> r;
#define DELTA_BC(name) \
  r["board_core." #name] = [](const Root& x) -> std::uint64_t { return x.board_core__DOT__##name; };
  DELTA_BC(command_q)
  DELTA_BC(enabled_q)
  DELTA_BC(holding_q)
  DELTA_BC(homed_q)
  DELTA_BC(homing_q)
  DELTA_BC(referenced_q)
  DELTA_BC(switch_meta_q)
  DELTA_BC(switch_q)
  DELTA_BC(switch_previous_q)
  DELTA_BC(encoder_a_meta_q)
  DELTA_BC(encoder_a_q)
  DELTA_BC(encoder_b_meta_q)
  DELTA_BC(encoder_b_q)
  DELTA_BC(phase_q)
  DELTA_BC(period_count_q)
  DELTA_BC(bad_frames_q)
  DELTA_BC(underruns_q)
  DELTA_BC(slew_limits_q)
  DELTA_BC(refused_q)
  DELTA_BC(last_sequence_q)
  DELTA_BC(word_index_q)
  DELTA_BC(estop_q)
  DELTA_BC(jog_q)
  DELTA_BC(jog_was_q)
  DELTA_BC(jog_joint_q)
  DELTA_BC(jog_negative_q)
  DELTA_BC(jog_left_q)
#undef DELTA_BC
  for (int j = 0; j < 3; ++j) {
    const std::string k = std::to_string(j);
    r["board_core.net_outputs[" + k + "]"] = [j](const Root& x) {
      return wide_bits(x.board_core__DOT__net_outputs, 24 * j, 24);
    };
  }
#define DELTA_M(inst, prefix, name) \
  r[inst "." #name] = [](const Root& x) -> std::uint64_t { return x.board_core__DOT__##prefix##__DOT__##name; };
  DELTA_M("u_uart_rx", u_uart_rx, valid_q)
  DELTA_M("u_uart_rx", u_uart_rx, shift_q)
  DELTA_M("u_link_rx", u_link_rx, write_q)
  DELTA_M("u_link_rx", u_link_rx, read_q)
  DELTA_M("u_link_rx", u_link_rx, start_q)
  DELTA_M("u_link_rx", u_link_rx, index_q)
  DELTA_M("u_link_rx", u_link_rx, end_q)
  DELTA_M("u_link_rx", u_link_rx, fetched_q)
  DELTA_M("u_link_rx", u_link_rx, crc_high_ok_q)
  DELTA_M("u_link_rx", u_link_rx, length_q)
  DELTA_M("u_link_rx", u_link_rx, type_q)
  DELTA_M("u_link_rx", u_link_rx, sequence_q)
  DELTA_M("u_link_rx", u_link_rx, ring_data_q)
  r["u_link_rx.u_crc.crc_q"] = [](const Root& x) -> std::uint64_t {
    return x.board_core__DOT__u_link_rx__DOT__u_crc__DOT__crc_q;
  };
  DELTA_M("u_setpoints", u_setpoints, sample_index_q)
  DELTA_M("u_setpoints", u_setpoints, fill_q)
  DELTA_M("u_setpoints", u_setpoints, full_at_start_q)
  DELTA_M("u_setpoints", u_setpoints, index_match_q)
  DELTA_M("u_setpoints", u_setpoints, vetoed_q)
  DELTA_M("u_setpoints", u_setpoints, starting_q)
  DELTA_M("u_interpolator", u_interpolator, busy_q)
  DELTA_M("u_interpolator", u_interpolator, step_q)
  DELTA_M("u_interpolator", u_interpolator, joint_q)
  DELTA_M("u_interpolator", u_interpolator, answer_pending_q)
  DELTA_M("u_interpolator", u_interpolator, answered_q)
  DELTA_M("u_interpolator", u_interpolator, slew_limited_o)
  r["u_interpolator.delta_q"] = [](const Root& x) -> std::uint64_t {
    return x.board_core__DOT__u_interpolator__DOT__delta_q & 0xFFFFu;
  };
  for (int i = 0; i < 3; ++i) {
    const std::string k = std::to_string(i);
    r["u_interpolator.r_q[" + k + "]"] = [i](const Root& x) -> std::uint64_t {
      return x.board_core__DOT__u_interpolator__DOT__r_q[i];
    };
    r["u_interpolator.d_q[" + k + "]"] = [i](const Root& x) -> std::uint64_t {
      return x.board_core__DOT__u_interpolator__DOT__d_q[i] & 0xFFFFu;
    };
  }
  DELTA_M("u_joint_axes", u_joint_axes, tick_q)
  DELTA_M("u_joint_axes", u_joint_axes, start_q)
  DELTA_M("u_joint_axes", u_joint_axes, encoder_error_q)
#undef DELTA_M
  for (int j = 0; j < 3; ++j) {
    const std::string k = std::to_string(j);
    r["u_joint_axes.counts_q[" + k + "]"] = [j](const Root& x) -> std::uint64_t {
      return (x.board_core__DOT__u_joint_axes__DOT__counts_q >> (16 * j)) & 0xFFFFu;
    };
    r["u_joint_axes.u_controller.current_q[" + k + "]"] = [j](const Root& x) -> std::uint64_t {
      return (x.board_core__DOT__u_joint_axes__DOT__u_controller__DOT__current_q >> (16 * j)) & 0xFFFFu;
    };
  }
#define DELTA_Q(j, name)                                                                                    \
  r["u_joint_axes.g_encoder[" #j "].u_counter." #name] = [](const Root& x) -> std::uint64_t {               \
    return x.board_core__DOT__u_joint_axes__DOT__g_encoder__BRA__##j##__KET____DOT__u_counter__DOT__##name; \
  };
#define DELTA_QJ(j) DELTA_Q(j, previous_q) DELTA_Q(j, count_q) DELTA_Q(j, error_q) DELTA_Q(j, rising_q)
  DELTA_QJ(0)
  DELTA_QJ(1)
  DELTA_QJ(2)
#undef DELTA_QJ
#undef DELTA_Q
#define DELTA_S(j)                                                                                              \
  r["u_joint_axes.u_safety.g_check[" #j "].difference_q"] = [](const Root& x) -> std::uint64_t {                \
    return x.board_core__DOT__u_joint_axes__DOT__u_safety__DOT__g_check__BRA__##j##__KET____DOT__difference_q & \
           0x1FFFFu;                                                                                            \
  };                                                                                                            \
  r["u_joint_axes.u_safety.g_check[" #j "].outside_q"] = [](const Root& x) -> std::uint64_t {                   \
    return x.board_core__DOT__u_joint_axes__DOT__u_safety__DOT__g_check__BRA__##j##__KET____DOT__outside_q;     \
  };
  DELTA_S(0)
  DELTA_S(1)
  DELTA_S(2)
#undef DELTA_S
#define DELTA_JA(sub, name)                                                \
  r["u_joint_axes." #sub "." #name] = [](const Root& x) -> std::uint64_t { \
    return x.board_core__DOT__u_joint_axes__DOT__##sub##__DOT__##name;     \
  };
  DELTA_JA(u_safety, silent_periods_q)
  DELTA_JA(u_safety, check_q)
  DELTA_JA(u_safety, checked_q)
  DELTA_JA(u_safety, fault_cause_q)
  DELTA_JA(u_safety, active_q)
  DELTA_JA(u_pwm, pwm_remaining_q)
  DELTA_JA(u_pwm, duty_q)
  DELTA_JA(u_pwm, direction_q)
  DELTA_JA(u_pwm, pwm_q)
  DELTA_JA(u_pwm, enable_q)
  DELTA_JA(u_pwm, dir_q)
  DELTA_JA(u_controller, primed_q)
  DELTA_JA(u_controller, overflow_q)
#undef DELTA_JA
  r["u_joint_axes.u_controller.ap_idle"] = [](const Root& x) -> std::uint64_t {
    return x.board_core__DOT__u_joint_axes__DOT__ap_idle;
  };
  r["u_joint_axes.peek_data_o"] = [](const Root& x) -> std::uint64_t { return x.board_core__DOT__peek_data; };
#define DELTA_TX(name) \
  r["u_link_tx." #name] = [](const Root& x) -> std::uint64_t { return x.board_core__DOT__u_link_tx__DOT__##name; };
  DELTA_TX(capturing_q)
  DELTA_TX(writing_q)
  DELTA_TX(telemetry_pending_q)
  DELTA_TX(capture_q)
  DELTA_TX(written_q)
  DELTA_TX(identify_pending_q)
  DELTA_TX(identify_sequence_q)
  DELTA_TX(telemetry_sequence_q)
  DELTA_TX(is_identify_q)
  DELTA_TX(length_q)
  DELTA_TX(sequence_q)
  DELTA_TX(state_q)
#undef DELTA_TX
#define DELTA_SI(name)                                               \
  r["u_safety_inputs." #name] = [](const Root& x) -> std::uint64_t { \
    return x.board_core__DOT__u_safety_inputs__DOT__##name;          \
  };
  DELTA_SI(meta_q)
  DELTA_SI(sync_q)
  DELTA_SI(history_q)
  DELTA_SI(cause_q)
#undef DELTA_SI
#define DELTA_ML(name)                                              \
  r["u_model_loader." #name] = [](const Root& x) -> std::uint64_t { \
    return x.board_core__DOT__u_model_loader__DOT__##name;          \
  };
  DELTA_ML(word_q)
  DELTA_ML(number_q)
  DELTA_ML(number_high_q)
  DELTA_ML(expected_q)
  DELTA_ML(loading_q)
  DELTA_ML(loaded_q)
  DELTA_ML(crc_q)
  DELTA_ML(restart_q)
  DELTA_ML(shift_count_q)
#undef DELTA_ML
  return r;
}

// The model's memories (the network's model port: 256 words each, the interpolator's play words).
constexpr int kModelMemoryWords = 256;
const std::vector<std::string> kModelMemories = {"u_network.u_weight1_ram.words", "u_network.u_bias1_ram.words",
                                                 "u_network.u_weight2_ram.words", "u_network.u_bias2_ram.words",
                                                 "u_interpolator.play_words"};

std::vector<std::uint64_t> rtl_memory(const Root& x, const std::string& memory) {
  std::vector<std::uint64_t> out;
  if (memory == "u_link_rx.ring_q") {
    for (int i = 0; i < board::kRxRingBytes; ++i) out.push_back(x.board_core__DOT__u_link_rx__DOT__ring_q[i]);
  } else if (memory == "u_link_tx.words") {
    for (int i = 0; i < board::kLinkTxWords; ++i) out.push_back(x.board_core__DOT__u_link_tx__DOT__words[i]);
  } else if (memory == "u_setpoints.ram_q") {
    for (int e = 0; e < board::kSetpointDepth; ++e) {
      out.push_back(x.board_core__DOT__u_setpoints__DOT__g_ram__BRA__0__KET____DOT__ram_q[e]);
      out.push_back(x.board_core__DOT__u_setpoints__DOT__g_ram__BRA__1__KET____DOT__ram_q[e]);
      out.push_back(x.board_core__DOT__u_setpoints__DOT__g_ram__BRA__2__KET____DOT__ram_q[e]);
    }
  } else if (memory == "u_network.u_weight1_ram.words") {
    const auto& words = x.board_core__DOT__u_network__DOT__g_layer1_lane__BRA__0__KET____DOT__u_weight1_ram__DOT__words;
    for (int i = 0; i < kModelMemoryWords; ++i) out.push_back(words[i]);
  } else if (memory == "u_network.u_bias1_ram.words") {
    const auto& words = x.board_core__DOT__u_network__DOT__u_bias1_ram__DOT__words;
    for (int i = 0; i < kModelMemoryWords; ++i) out.push_back(words[i]);
  } else if (memory == "u_network.u_weight2_ram.words") {
    const auto& words = x.board_core__DOT__u_network__DOT__g_layer2_lane__BRA__0__KET____DOT__u_weight2_ram__DOT__words;
    for (int i = 0; i < kModelMemoryWords; ++i) out.push_back(words[i]);
  } else if (memory == "u_network.u_bias2_ram.words") {
    const auto& words = x.board_core__DOT__u_network__DOT__g_layer2_lane__BRA__0__KET____DOT__u_bias2_ram__DOT__words;
    for (int i = 0; i < kModelMemoryWords; ++i) out.push_back(words[i]);
  } else if (memory == "u_interpolator.play_words") {
    for (int i = 0; i < 4; ++i) out.push_back(x.board_core__DOT__u_interpolator__DOT__play_words[i]);
  }
  return out;
}

// The model board and the probed RTL board in lockstep from reset: the same pins every clock,
// the chosen modules' registers (and block RAMs) compared after every clock.
class Lockstep {
 public:
  Lockstep(const golden::QuantisedNetwork& q, const std::string& mem_dir, std::vector<std::string> instances,
           std::vector<std::string> memories)
      : context_(std::make_unique<VerilatedContext>()),
        model_(mem_dir + "/identify.mem"),
        line_(kClocksPerBit),
        readers_(rtl_registers()),
        instances_(std::move(instances)),
        memories_(std::move(memories)) {
    const std::string plusarg = "+delta_mem_dir=" + mem_dir;
    const char* argv[] = {"model_board_modules", plusarg.c_str()};
    context_->commandArgs(2, argv);
    core_ = std::make_unique<Vboard_core_probe>(context_.get(), "board");
    rtl::reset_board(*core_);
    model_.check_runs(true);
    compare();  // the reset values
  }
  ~Lockstep() { core_->final(); }

  // Bytes onto the RX line behind what it still sends (both boards).
  void send(const std::vector<std::uint8_t>& bytes) {
    line_.send(bytes);
    model_.receive(bytes.data(), bytes.size());
  }
  bool line_busy() const { return line_.sending(); }

  // One board clock with these encoder lines and home switches; false once a register differed.
  bool clock(int encoder_a, int encoder_b, int home_switches) {
    if (failed_) return false;
    Vboard_core_probe& core = *core_;
    const Root& root = *core.rootp;
    // Before the edge: the interpolator's shift write and the network's answer (see compare()).
    const bool shift_write = root.board_core__DOT__shift_write;
    const int shift_joint = root.board_core__DOT__shift_joint;
    const std::uint64_t shift_value = root.board_core__DOT__shift & ((1u << kShiftBits) - 1);
    const bool answer = root.board_core__DOT__net_done;
    const bool rtl_idle_before = root.board_core__DOT__u_joint_axes__DOT__ap_idle;
    interpolating_before_ = root.board_core__DOT__u_interpolator__DOT__busy_q;

    core.uart_rx_i = line_.rx_pin();
    core.encoder_a_i = encoder_a & 7;
    core.encoder_b_i = encoder_b & 7;
    core.home_switch_i = home_switches & 7;
    core.estop_open_i = estop_open_ ? 1 : 0;
    core.drive_fault_i = drive_fault_ & 7;
    network_clock_.clock(core);
    // (a play is at tick PlayTick: in a long run's sparse clocks the index is read only near it)
    const bool track_plays = register_stride_ <= 1 || tick() < kDenseTicks;
    const std::uint32_t index_before = track_plays ? model_sample_index() : 0;
    try {
      model_.set_safety_inputs(estop_open_, drive_fault_);
      model_.clock(encoder_a | (home_switches << 3), encoder_b);
    } catch (const std::logic_error& e) {
      fail_with(std::string("the model's run check: ") + e.what());
      return false;
    }
    ++clocks_;
    if (track_plays && model_sample_index() != index_before)
      answer_in_flight_ = true;  // a setpoint played: the network runs
    if (answer) answer_in_flight_ = false;
    if (shift_write) written_shift_[shift_joint & 3] = shift_value, shift_known_[shift_joint & 3] = true;
    rtl_idle_before_ = rtl_idle_before;
    interpolating_ = root.board_core__DOT__u_interpolator__DOT__busy_q;

    // The TX line: the same bytes in the same clocks.
    if (line_.sample_tx_pin(core.uart_tx_o)) rtl_tx_.push_back({clocks_, line_.byte()});
    std::uint8_t byte = 0;
    while (model_.take_tx_byte(&byte)) model_tx_.push_back({clocks_, byte});
    while (!rtl_tx_.empty() && !model_tx_.empty()) {
      if (rtl_tx_.front() != model_tx_.front()) {
        std::ostringstream what;
        what << "TX line: RTL byte 0x" << std::hex << int(rtl_tx_.front().second) << std::dec << " in clock "
             << rtl_tx_.front().first << ", model 0x" << std::hex << int(model_tx_.front().second) << std::dec
             << " in clock " << model_tx_.front().first;
        fail_with(what.str());
        return false;
      }
      ++tx_bytes_;
      rtl_tx_.erase(rtl_tx_.begin());
      model_tx_.erase(model_tx_.begin());
    }
    if (rtl_tx_.size() > 1 || model_tx_.size() > 1) {
      fail_with("TX line: one board sent a byte the other did not");
      return false;
    }
    compare_pins();
    if (!failed_ && (register_stride_ <= 1 || clocks_ % register_stride_ == 0 || tick() < kDenseTicks)) compare();
    return !failed_;
  }

  // The safety inputs both boards sample from the next clock on (1 = stop), held until set again.
  void set_safety_inputs(bool estop_open, int drive_fault) { estop_open_ = estop_open, drive_fault_ = drive_fault; }
  // Registers compared every clock (1), else only every `stride`-th clock and at ticks below kDenseTicks (the
  // output pins and the TX line are still compared every clock): for long runs.
  void set_register_stride(std::uint64_t stride) { register_stride_ = stride; }

  cosim::ModelBoard& model() { return model_; }
  const Root& rtl() const { return *core_->rootp; }
  std::uint64_t clocks() const { return clocks_; }
  std::uint64_t tx_bytes() const { return tx_bytes_; }
  bool failed() const { return failed_; }
  // Register clocks in which joint_safety's pipeline held another joint's reference (comparable()).
  std::uint64_t rotated_reference_clocks() const { return rotated_reference_clocks_; }
  int tick() const { return static_cast<int>(rtl().board_core__DOT__tick); }
  // The model's register by its RTL name (an instance's probe).
  std::uint64_t model_register(const std::string& instance, const std::string& name) {
    for (const auto& reg : model_.probe_registers(instance)) {
      if (reg.name == name) return reg.value;
    }
    throw std::invalid_argument("no model register " + instance + "." + name);
  }

 private:
  std::uint32_t model_sample_index() {
    return static_cast<std::uint32_t>(model_register("u_setpoints", "sample_index_q"));
  }

  void fail_with(const std::string& what) {
    failed_ = true;
    ADD_FAILURE() << what << "\n  at clock " << clocks_ << " after reset (tick " << tick() << ", period "
                  << clocks_ / kPeriod << "), seed " << test_seed() << " (DELTA_TEST_SEED=" << test_seed()
                  << " replays it)\n  RTL board_core: enabled_q " << int(rtl().board_core__DOT__enabled_q)
                  << ", holding_q " << int(rtl().board_core__DOT__holding_q) << ", homing_q "
                  << int(rtl().board_core__DOT__homing_q) << ", referenced_q "
                  << int(rtl().board_core__DOT__referenced_q) << ", fault cause "
                  << int(rtl().board_core__DOT__u_joint_axes__DOT__u_safety__DOT__fault_cause_q) << ", fill "
                  << rtl().board_core__DOT__u_setpoints__DOT__fill_q << ", estop_q "
                  << int(rtl().board_core__DOT__estop_q) << ", jog_q " << int(rtl().board_core__DOT__jog_q)
                  << ", board causes " << int(rtl().board_core__DOT__u_safety_inputs__DOT__cause_q);
  }

  // Where the model keeps a register in another form than the RTL, as model_board.hpp states:
  // whether this clock's values are comparable.
  bool comparable(const std::string& key, const std::uint64_t model_value) {
    const Root& x = rtl();
    // The network's answer: the model has it at the play, the RTL when the network is done (long
    // before the update reads it). The setpoint buffer's start pulse waits for the network's ready.
    if (key == "u_setpoints.starting_q" || key == "u_interpolator.answer_pending_q" ||
        key == "u_interpolator.answered_q" || key.rfind("board_core.net_outputs", 0) == 0) {
      return !answer_in_flight_;
    }
    // The controller's start request: the model clears it when the run starts, the RTL at ap_ready.
    if (key == "u_joint_axes.start_q") return x.board_core__DOT__u_joint_axes__DOT__ap_idle;
    // A stored current: the RTL stores it a clock before the model (with current_valid, which only
    // joint_pwm reads: its duty is compared).
    if (key.rfind("u_joint_axes.u_controller.current_q[", 0) == 0) {
      const int j = key[key.size() - 2] - '0';
      return ((x.board_core__DOT__u_joint_axes__DOT__u_controller__DOT__current_valid_q >> j) & 1) == 0;
    }
    // The peek reads the controller's memory only while it is idle (telemetry reads it then).
    if (key == "u_joint_axes.peek_data_o") {
      return x.board_core__DOT__u_joint_axes__DOT__ap_idle && rtl_idle_before_;
    }
    // delta_q: a pipeline register the RTL loads every clock; the model holds the segment change
    // from its step (InterpolatorDeltaStep) to the reference's.
    if (key == "u_interpolator.delta_q") {
      return model_register("u_interpolator", "busy_q") &&
             static_cast<int>(model_register("u_interpolator", "step_q")) > kDeltaStep;
    }
    // joint_safety's pipeline reads board_core's references_o, which are the interpolator's
    // rotating r_q: while it updates them (and a clock after, the pipeline's), the RTL's difference_q
    // and outside_q of joint j are those of r_q[j], another joint's reference; the model's are always
    // joint j's own. Nothing reads them then (the check is at tick 2), but the registers differ:
    // counted and printed, not compared.
    if (key.find("u_safety.g_check[") != std::string::npos && (interpolating_ || interpolating_before_)) {
      const auto it = readers_.find(key);
      if (it != readers_.end() && it->second(x) != model_value) ++rotated_reference_clocks_;
      return false;
    }
    return true;
  }

  // The output pins: the drives' enable, PWM and direction, the fault and status outputs.
  void compare_pins() {
    const Vboard_core_probe& core = *core_;
    const cosim::BoardPins p = model_.pins();
    const std::array<std::pair<const char*, std::pair<std::uint64_t, std::uint64_t>>, 8> pins = {{
        {"drive_enable_o", {p.drive_enable ? 1u : 0u, core.drive_enable_o}},
        {"drive_pwm_o", {static_cast<std::uint64_t>(p.drive_pwm), core.drive_pwm_o}},
        {"drive_dir_o", {static_cast<std::uint64_t>(p.drive_dir), core.drive_dir_o}},
        {"joint_fault_cause_o", {static_cast<std::uint64_t>(p.fault_cause_bits), core.joint_fault_cause_o}},
        {"board_fault_cause_o", {static_cast<std::uint64_t>(p.board_fault_bits), core.board_fault_cause_o}},
        {"estop_latched_o", {p.estop_latched ? 1u : 0u, core.estop_latched_o}},
        {"encoder_error_o", {static_cast<std::uint64_t>(p.encoder_error_bits), core.encoder_error_o}},
        {"stage_sync_o", {p.stage_sync ? 1u : 0u, core.stage_sync_o}},
    }};
    for (const auto& [name, values] : pins) {
      if (values.first != values.second) {
        std::ostringstream what;
        what << "pin " << name << ": model 0x" << std::hex << values.first << ", RTL 0x" << values.second << std::dec;
        fail_with(what.str());
        return;
      }
    }
  }

  // A probed register's RTL name and reader, kept by its place in the instance's probe list (the
  // list changes only where a register is listed in some clocks: looked up again there).
  struct Probed {
    std::string name, key;
    const Reader* reader = nullptr;
  };
  const Probed* probed(std::size_t instance, std::size_t place, const std::string& name) {
    std::vector<Probed>& list = probed_[instance];
    if (list.size() <= place) list.resize(place + 1);
    Probed& p = list[place];
    if (p.name != name || p.key.empty()) {
      p.name = name;
      p.key = instances_[instance] + "." + name;
      const auto it = readers_.find(p.key);
      p.reader = it == readers_.end() ? nullptr : &it->second;
    }
    return &p;
  }

  void compare() {
    probed_.resize(instances_.size());
    for (std::size_t i = 0; i < instances_.size(); ++i) {
      const std::string& instance = instances_[i];
      std::size_t place = 0;
      for (const auto& reg : model_.probe_registers(instance)) {
        const Probed& p = *probed(i, place++, reg.name);
        const std::string& key = p.key;
        std::uint64_t rtl_value = 0;
        if (key.rfind("u_interpolator.shift_o[", 0) == 0) {  // the play shift written for joint j
          const int j = key[key.size() - 2] - '0';
          if (!shift_known_[j]) continue;
          rtl_value = written_shift_[j];
        } else {
          if (p.reader == nullptr) {
            fail_with("no RTL register for the model's " + key);
            return;
          }
          if (!comparable(key, reg.value)) continue;
          rtl_value = (*p.reader)(rtl());
          if (key == "u_link_tx.state_q") rtl_value = rtl_value != 0 ? 2 : 0;  // Fetch folded into Send
        }
        if (rtl_value != reg.value) {
          std::ostringstream what;
          what << "module " << instance << ", register " << reg.name << ": model 0x" << std::hex << reg.value
               << ", RTL 0x" << rtl_value << std::dec;
          fail_with(what.str());
          return;
        }
      }
    }
    for (const std::string& memory : memories_) {
      const std::vector<std::uint64_t> a = model_.probe_memory(memory), b = rtl_memory(rtl(), memory);
      if (a.size() != b.size()) {
        fail_with("memory " + memory + ": the model has " + std::to_string(a.size()) + " words, the RTL " +
                  std::to_string(b.size()));
        return;
      }
      for (std::size_t i = 0; i < a.size(); ++i) {
        if (a[i] != b[i]) {
          std::ostringstream what;
          what << "memory " << memory << "[" << i << "]: model 0x" << std::hex << a[i] << ", RTL 0x" << b[i];
          fail_with(what.str());
          return;
        }
      }
    }
  }

  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Vboard_core_probe> core_;
  rtl::IdleNetworkSkip network_clock_;
  cosim::ModelBoard model_;
  rtl::UartLine line_;
  std::unordered_map<std::string, Reader> readers_;
  std::vector<std::string> instances_, memories_;
  std::vector<std::vector<Probed>> probed_;  // by instance, by place in its probe list
  std::uint64_t clocks_ = 0, tx_bytes_ = 0;
  bool estop_open_ = false;
  int drive_fault_ = 0;
  std::uint64_t register_stride_ = 1;
  bool failed_ = false;
  bool answer_in_flight_ = false, rtl_idle_before_ = true;
  bool interpolating_ = false, interpolating_before_ = false;
  std::uint64_t rotated_reference_clocks_ = 0;  // joint_safety registers of a rotated reference (above)
  std::array<std::uint64_t, 3> written_shift_{};
  std::array<bool, 3> shift_known_{};
  std::vector<std::pair<std::uint64_t, std::uint8_t>> rtl_tx_, model_tx_;
};

// ---- stimulus ----

// The encoder lines of three joints: a quadrature phase each (A, B = 00, 10, 11, 01 counting up).
struct Encoders {
  std::array<int, 3> phase{};
  int home = 0;
  static int ab(int p) {
    static constexpr int kGray[4] = {0b00, 0b10, 0b11, 0b01};
    return kGray[p & 3];
  }
  int a() const {
    return ((ab(phase[0]) >> 1) & 1) | (((ab(phase[1]) >> 1) & 1) << 1) | (((ab(phase[2]) >> 1) & 1) << 2);
  }
  int b() const { return (ab(phase[0]) & 1) | ((ab(phase[1]) & 1) << 1) | ((ab(phase[2]) & 1) << 2); }
};

class Stimulus {
 public:
  Stimulus(const golden::QuantisedNetwork& q, std::uint64_t seed) : q_(q), rng_(seed) {}

  int uniform(int low, int high) { return std::uniform_int_distribution<int>(low, high)(rng_); }
  bool chance(double p) { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < p; }
  std::uint8_t byte() { return static_cast<std::uint8_t>(uniform(0, 255)); }

  std::vector<std::uint8_t> frame(link::FrameType type, std::vector<std::uint8_t> payload) {
    link::Frame f;
    f.sequence = sequence_++;
    f.type = type;
    f.payload = std::move(payload);
    return link::encode_frame(f);
  }
  std::vector<std::uint8_t> command(int code) {
    return frame(link::FrameType::kCommand, {static_cast<std::uint8_t>(code)});
  }
  std::vector<std::uint8_t> identify() { return frame(link::FrameType::kIdentifyRequest, {}); }
  // A model frame (frame number n, a 48-bit word).
  std::vector<std::uint8_t> model(const link::ModelPayload& payload) {
    link::Frame f = link::make_frame(sequence_++, payload);
    return link::encode_frame(f);
  }
  const golden::QuantisedNetwork& network() const { return q_; }
  // A setpoint: its sample index and three scaled input codes (mostly inside the trained cube).
  std::vector<std::uint8_t> setpoint(std::uint32_t index) {
    std::vector<std::uint8_t> p;
    for (int b = 0; b < 4; ++b) p.push_back(static_cast<std::uint8_t>(index >> (8 * b)));
    for (int j = 0; j < 3; ++j) {
      // Mostly within half the scaled input's span, else any code.
      const std::int64_t c = chance(0.9) ? std::uniform_int_distribution<std::int64_t>(-16384, 16384)(rng_)
                                         : static_cast<std::int16_t>(rng_());
      for (int b = 0; b < 2; ++b) p.push_back(static_cast<std::uint8_t>(static_cast<std::uint64_t>(c) >> (8 * b)));
    }
    return frame(link::FrameType::kSetpoint, p);
  }
  // A frame spoiled: a bit flipped, cut short, its length or type changed, or line noise.
  std::vector<std::uint8_t> corrupt(std::vector<std::uint8_t> f) {
    switch (uniform(0, 4)) {
      case 0:
        f[static_cast<std::size_t>(uniform(0, static_cast<int>(f.size()) - 1))] ^=
            static_cast<std::uint8_t>(1 << uniform(0, 7));
        break;
      case 1:
        f.resize(static_cast<std::size_t>(uniform(1, static_cast<int>(f.size()) - 1)));
        break;
      case 2:
        f[1] = byte();
        break;
      case 3:
        f[3] = byte();
        break;
      default:
        f.assign(static_cast<std::size_t>(uniform(1, 12)), 0);
        for (auto& b : f) b = chance(0.3) ? static_cast<std::uint8_t>(board::kFrameSync) : byte();
    }
    return f;
  }

  std::mt19937_64& rng() { return rng_; }

 private:
  const golden::QuantisedNetwork& q_;
  std::mt19937_64 rng_;
  std::uint8_t sequence_ = 0;
};

struct Fixture {
  golden::QuantisedNetwork q;
  std::string mem_dir;
  Fixture() {
    q = golden::quantise_file(kWeights, nn::read_weights_file(kWeights));
    mem_dir = fresh_directory("model_board_modules_mem");
    golden::write_export(q, mem_dir);
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void report(const char* name, const Lockstep& run, std::chrono::steady_clock::time_point start) {
  std::cout << name << ": seed " << test_seed() << ", " << run.clocks() << " clocks (" << run.clocks() / kPeriod
            << " control periods), " << run.tx_bytes() << " TX bytes compared, "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() << " s\n";
}

// Runs `clocks` clocks with the encoder lines held; false on a divergence.
bool run_for(Lockstep& run, const Encoders& e, std::uint64_t clocks) {
  for (std::uint64_t i = 0; i < clocks; ++i) {
    if (!run.clock(e.a(), e.b(), e.home)) return false;
  }
  return true;
}
// Until the RX line has sent everything, then `gap` clocks more.
bool drain(Lockstep& run, const Encoders& e, std::uint64_t gap = 0) {
  while (run.line_busy()) {
    if (!run.clock(e.a(), e.b(), e.home)) return false;
  }
  return run_for(run, e, gap);
}

// ---- the tests ----

// uart_rx and link_rx (and board_core's frame counters and command register): random valid
// frames of every type, corrupted ones (bit flips, cut short, wrong length or type, noise with
// sync bytes) and random gaps between bytes and frames, with the ring wrapping many times.
TEST(ModelBoardModules, UartRxAndLinkRxEqualTheRtlUnderRandomAndCorruptedFrames) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  const auto start = std::chrono::steady_clock::now();
  Fixture& f = fixture();
  Lockstep run(f.q, f.mem_dir, {"u_uart_rx", "u_link_rx", "board_core"}, {"u_link_rx.ring_q"});
  Stimulus s(f.q, test_seed());
  Encoders e;
  const std::uint64_t kClocks = 600 * kPeriod;
  while (run.clocks() < kClocks && !run.failed()) {
    std::vector<std::uint8_t> bytes;
    switch (s.uniform(0, 5)) {
      case 0:
        bytes = s.identify();
        break;
      case 1:
        bytes = s.command(s.chance(0.8) ? s.uniform(1, 6) : s.byte());
        break;
      case 2:
        bytes = s.setpoint(static_cast<std::uint32_t>(s.rng()()));
        break;
      default:
        bytes =
            s.corrupt(s.chance(0.5) ? s.setpoint(static_cast<std::uint32_t>(s.rng()())) : s.command(s.uniform(1, 6)));
    }
    // Byte by byte with random gaps (mostly back to back).
    for (const std::uint8_t b : bytes) {
      run.send({b});
      const std::uint64_t gap =
          s.chance(0.85) ? 0 : static_cast<std::uint64_t>(s.uniform(1, 3 * static_cast<int>(kByteClocks)));
      if (!drain(run, e, gap)) break;
    }
  }
  report("uart_rx + link_rx", run, start);
  EXPECT_FALSE(run.failed());
  EXPECT_GT(run.model_register("board_core", "bad_frames_q"), 10u);
}

// A session on the pins: frames with random gaps, the encoder lines stepping at random (valid
// quadrature steps, now and then a skipped state) and the home switches as the test sets them.
class Session {
 public:
  Session(Lockstep& run, Stimulus& s) : run_(run), s_(s) {}
  double step_chance = 0.0;                 // per clock: a joint steps
  double skip_chance = 0.0;                 // per step: it skips a state instead
  std::array<double, 3> up{0.5, 0.5, 0.5};  // a step's chance to count up, per joint
  Encoders e;

  bool clock() {
    if (step_chance > 0.0 && s_.chance(step_chance)) {
      const int j = s_.uniform(0, 2);
      e.phase[j] += s_.chance(skip_chance) ? 2 : (s_.chance(up[j]) ? 1 : -1);
    }
    return run_.clock(e.a(), e.b(), e.home);
  }
  bool wait(std::uint64_t clocks) {
    for (std::uint64_t i = 0; i < clocks; ++i) {
      if (!clock()) return false;
    }
    return true;
  }
  // A frame onto the line, its bytes sent, then `gap` clocks.
  bool send(const std::vector<std::uint8_t>& bytes, std::uint64_t gap = 0) {
    run_.send(bytes);
    while (run_.line_busy()) {
      if (!clock()) return false;
    }
    return wait(gap);
  }
  bool command(int code, std::uint64_t gap = 0) { return send(s_.command(code), gap); }
  // The model's load (golden::model_frames of the fixture's network), frame by frame.
  bool load() {
    for (const link::ModelPayload& frame : golden::model_frames(s_.network())) {
      if (!send(s_.model(frame))) return false;
    }
    return true;
  }
  // Drives on from reset: the model loaded, set home, enable.
  bool enable() { return load() && command(board::kCommandSetHome) && command(board::kCommandEnable); }
  std::uint32_t next_index() {
    return static_cast<std::uint32_t>(run_.model_register("u_setpoints", "sample_index_q") +
                                      run_.model_register("u_setpoints", "fill_q"));
  }
  std::uint64_t fill() { return run_.model_register("u_setpoints", "fill_q"); }

 private:
  Lockstep& run_;
  Stimulus& s_;
};

// setpoint_buffer (and board_core's commands and counters): setpoint frames with the next index
// or a random one, corrupted ones, enable, disable, hold, set home and clear fault at random,
// the buffer filled while holding (up to full: frames refused) and drained by the plays.
TEST(ModelBoardModules, SetpointBufferEqualsTheRtlUnderRandomSetpointsAndCommands) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  const auto start = std::chrono::steady_clock::now();
  Fixture& f = fixture();
  Lockstep run(f.q, f.mem_dir, {"u_setpoints", "board_core"}, {"u_setpoints.ram_q"});
  Stimulus s(f.q, test_seed() + 1);
  Session session(run, s);
  ASSERT_TRUE(session.enable());
  const std::uint64_t kClocks = run.clocks() + 300 * kPeriod;  // after the load and the enable
  // Once, at a random time: the buffer filled to full and past it while holding.
  std::uint64_t fill_up_at = static_cast<std::uint64_t>(s.uniform(20, 200)) * kPeriod + run.clocks();
  std::uint64_t most = 0;
  while (run.clocks() < kClocks && !run.failed()) {
    int pick = s.uniform(0, 98);
    if (run.clocks() >= fill_up_at) {
      pick = 99;
      fill_up_at = ~std::uint64_t{0};
    }
    const std::uint64_t gap =
        s.chance(0.7) ? 0 : static_cast<std::uint64_t>(s.uniform(0, 3 * static_cast<int>(kPeriod)));
    bool ok = true;
    if (pick < 70) {
      std::uint32_t index = session.next_index();
      if (s.chance(0.1)) index += static_cast<std::uint32_t>(s.uniform(-2, 2));
      if (s.chance(0.02)) index = static_cast<std::uint32_t>(s.rng()());
      ok = session.send(s.setpoint(index), gap);
    } else if (pick < 77) {
      ok = session.send(s.corrupt(s.setpoint(session.next_index())), gap);
    } else if (pick < 84) {
      ok = session.command(board::kCommandEnable, gap);
    } else if (pick < 88) {
      ok = session.command(board::kCommandDisable, gap);
    } else if (pick < 94) {
      ok = session.command(board::kCommandHold, gap);
    } else if (pick < 97) {
      ok = session.command(s.chance(0.5) ? board::kCommandSetHome : board::kCommandClearFault, gap);
    } else {  // (98: a short fill, 99: the one to full)
      // Fill the buffer while holding: up to full and past it (frames refused), then resume.
      ok = session.command(board::kCommandEnable) && session.command(board::kCommandHold);
      const int frames = pick == 99 ? static_cast<int>(board::kSetpointDepth) + 3 : s.uniform(5, 40);
      for (int i = 0; ok && i < frames; ++i) ok = session.send(s.setpoint(session.next_index()));
      ok = ok && session.command(board::kCommandEnable);
    }
    most = std::max(most, session.fill());
    if (!ok) break;
  }
  report("setpoint_buffer", run, start);
  EXPECT_FALSE(run.failed());
  std::cout << "  the fill reached " << most << "; refused " << run.model_register("board_core", "refused_q")
            << ", underruns " << run.model_register("board_core", "underruns_q") << "\n";
}

// reference_interpolator: setpoints streamed one per setpoint period (near positions and far
// jumps, which saturate the segment change), holds and resumes, disables with the encoders moving
// (the references follow the counts), homing (the segment change kept across setpoints).
TEST(ModelBoardModules, ReferenceInterpolatorEqualsTheRtlUnderStreamedSetpoints) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  const auto start = std::chrono::steady_clock::now();
  Fixture& f = fixture();
  Lockstep run(f.q, f.mem_dir, {"u_interpolator", "board_core"}, {});
  Stimulus s(f.q, test_seed() + 2);
  Session session(run, s);
  session.step_chance = 1.0 / 400;
  ASSERT_TRUE(session.enable());
  const std::uint64_t kSetpointClocks = kPeriod * static_cast<std::uint64_t>(board::kPeriodsPerSetpoint);
  const std::uint64_t kClocks = run.clocks() + 600 * kPeriod;
  while (run.clocks() < kClocks && !run.failed()) {
    const int pick = s.uniform(0, 99);
    bool ok = true;
    if (pick < 85) {  // keep two or three setpoints ahead of the plays
      ok = session.send(s.setpoint(session.next_index()));
      if (ok && session.fill() >= 3)
        ok = session.wait(kSetpointClocks - kByteClocks * (board::kSetpointPayloadBytes + 6) +
                          static_cast<std::uint64_t>(s.uniform(0, 500)));
    } else if (pick < 90) {
      ok = session.command(board::kCommandHold, static_cast<std::uint64_t>(s.uniform(0, 3)) * kSetpointClocks) &&
           session.command(board::kCommandEnable);
    } else if (pick < 95) {
      ok = session.command(board::kCommandDisable, static_cast<std::uint64_t>(s.uniform(1, 3)) * kPeriod) &&
           session.command(s.chance(0.5) ? board::kCommandHomeStart : board::kCommandSetHome) &&
           session.command(board::kCommandEnable);
    } else {
      ok = session.wait(static_cast<std::uint64_t>(s.uniform(1, 2)) * kSetpointClocks);  // underruns
    }
    if (!ok) break;
  }
  report("reference_interpolator", run, start);
  EXPECT_FALSE(run.failed());
  std::cout << "  slew limits " << run.model_register("board_core", "slew_limits_q") << ", underruns "
            << run.model_register("board_core", "underruns_q") << "\n";
}

// joint_axes (quadrature counters, the controller's run and stores, joint_safety, joint_pwm, the
// peek): the encoders stepping at random with drifts (following errors), skipped states (encoder
// faults), clear fault, enable and disable, homing with home switch edges.
TEST(ModelBoardModules, JointAxesEqualTheRtlUnderRandomEncodersSwitchesAndCommands) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  const auto start = std::chrono::steady_clock::now();
  Fixture& f = fixture();
  Lockstep run(f.q, f.mem_dir, {"u_joint_axes", "board_core"}, {});
  Stimulus s(f.q, test_seed() + 3);
  Session session(run, s);
  session.step_chance = 1.0 / 30;
  ASSERT_TRUE(session.enable());
  const std::uint64_t kClocks = run.clocks() + 350 * kPeriod;
  int faults = 0;
  while (run.clocks() < kClocks && !run.failed()) {
    const int pick = s.uniform(0, 99);
    const std::uint64_t gap = static_cast<std::uint64_t>(s.uniform(0, 2 * static_cast<int>(kPeriod)));
    session.skip_chance = s.chance(0.1) ? 0.002 : 0.0;
    for (auto& up : session.up) up = s.chance(0.2) ? (s.chance(0.5) ? 0.9 : 0.1) : 0.5;  // drifts: following errors
    bool ok = true;
    if (pick < 30) {
      ok = session.send(s.setpoint(session.next_index()), gap);
    } else if (pick < 50) {
      ok = session.command(board::kCommandClearFault) && session.command(board::kCommandEnable, gap);
    } else if (pick < 60) {
      ok = session.command(board::kCommandDisable, gap);
    } else if (pick < 70) {
      // Homing: home start with the drives off, enable, a switch closes (and opens again).
      ok = session.command(board::kCommandDisable) && session.command(board::kCommandHomeStart) &&
           session.command(board::kCommandClearFault) && session.command(board::kCommandEnable, gap);
      session.e.home |= 1 << s.uniform(0, 2);
      ok = ok && session.wait(static_cast<std::uint64_t>(s.uniform(1, 400)));
      if (s.chance(0.5)) session.e.home = 0;
    } else if (pick < 80) {
      session.e.home = s.uniform(0, 7);
      ok = session.wait(gap);
    } else {
      ok = session.send(s.identify(), gap);
    }
    if (run.model_register("u_joint_axes", "u_safety.fault_cause_q") != 0) ++faults;
    if (!ok) break;
  }
  report("joint_axes", run, start);
  EXPECT_FALSE(run.failed());
  std::cout << "  steps with a fault latched: " << faults << ", encoder errors "
            << run.model_register("u_joint_axes", "encoder_error_q")
            << "\n  joint_safety registers of a rotated reference (RTL only): " << run.rotated_reference_clocks()
            << "\n";
}

// model_loader (docs/board_link.md, "The model"; and board_core's counters, the identify frames'
// CRC on the TX line, the network's answers on the loaded words): loads whole and cut short,
// restarted at frame 0, frames out of order (repeated, skipped, random numbers), corrupted on the
// line (dropped) and with a word changed under a valid frame CRC (the commit's CRC no longer
// matches), loads begun with the drives on (refused), with identify requests, enables (refused
// without a model) and setpoints between them; the words in the memories compared every clock.
TEST(ModelBoardModules, ModelLoaderEqualsTheRtlUnderGoodCorruptedAndOutOfOrderLoads) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  const auto start = std::chrono::steady_clock::now();
  Fixture& f = fixture();
  Lockstep run(f.q, f.mem_dir, {"u_model_loader", "board_core"}, kModelMemories);
  Stimulus s(f.q, test_seed() + 5);
  Session session(run, s);
  session.step_chance = 1.0 / 200;
  const std::vector<link::ModelPayload> image = golden::model_frames(f.q);
  const std::uint64_t kClocks = 1000 * kPeriod;
  int loads = 0, loaded = 0, enables = 0;
  bool ok = session.command(board::kCommandSetHome);
  while (ok && run.clocks() < kClocks && !run.failed()) {
    const int pick = loads < 2 ? 0 : s.uniform(0, 99);  // a clean load, then a corrupted one, first
    if (pick < 40) {
      // A load: mostly whole and clean, else a word changed under a valid frame CRC or cut short;
      // identify requests now and then just before frame 0 or the commit (the reply on the line
      // as the CRC changes).
      const int kind = loads == 0 ? 0 : loads == 1 ? 8 : s.uniform(0, 9);
      const bool line_errors = kind == 7;
      const int corrupt = kind == 8 ? s.uniform(0, static_cast<int>(board::kModelCommitFrame) - 1) : -1;
      const int end = kind == 9 ? s.uniform(1, static_cast<int>(image.size()) - 1) : static_cast<int>(image.size());
      if (run.model_register("board_core", "enabled_q") != 0) ok = session.command(board::kCommandDisable);
      for (int n = 0; ok && n < end; ++n) {
        link::ModelPayload frame = image[static_cast<std::size_t>(n)];
        if (n == corrupt)
          frame.word[static_cast<std::size_t>(s.uniform(0, 2))] ^= static_cast<std::uint16_t>(1u << s.uniform(0, 15));
        if ((n == 0 && s.chance(0.3)) || (n == static_cast<int>(board::kModelCommitFrame) && s.chance(0.5))) {
          ok = session.send(s.identify(), static_cast<std::uint64_t>(s.uniform(0, 3000)));
        }
        // Now and then the line spoils it (dropped: the load stops there unless resent) or the
        // host resends an earlier frame or skips one.
        if (line_errors && s.chance(0.02)) {
          ok = ok && session.send(s.corrupt(s.model(frame)));
          if (s.chance(0.5)) continue;
        }
        if (line_errors && s.chance(0.02))
          ok = ok && session.send(s.model(image[static_cast<std::size_t>(s.uniform(0, n))]));
        if (line_errors && s.chance(0.01)) continue;
        ok = ok && session.send(s.model(frame), s.chance(0.9) ? 0 : static_cast<std::uint64_t>(s.uniform(0, 3000)));
      }
      ++loads;
      if (run.model_register("u_model_loader", "loaded_q") != 0) ++loaded;
    } else if (pick < 50) {  // frames with random numbers and words
      for (int i = s.uniform(1, 6); ok && i > 0; --i) {
        const int n = s.chance(0.5) ? s.uniform(0, static_cast<int>(board::kModelFrames) + 2) : s.uniform(0, 65535);
        ok = session.send(s.model(link::ModelPayload::of(static_cast<std::uint16_t>(n), s.rng()())));
      }
    } else if (pick < 70) {
      // An enable (refused without a model), setpoints (played on the loaded network), a load
      // begun with the drives on (refused), the disable.
      ok = session.command(board::kCommandEnable);
      ++enables;
      for (int i = s.uniform(1, 6); ok && i > 0; --i) ok = session.send(s.setpoint(session.next_index()));
      for (int n = s.uniform(0, 3); ok && n > 0; --n)
        ok = session.send(s.model(image[static_cast<std::size_t>(n - 1)]));
      ok = ok && session.wait(static_cast<std::uint64_t>(s.uniform(0, 10 * static_cast<int>(kPeriod))));
      if (ok && s.chance(0.9)) ok = session.command(board::kCommandDisable);
    } else if (pick < 90) {
      ok = session.send(s.identify(), static_cast<std::uint64_t>(s.uniform(0, static_cast<int>(kPeriod))));
    } else {
      ok = session.send(s.setpoint(session.next_index()),
                        static_cast<std::uint64_t>(s.uniform(0, 2 * static_cast<int>(kPeriod))));
    }
  }
  report("model_loader", run, start);
  EXPECT_FALSE(run.failed());
  std::cout << "  loads " << loads << ", " << loaded << " ending with a model; enables " << enables << ", refused "
            << run.model_register("board_core", "refused_q") << ", bad frames "
            << run.model_register("board_core", "bad_frames_q") << "\n";
  EXPECT_GT(loaded, 0);
  EXPECT_GT(loads, loaded);
}

// link_tx (its capture, the telemetry words it writes, the frames it sends: the TX line's bytes
// in the same clocks): identify requests at random times, alone and in bursts, beside the
// telemetry snapshots, with the board's state changing (commands, setpoints, encoders).
TEST(ModelBoardModules, LinkTxEqualsTheRtlUnderIdentifyRequestsAtRandomTimes) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  const auto start = std::chrono::steady_clock::now();
  Fixture& f = fixture();
  Lockstep run(f.q, f.mem_dir, {"u_link_tx"}, {"u_link_tx.words"});
  Stimulus s(f.q, test_seed() + 4);
  Session session(run, s);
  session.step_chance = 1.0 / 100;
  ASSERT_TRUE(session.enable());
  const std::uint64_t kClocks = run.clocks() + 1200 * kPeriod;
  while (run.clocks() < kClocks && !run.failed()) {
    const int pick = s.uniform(0, 99);
    const std::uint64_t gap = static_cast<std::uint64_t>(s.uniform(0, static_cast<int>(kPeriod)));
    bool ok = true;
    if (pick < 45) {
      ok = session.send(s.identify(), gap);
    } else if (pick < 55) {
      for (int i = s.uniform(2, 5); ok && i > 0; --i) ok = session.send(s.identify());
    } else if (pick < 80) {
      ok = session.send(s.setpoint(session.next_index()), gap);
    } else if (pick < 90) {
      ok = session.command(s.uniform(1, 6), gap);
    } else {
      ok = session.wait(gap);
    }
    if (!ok) break;
  }
  report("link_tx", run, start);
  EXPECT_FALSE(run.failed());
  EXPECT_GT(run.tx_bytes(), 1000u);
}

// The board's safety inputs, the e-stop command and the bench jog (board_safety_inputs.sv and
// board_core's estop_q and jog registers, joint_pwm's pins; the output pins and the telemetry
// bytes on the TX line in the same clocks): the e-stop input and the three drive-fault inputs at
// the stop level at random times, for random lengths (glitches shorter than the filter, a few
// clocks or under BoardInputFilterPeriods - 1 periods, and long ones that latch); clear fault
// while an input still samples at stop (refused) and after (accepted); CommandEstop in every
// state; each joint's jog in both signs ended early by a disable, an e-stop command or a safety
// input, and one jog run to its end (its JogPeriods periods: the registers compared every 256th
// clock and at ticks 0-3 there, the pins and the TX line every clock).
TEST(ModelBoardModules, SafetyInputsEstopAndJogEqualTheRtlUnderRandomInputsAndCommands) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  const auto start = std::chrono::steady_clock::now();
  Fixture& f = fixture();
  Lockstep run(f.q, f.mem_dir, {"u_safety_inputs", "board_core", "u_joint_axes"}, {});
  Stimulus s(f.q, test_seed() + 6);
  Session session(run, s);
  session.step_chance = 1.0 / 300;
  bool estop_open = false;
  int drive_fault = 0;
  auto lines = [&] { run.set_safety_inputs(estop_open, drive_fault); };
  const int kGlitchClocks = static_cast<int>((board::kBoardInputFilterPeriods - 1) * kPeriod) - 1;
  const int kLatchClocks = static_cast<int>((board::kBoardInputFilterPeriods + 1) * kPeriod);
  // One input (0: the e-stop chain, 1 + j: drive j) at stop for `clocks` clocks, then released;
  // `during` runs with it held (e.g. a clear fault, refused).
  auto pulse = [&](int input, int clocks, const std::function<bool()>& during) {
    if (input == 0)
      estop_open = true;
    else
      drive_fault |= 1 << (input - 1);
    lines();
    bool ok = session.wait(static_cast<std::uint64_t>(clocks)) && (!during || during());
    if (input == 0)
      estop_open = false;
    else
      drive_fault &= ~(1 << (input - 1));
    lines();
    return ok;
  };
  auto refused = [&] { return run.model_register("board_core", "refused_q"); };
  auto board_causes = [&] { return run.model_register("u_safety_inputs", "cause_q"); };
  int latches = 0, refused_clears = 0, accepted_clears = 0, jogs = 0, jogs_on = 0;
  std::array<int, 4> jog_ends{};  // by a disable, an e-stop command, a safety input, its end
  // A clear fault while an input is held at stop (refused, counted), then released and cleared.
  auto clear_all = [&](bool check_refusal) {
    bool ok = true;
    if (check_refusal) {
      const std::uint64_t before = refused();
      ok = pulse(s.uniform(0, 3), static_cast<int>(kPeriod) + s.uniform(2, 200),
                 [&] { return session.command(board::kCommandClearFault); });
      if (refused() == before + 1)
        ++refused_clears;
      else
        ADD_FAILURE() << "a clear fault with an input at stop was not refused";
      ok = ok && session.wait(static_cast<std::uint64_t>(2 * kPeriod));  // the last sample back at run
    }
    ok = ok && session.command(board::kCommandClearFault);
    if (run.model_register("u_safety_inputs", "cause_q") == 0 && run.model_register("board_core", "estop_q") == 0)
      ++accepted_clears;
    return ok;
  };
  // Drives on after a clear, then random events with the drives on or off.
  run.set_register_stride(256);  // (the load: the modules under test idle)
  bool ok = session.enable();
  run.set_register_stride(1);
  const std::uint64_t kClocks = run.clocks() + 160 * kPeriod;
  while (ok && run.clocks() < kClocks && !run.failed()) {
    const int pick = s.uniform(0, 99);
    const std::uint64_t gap = static_cast<std::uint64_t>(s.uniform(0, 2 * static_cast<int>(kPeriod)));
    if (pick < 25) {  // a glitch on one input: shorter than the filter
      const int clocks = s.chance(0.4) ? s.uniform(1, 12) : s.uniform(1, kGlitchClocks);
      const std::uint64_t before = board_causes();
      ok = pulse(s.uniform(0, 3), clocks, nullptr) && session.wait(gap);
      if (board_causes() != before) ADD_FAILURE() << "a glitch of " << clocks << " clocks latched a cause";
    } else if (pick < 40) {  // an input held long enough to latch, maybe two at once
      const int input = s.uniform(0, 3);
      ok = pulse(input, kLatchClocks + s.uniform(0, static_cast<int>(kPeriod)),
                 [&] { return !s.chance(0.3) || pulse((input + s.uniform(1, 3)) % 4, kLatchClocks, nullptr); });
      if (board_causes() != 0) ++latches;
      ok = ok && session.wait(gap);
    } else if (pick < 50) {
      ok = session.command(board::kCommandEstop, gap);
    } else if (pick < 62) {
      ok = clear_all(s.chance(0.5)) && session.command(board::kCommandEnable, gap);
    } else if (pick < 70) {
      ok = session.command(board::kCommandDisable, gap);
    } else if (pick < 75) {
      ok = session.send(s.setpoint(session.next_index()), gap);
    } else {  // a jog (refused unless the drives are off and no cause is latched), ended early
      const int code = s.uniform(0, 5);
      if (s.chance(0.7)) ok = session.command(board::kCommandDisable) && clear_all(false);
      ok = ok && session.command(static_cast<int>(board::kCommandJogBase) + code);
      ++jogs;
      if (run.model_register("board_core", "jog_q") != 0) ++jogs_on;
      ok = ok && session.wait(static_cast<std::uint64_t>(s.uniform(1, 4 * static_cast<int>(kPeriod))));
      const int end = s.uniform(0, 2);
      ++jog_ends[static_cast<std::size_t>(end)];
      if (end == 0)
        ok = ok && session.command(board::kCommandDisable, gap);
      else if (end == 1)
        ok = ok && session.command(board::kCommandEstop, gap);
      else
        ok = ok && pulse(s.uniform(0, 3), kLatchClocks, nullptr) && session.wait(gap);
    }
  }
  // A clear fault with an input at stop, whatever the random events were (refused), then accepted.
  session.step_chance = 0.0;
  ok = ok && clear_all(true);
  // Each joint's jog in both signs ended early by each of the three, then one jog run to its end
  // (the encoders still: no joint cause).
  for (int code = 0; ok && code < 6; ++code) {
    for (int end = 0; ok && end < 3; ++end) {
      ok = session.command(board::kCommandDisable) && clear_all(false) &&
           session.command(static_cast<int>(board::kCommandJogBase) + code);
      ++jogs;
      if (run.model_register("board_core", "jog_q") != 0)
        ++jogs_on;
      else
        ADD_FAILURE() << "jog " << code << " refused with the drives off and no cause latched";
      ok = ok && session.wait(static_cast<std::uint64_t>(s.uniform(1, 3 * static_cast<int>(kPeriod))));
      ++jog_ends[static_cast<std::size_t>(end)];
      if (end == 0)
        ok = ok && session.command(board::kCommandDisable);
      else if (end == 1)
        ok = ok && session.command(board::kCommandEstop);
      else
        ok = ok && pulse(s.uniform(0, 3), kLatchClocks, nullptr) && session.wait(2 * kPeriod);
      ok = ok && session.wait(static_cast<std::uint64_t>(s.uniform(0, static_cast<int>(kPeriod))));
      if (run.model_register("board_core", "jog_q") != 0) ADD_FAILURE() << "jog " << code << " not ended by " << end;
    }
  }
  const int full_code = s.uniform(0, 5);
  ok = ok && session.command(board::kCommandDisable) && clear_all(false) &&
       session.command(static_cast<int>(board::kCommandJogBase) + full_code);
  const bool full_started = run.model_register("board_core", "jog_q") != 0;
  run.set_register_stride(256);
  std::uint64_t jog_clocks = 0;
  const auto jog_start = std::chrono::steady_clock::now();
  while (ok && run.rtl().board_core__DOT__jog_q != 0) {
    ok = session.wait(1);
    ++jog_clocks;
  }
  run.set_register_stride(1);
  ++jog_ends[3];
  ok = ok && session.wait(2 * kPeriod);
  report("safety inputs, e-stop and jog", run, start);
  EXPECT_FALSE(run.failed());
  std::cout << "  causes latched " << latches << " times; clears refused " << refused_clears << ", accepted "
            << accepted_clears << "; jogs " << jogs << " (" << jogs_on << " started), ended by a disable "
            << jog_ends[0] << ", an e-stop command " << jog_ends[1] << ", a safety input " << jog_ends[2]
            << "; the full jog (joint " << full_code / 2 << (full_code % 2 != 0 ? ", negative" : ", positive")
            << ") ran " << jog_clocks << " clocks ("
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - jog_start).count() << " s)\n";
  EXPECT_TRUE(full_started);
  // The full jog ran between JogPeriods - 1 and JogPeriods periods (gate_choices.md 7).
  EXPECT_GE(jog_clocks, (static_cast<std::uint64_t>(board::kJogPeriods) - 1) * kPeriod);
  EXPECT_LE(jog_clocks, static_cast<std::uint64_t>(board::kJogPeriods) * kPeriod);
  EXPECT_EQ(run.model_register("board_core", "jog_left_q"), 0u);
  EXPECT_EQ(run.rtl().board_core__DOT__enabled_q, 0);
  EXPECT_GT(latches, 0);
  EXPECT_GT(refused_clears, 0);
  EXPECT_GT(accepted_clears, 0);
}

}  // namespace
}  // namespace delta::test
