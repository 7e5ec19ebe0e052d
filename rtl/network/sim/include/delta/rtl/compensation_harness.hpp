// Drives a Verilated backlash_compensation.sv (RTL or gate-level netlist): restart, then one
// answer pulse per network answer; returns the joint references at done_o.
//
// Model is any Verilated class with the module's ports (clk_i, rst_ni, restart_i, answer_i,
// answers_i, half_play_i, done_o, references_o). Codes travel as two's complement in `width` bits
// per joint (72-bit vectors are Verilator word arrays); the harness sign-extends the references.
// Owns its VerilatedContext.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <verilated.h>

namespace delta::rtl {

template <class Model>
class CompensationHarness {
 public:
  CompensationHarness(int width, int half_play_width, const std::array<std::int64_t, 3>& half_play)
      : width_(width), context_(new VerilatedContext) {
    context_->fatalOnError(false);
    model_ = std::make_unique<Model>(context_.get(), "compensation");
    for (int j = 0; j < 3; ++j) {
      if (half_play[j] < 0 || half_play[j] >= (std::int64_t{1} << half_play_width)) {
        throw std::out_of_range("compensation_harness: half-play " + std::to_string(half_play[j]) + " does not fit " +
                                std::to_string(half_play_width) + " unsigned bits");
      }
      set_field(model_->half_play_i, j * half_play_width, half_play_width, static_cast<std::uint64_t>(half_play[j]));
    }
    model_->clk_i = 0;
    model_->restart_i = 0;
    model_->answer_i = 0;
    model_->rst_ni = 0;
    model_->eval();
    for (int i = 0; i < 2; ++i) tick();
    model_->rst_ni = 1;
    tick();
  }

  ~CompensationHarness() {
    Verilated::threadContextp(context_.get());  // as NetworkHarness: this model's context, not another's
    model_->final();
    model_.reset();
  }
  CompensationHarness(const CompensationHarness&) = delete;
  CompensationHarness& operator=(const CompensationHarness&) = delete;

  // The next answer passes unchanged (a new recording).
  void restart() {
    model_->restart_i = 1;
    tick();
    model_->restart_i = 0;
  }

  // One answer (output codes of `width` bits, checked) -> the references, after done_o.
  std::array<std::int64_t, 3> step(const std::array<std::int64_t, 3>& answers, int max_cycles = 16) {
    for (int j = 0; j < 3; ++j) {
      const std::int64_t low = -(std::int64_t{1} << (width_ - 1));
      const std::int64_t high = (std::int64_t{1} << (width_ - 1)) - 1;
      if (answers[j] < low || answers[j] > high) {
        throw std::out_of_range("compensation_harness: answer " + std::to_string(answers[j]) + " does not fit " +
                                std::to_string(width_) + " bits");
      }
      set_field(model_->answers_i, j * width_, width_, static_cast<std::uint64_t>(answers[j]));
    }
    model_->answer_i = 1;
    tick();
    model_->answer_i = 0;
    for (int cycle = 1; cycle <= max_cycles; ++cycle) {
      tick();
      if (model_->done_o) {
        latency_cycles_ = cycle;
        std::array<std::int64_t, 3> references{};
        for (int j = 0; j < 3; ++j) references[j] = sign_extend(get_field(model_->references_o, j * width_, width_));
        return references;
      }
    }
    throw std::runtime_error("compensation_harness: no done_o within " + std::to_string(max_cycles) + " cycles");
  }

  int latency_cycles() const { return latency_cycles_; }  // clock edges from the answer's to done_o

 private:
  // A field of a port: a scalar (up to 64 bits) or a Verilator word array (VlWide).
  template <class Port>
  static void set_field(Port& port, int offset, int bits, std::uint64_t value) {
    for (int b = 0; b < bits; ++b) {
      const bool bit = (value >> b) & 1U;
      const int at = offset + b;
      if constexpr (std::is_integral_v<Port>) {
        port = static_cast<Port>((port & ~(Port{1} << at)) | (static_cast<Port>(bit) << at));
      } else {
        port[at / 32] = (port[at / 32] & ~(1U << (at % 32))) | (static_cast<std::uint32_t>(bit) << (at % 32));
      }
    }
  }
  template <class Port>
  static std::uint64_t get_field(const Port& port, int offset, int bits) {
    std::uint64_t value = 0;
    for (int b = 0; b < bits; ++b) {
      const int at = offset + b;
      std::uint64_t bit = 0;
      if constexpr (std::is_integral_v<Port>) {
        bit = (static_cast<std::uint64_t>(port) >> at) & 1U;
      } else {
        bit = (port[at / 32] >> (at % 32)) & 1U;
      }
      value |= bit << b;
    }
    return value;
  }
  std::int64_t sign_extend(std::uint64_t value) const {
    const std::uint64_t sign = std::uint64_t{1} << (width_ - 1);
    return static_cast<std::int64_t>((value ^ sign) - sign);
  }
  void tick() {
    model_->clk_i = 1;
    model_->eval();
    model_->clk_i = 0;
    model_->eval();
  }

  int width_;
  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Model> model_;
  int latency_cycles_ = 0;
};

}  // namespace delta::rtl
