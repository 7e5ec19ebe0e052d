// A bench around a Verilated board core (RTL or gate-level netlist) for the link v2 tests: its two
// clocks, a serial line at the board's pins (UartLine, the board's own 23 clocks per bit), the
// host's FrameDecoder on what the board sends, and quadrature encoders that can follow a target.
// A board starts with no model: load_model sends one through the link as a host does.
#pragma once

#include <verilated.h>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"
#include "delta/robot_world.hpp"
#include "delta/rtl/board_clock.hpp"
#include "delta/rtl/uart_line.hpp"

namespace delta::test {

constexpr int kLinkClocksPerBit = static_cast<int>(board::kLinkClocksPerBit);
constexpr int kBoardClocksPerPeriod = static_cast<int>(board::kClocksPerPeriod);
constexpr int kBoardHomeCount = static_cast<int>(board::kHomeCount);
constexpr std::int64_t kCyclesPerMillisecond = std::int64_t{kBoardClocksPerPeriod} * board::kPeriodsPerSetpoint;

template <typename Core>
class LinkBench {
 public:
  explicit LinkBench(const std::string& mem_dir) : context_(std::make_unique<VerilatedContext>()) {
    const std::string plusarg = "+delta_mem_dir=" + mem_dir;
    const char* argv[] = {"board_link", plusarg.c_str()};
    context_->commandArgs(2, argv);
    core_ = std::make_unique<Core>(context_.get());
    core_->rst_ni = 0;
    core_->rst_network_ni = 0;
    core_->uart_rx_i = 1;
    core_->encoder_a_i = 0;
    core_->encoder_b_i = 0;
    core_->estop_open_i = 0;  // the safety inputs at their run level
    core_->drive_fault_i = 0;
    core_->clk_i = 0;
    core_->clk_network_i = 0;
    core_->eval();
    for (int i = 0; i < 4; ++i) rtl::clock_board(*core_);
    core_->rst_ni = 1;
    core_->rst_network_ni = 1;
    core_->eval();
  }
  ~LinkBench() { core_->final(); }

  Core& core() { return *core_; }
  std::int64_t cycles() const { return cycles_; }

  void send(const std::vector<std::uint8_t>& bytes) { line_.send(bytes); }
  void send(const link::Frame& frame) { send(link::encode_frame(frame)); }
  bool sending() const { return line_.sending(); }

  // One board clock: the line drives the RX pin, the encoders their lines, the board ticks, its TX
  // pin is sampled and every completed frame decoded; then the per-cycle hook.
  void cycle() {
    core_->uart_rx_i = line_.rx_pin();
    step_encoders();
    rtl::clock_board(*core_);
    ++cycles_;
    if (line_.sample_tx_pin(core_->uart_tx_o)) {
      const std::uint8_t byte = line_.byte();
      for (link::Frame& frame : decoder_.feed(&byte, 1)) on_frame(std::move(frame));
    }
    if (hook) hook();
  }
  void run(std::int64_t count) {
    for (std::int64_t i = 0; i < count; ++i) cycle();
  }
  void run_until_sent() {
    while (line_.sending()) cycle();
  }
  // Runs until `done` holds; false after `limit` cycles without it.
  bool run_until(const std::function<bool()>& done, std::int64_t limit) {
    for (std::int64_t i = 0; i < limit; ++i) {
      if (done()) return true;
      cycle();
    }
    return done();
  }

  // Frames from the board.
  const std::vector<link::TelemetryPayload>& telemetry() const { return telemetry_; }
  // The same frames' payloads as sent (every bit, the ones the host's decoder masks included).
  const std::vector<std::vector<std::uint8_t>>& telemetry_payloads() const { return telemetry_payloads_; }
  const std::vector<std::uint8_t>& telemetry_sequences() const { return telemetry_sequences_; }
  const std::vector<link::Frame>& identify_frames() const { return identify_; }
  const link::DecoderCounters& host_decoder() const { return decoder_.counters(); }

