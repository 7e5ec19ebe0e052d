// The board core end to end over its UART, with its two clocks (the network's at twice the
// board's, as the PLL makes them): framed requests (positions as raw input codes) in, framed
// answers (joint references as raw output codes) out, equal to the golden model; a bad checksum
// is answered with NAK. And the answer's way to the drives: the joint controllers take it as
// their reference from the next control period on, and every period's PWM duty and direction
// equal the golden joint controller's current. UART at 4 clocks per bit.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <vector>

#include "Vboard_core.h"
#include "delta/board_facts.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/link_v1.hpp"
#include "delta/robot_world.hpp"
#include "delta/rtl/board_clock.hpp"
#include "delta/rtl/uart_line.hpp"
#include "rtl_fixture.hpp"

namespace delta::test {
namespace {

// The Verilated board core's test build (-G values from rtl/board/delta_board_pkg.sv, Sim*).
constexpr int kClocksPerBit = static_cast<int>(board::kSimClocksPerBit);
constexpr int kClocksPerPeriod = static_cast<int>(board::kSimClocksPerPeriod);  // control period in board clocks
constexpr int kHomeCount = static_cast<int>(board::kHomeCount);
constexpr int kPwmPeriod = static_cast<int>(board::kPwmPeriodCycles);

// Checks the drive outputs against the golden joint controller, period by period, and moves the
// encoders (one count per period at most, 100 deg/s). Board edge e (0 at the first edge after
// reset) is cycle e % kClocksPerPeriod of control period e / kClocksPerPeriod; the board latches
// encoders and reference at cycle 0, so encoders move only at cycle 100 and the golden model sees
// the position of cycle 0.
class JointMonitor {
 public:
  JointMonitor() : coefficients_(control::make_fixed_coefficients(control::JointControllerParameters{})) {}

  // The network answer the board is about to receive (raw Q10.14 degrees).
  void expect_reference(const std::array<std::int64_t, 3>& raw) { reference_raw_ = raw; }
  void move_encoders_to(const std::array<int, 3>& counts) { goal_ = counts; }
  void enable() { enabled_checks_ = true; }
  int largest_duty() const { return largest_duty_; }
  int partial_duties() const { return partial_duties_; }  // joint-periods with 0 < duty < 100 %
  int referenced_periods() const { return referenced_periods_; }

  // Encoder inputs for the next edge.
  void drive(Vboard_core& core) const {
    int a = 0, b = 0;
    for (int j = 0; j < 3; ++j) {
      a |= quadrature_a(position_[j]) << j;
      b |= quadrature_b(position_[j]) << j;
    }
    core.encoder_a_i = a;
    core.encoder_b_i = b;
  }

  // After board edge `edge` (the outputs are those of the state after it).
  void after_edge(const Vboard_core& core, std::int64_t edge) {
    if (!enabled_checks_) return;
    const int cycle = static_cast<int>(edge % kClocksPerPeriod);
    if (cycle == 0) start_period(edge / kClocksPerPeriod);
    if (cycle == 100) {
      for (int j = 0; j < 3; ++j)
        position_[j] += (goal_[j] > kHomeCount + position_[j]) - (goal_[j] < kHomeCount + position_[j]);
    }
    if (cycle == kWindowStart) {
      for (int j = 0; j < 3; ++j) {
        EXPECT_EQ((core.drive_dir_o >> j) & 1, expected_[j] < 0 ? 1 : 0)
            << "period " << edge / kClocksPerPeriod << " joint " << j;
      }
    }
    if (cycle >= kWindowStart && cycle < kWindowStart + kPwmPeriod) {
      for (int j = 0; j < 3; ++j) high_[j] += (core.drive_pwm_o >> j) & 1;
    }
    if (cycle == kWindowStart + 1023) {
      for (int j = 0; j < 3; ++j) {
        const int duty = std::abs(static_cast<int>(expected_[j])) >> 4;
        EXPECT_EQ(high_[j], duty) << "period " << edge / kClocksPerPeriod << " joint " << j << " current "
                                  << expected_[j];
        largest_duty_ = std::max(largest_duty_, duty);
        partial_duties_ += duty > 0 && duty < kPwmPeriod;
      }
    }
    EXPECT_EQ(core.encoder_error_o, 0);
    EXPECT_EQ(core.joint_limited_o, 0);
    EXPECT_EQ(core.joint_fault_o, 0);
    enabled_ = core.drive_enable_o;
  }