  // Sends a frame and runs until the next telemetry frame that was snapshot after it was taken.
  link::TelemetryPayload exchange(const link::Frame& frame) {
    send(frame);
    run_until_sent();
    return next_telemetry();
  }
  link::TelemetryPayload next_telemetry() {
    const std::size_t seen = telemetry_.size();
    // A snapshot started before the frame arrived may be on its way: take the one after it.
    run_until([&] { return telemetry_.size() >= seen + 2; }, 3 * kCyclesPerMillisecond);
    return telemetry_.back();
  }
  link::Frame command(link::Command command) { return link::make_frame(next_sequence_++, command); }

  // The frames of q's load (golden::model_frames) as the host sends them.
  std::vector<link::Frame> model_frames(const golden::QuantisedNetwork& q) {
    std::vector<link::Frame> frames;
    for (const link::ModelPayload& payload : golden::model_frames(q))
      frames.push_back(link::make_frame(next_sequence_++, payload));
    return frames;
  }
  // Sends frames back to back and runs until the board has taken the last (its CRC included).
  void send_all(const std::vector<link::Frame>& frames) {
    for (const link::Frame& frame : frames) send(frame);
    run_until_sent();
    run(kFrameSettleCycles);
  }
  // Loads q's model through the link as a host does (the drives off): the board then holds it.
  void load_model(const golden::QuantisedNetwork& q) { send_all(model_frames(q)); }
  // Cycles from a frame's last stop bit until the board has acted on it (uart_rx, link_rx, the
  // loader's CRC), with a margin.
  static constexpr std::int64_t kFrameSettleCycles = 4 * kLinkClocksPerBit + board::kModelCrcClocks;
  std::uint8_t next_sequence() { return next_sequence_++; }

  // Encoders: counts moved from the home count, stepped one quadrature state every 16 cycles
  // towards target_counts (the count the board should read).
  std::array<int, 3> target_counts{kBoardHomeCount, kBoardHomeCount, kBoardHomeCount};
  std::array<int, 3> counts() const { return counts_; }
  // After an accepted set home: the board reads the home count wherever the lines are.
  void homed() {
    counts_ = {kBoardHomeCount, kBoardHomeCount, kBoardHomeCount};
    target_counts = counts_;
  }
  std::function<void()> hook;

 private:
  void on_frame(link::Frame frame) {
    if (frame.type == link::FrameType::kTelemetry) {
      telemetry_sequences_.push_back(frame.sequence);
      telemetry_.push_back(link::decode_telemetry(frame.payload));
      telemetry_payloads_.push_back(frame.payload);
    } else if (frame.type == link::FrameType::kIdentify) {
      identify_.push_back(std::move(frame));
    }
  }
  void step_encoders() {
    if (cycles_ % 16 == 0) {
      for (int j = 0; j < 3; ++j) {
        const int step = (target_counts[j] > counts_[j]) - (target_counts[j] < counts_[j]);
        counts_[j] += step;
        position_[j] += step;
      }
    }
    int a = 0, b = 0;
    for (int j = 0; j < 3; ++j) {
      a |= quadrature_a(position_[j]) << j;
      b |= quadrature_b(position_[j]) << j;
    }
    core_->encoder_a_i = a;
    core_->encoder_b_i = b;
  }

  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Core> core_;
  rtl::UartLine line_{kLinkClocksPerBit};
  link::FrameDecoder decoder_{link::Receiver::kHost};
  std::vector<link::TelemetryPayload> telemetry_;
  std::vector<std::vector<std::uint8_t>> telemetry_payloads_;
  std::vector<std::uint8_t> telemetry_sequences_;
  std::vector<link::Frame> identify_;
  std::int64_t cycles_ = 0;
  std::array<int, 3> counts_{kBoardHomeCount, kBoardHomeCount, kBoardHomeCount};  // what the board counts
  std::array<int, 3> position_{0, 0, 0};                                          // quadrature position of the lines
  std::uint8_t next_sequence_ = 1;
};

}  // namespace delta::test