 private:
  // Every current is stored by cycle 892 + a few after the tick (joint_controller.sv); the
  // PWM is then counted over one whole 1024-cycle PWM period before the next period's stores.
  static constexpr int kWindowStart = 950;

  void start_period(std::int64_t period) {
    // The reference is used from the first period whose tick comes after drive_enable_o rose.
    if (enabled_) ++referenced_periods_;
    for (int j = 0; j < 3; ++j) {
      control::JointFixedInput input;
      input.encoder = static_cast<std::int16_t>(kHomeCount + position_[j]);
      input.reference = enabled_ ? static_cast<std::int32_t>((25 * reference_raw_[j] + 8) >> 4) : input.encoder * 256;
      if (period == 0) state_[j] = control::fixed_rest_state(input);
      control::JointFixedStatus status;
      expected_[j] = control::fixed_update(coefficients_, state_[j], input, status);
      high_[j] = 0;
    }
  }

  control::JointFixedCoefficients coefficients_;
  std::array<control::JointFixedState, 3> state_{};
  std::array<std::int16_t, 3> expected_{0, 0, 0};
  std::array<std::int64_t, 3> reference_raw_{0, 0, 0};
  std::array<int, 3> position_{0, 0, 0};  // counts moved since reset
  std::array<int, 3> goal_{kHomeCount, kHomeCount, kHomeCount};
  std::array<int, 3> high_{0, 0, 0};
  bool enabled_checks_ = false;
  bool enabled_ = false;
  int largest_duty_ = 0;
  int partial_duties_ = 0;
  int referenced_periods_ = 0;
};

class BoardUart {
 public:
  explicit BoardUart(const std::string& mem_dir) : context_(new VerilatedContext) {
    const std::string plusarg = "+delta_mem_dir=" + mem_dir;
    const char* argv[] = {"board_uart", plusarg.c_str()};
    context_->commandArgs(2, argv);
    core_ = std::make_unique<Vboard_core>(context_.get(), "board");
    core_->uart_rx_i = 1;
    core_->encoder_a_i = 0;
    core_->encoder_b_i = 0;
    core_->rst_ni = 0;
    core_->rst_network_ni = 0;
    for (int i = 0; i < 4; ++i) tick();
    core_->rst_ni = 1;
    core_->rst_network_ni = 1;
    edge_ = 0;
    listening_ = true;  // tx_o is undefined before reset
  }

  JointMonitor& joints() { return joints_; }
  void run(std::int64_t cycles) {
    for (std::int64_t i = 0; i < cycles; ++i) tick();
  }
  std::int64_t edge() const { return edge_; }
  ~BoardUart() { core_->final(); }

  // Sends the bytes (8N1, LSB first) while decoding what the board transmits; returns the bytes
  // received until the line has been idle for 40 bit times after the last one.
  std::vector<std::uint8_t> exchange(const std::vector<std::uint8_t>& request) {
    line_.send(request);
    while (line_.sending()) tick();
    int idle = 0;
    while (idle < 40 * kClocksPerBit * 10 && context_->time() < 100'000'000) {
      idle = received_.size() > received_before_idle_ ? 0 : idle + 1;
      received_before_idle_ = received_.size();
      tick();
    }
    std::vector<std::uint8_t> answer(received_.begin(), received_.end());
    received_.clear();
    received_before_idle_ = 0;
    return answer;
  }

 private:
  // One board clock = two network clocks, rising together (the PLL's GENCLK and GENCLK_HALF); the
  // serial line drives rx_i and decodes tx_o (rtl/board/sim/uart_line.hpp).
  void tick() {
    core_->uart_rx_i = line_.rx_pin();
    if (listening_) joints_.drive(*core_);
    rtl::clock_board(*core_);
    context_->timeInc(1);
    const int tx = core_->uart_tx_o;
    if (!listening_) return;
    joints_.after_edge(*core_, edge_++);
    if (line_.sample_tx_pin(tx)) received_.push_back(line_.byte());
  }

  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Vboard_core> core_;
  JointMonitor joints_;  // checks nothing until enabled
  std::int64_t edge_ = 0;
  std::vector<std::uint8_t> received_;
  std::size_t received_before_idle_ = 0;
  bool listening_ = false;
  rtl::UartLine line_{kClocksPerBit};
};

// The answer's three codes, after its framing and checksum are checked.
std::array<std::int64_t, 3> answer_codes(const std::vector<std::uint8_t>& answer, int vector) {
  const auto codes = link_v1::parse_answer(answer);
  EXPECT_TRUE(codes.has_value()) << "vector " << vector << ": " << answer.size() << " bytes, or a bad checksum";
  return codes.value_or(std::array<std::int64_t, 3>{});
}

using link_v1::request_frame;

TEST(BoardUart, AnswersEqualTheGoldenModel) {
  constexpr std::uint64_t kSeed = 20260105;
  std::cout << "vector seed " << kSeed << "\n";
  const golden::QuantisedNetwork q = golden::quantise(random_network(31));
  const std::string mem_dir = fresh_directory("board_uart_mem");
  golden::write_export(q, mem_dir);
  BoardUart board(mem_dir);
  InputVectors inputs(q, kSeed);
  for (int v = 0; v < 20; ++v) {
    const std::array<std::int64_t, 3> x = inputs.next();
    board.joints().expect_reference(golden::evaluate_raw(q, x).alpha);
    EXPECT_EQ(answer_codes(board.exchange(request_frame(x)), v), golden::evaluate_raw(q, x).alpha) << "vector " << v;
  }
  // A wrong checksum gets NAK, and the link then serves the next request.
  EXPECT_EQ(board.exchange(request_frame(inputs.next(), 1)), std::vector<std::uint8_t>{0x15});
  const std::array<std::int64_t, 3> x = inputs.next();
  EXPECT_EQ(board.exchange(request_frame(x)).size(), 11u);
}

// The answer drives the joints. The network is shifted (its output range) so that the answer
// is a few counts from the encoders' home position: the currents stay inside the limit and no
// state saturates. The joints hold their encoder position with the drives disabled until the
// answer arrives, then take it as their reference from the next control period on, while the
// encoders move a few counts. Every period, each PWM duty and direction equals the golden
// controller's current.
TEST(BoardUart, AnswersBecomeTheJointReferencesFromTheNextControlPeriod) {
  constexpr std::uint64_t kSeed = 20261121;
  std::cout << "vector seed " << kSeed << "\n";
  nn::Network network = random_network(31);
  InputVectors inputs(golden::quantise(network), kSeed);
  const std::array<std::int64_t, 3> x = inputs.next();
  const std::array<double, 3> target_deg{30.07, 29.95, 30.12};
  golden::QuantisedNetwork q = golden::quantise(network);
  for (int iteration = 0; iteration < 3; ++iteration) {  // the output offsets are quantised too
    const std::array<std::int64_t, 3> y = golden::evaluate_raw(q, x).alpha;
    for (int j = 0; j < 3; ++j) {
      const double shift = target_deg[j] - y[j] / 16384.0;
      network.output_min[j] += shift;
      network.output_max[j] += shift;
    }
    q = golden::quantise(network);
  }
  const std::array<std::int64_t, 3> y = golden::evaluate_raw(q, x).alpha;
  std::cout << "answer (deg) " << y[0] / 16384.0 << " " << y[1] / 16384.0 << " " << y[2] / 16384.0 << "\n";
  for (int j = 0; j < 3; ++j) ASSERT_NEAR(y[j] / 16384.0, target_deg[j], 0.01);

  const std::string mem_dir = fresh_directory("board_joint_mem");
  golden::write_export(q, mem_dir);
  BoardUart board(mem_dir);
  board.joints().enable();
  board.joints().expect_reference(y);
  board.run(3 * kClocksPerPeriod);
  EXPECT_EQ(board.joints().referenced_periods(), 0);
  EXPECT_EQ(answer_codes(board.exchange(request_frame(x)), 0), y);
  board.joints().move_encoders_to({kHomeCount + 3, kHomeCount - 2, kHomeCount + 1});
  board.run(8 * kClocksPerPeriod - board.edge() % kClocksPerPeriod);
  EXPECT_GE(board.joints().referenced_periods(), 6);
  // The reference step saturates the current for a period or two (g_ref = 1200 rad/s); the PWM
  // must also have been checked between 0 and 100 %.
  std::cout << "largest duty " << board.joints().largest_duty() << " / 1024, joint-periods with a partial duty "
            << board.joints().partial_duties() << "\n";
  EXPECT_GE(board.joints().partial_duties(), 6);
}

}  // namespace
}  // namespace delta::test
