// Drives a Verilated network (RTL or gate-level netlist) through its Vitis HLS ap_ctrl_hs ports.
//
// Model is any Verilated class with the ports of delta_network.sv: ap_clk, ap_rst, ap_start,
// ap_done, ap_idle, ap_ready, u_0..u_2 (scaled input codes, golden::scale_input) and y_0..y_2 (raw output codes) with
// y_k_ap_vld. Codes travel as two's complement in InputWidth / OutputWidth bits; the harness
// sign-extends outputs back to int64. Owns its VerilatedContext; FST waveforms only when asked.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include <verilated.h>
#include <verilated_fst_c.h>

namespace delta::rtl {

struct NetworkRun {
  std::array<std::int64_t, 3> outputs{};
  // Rising ap_clk edges from the one that takes ap_start (1) to the one after which ap_done is high.
  int latency_cycles = 0;
};

template <class Model>
class NetworkHarness {
 public:
  // mem_dir: directory of the .mem files (passed as +delta_mem_dir; ignored by a netlist, whose
  // memories were filled at synthesis). fst_path: empty for no waveform.
  NetworkHarness(int input_width, int output_width, const std::string& mem_dir, const std::string& fst_path = "")
      : input_width_(input_width), output_width_(output_width), context_(new VerilatedContext) {
    const std::string plusarg = "+delta_mem_dir=" + mem_dir;
    const char* argv[] = {"network_harness", plusarg.c_str()};
    context_->commandArgs(2, argv);
    context_->fatalOnError(false);
    if (!fst_path.empty()) context_->traceEverOn(true);
    model_ = std::make_unique<Model>(context_.get(), "network");
    if (!fst_path.empty()) {
      trace_ = std::make_unique<VerilatedFstC>();
      model_->trace(trace_.get(), 99);
      trace_->open(fst_path.c_str());
    }
    model_->ap_clk = 0;
    model_->ap_start = 0;
    model_->ap_rst = 1;
    model_->eval();
    check_alive();
    for (int i = 0; i < 3; ++i) tick();
    model_->ap_rst = 0;
    tick();
  }

  ~NetworkHarness() {
    if (trace_) trace_->close();
    // A Verilated model's scopes unregister through the thread's current context: make it this
    // model's, not another harness's (already gone) when two live in one process.
    Verilated::threadContextp(context_.get());
    model_->final();
    model_.reset();
  }

  NetworkHarness(const NetworkHarness&) = delete;
  NetworkHarness& operator=(const NetworkHarness&) = delete;

  // One inference: inputs must fit input_width bits (checked), returns the output codes.
  NetworkRun run(const std::array<std::int64_t, 3>& inputs, int max_cycles = 10000) {
    if (!model_->ap_idle) throw std::runtime_error("network_harness: ap_idle low before ap_start");
    set_input(model_->u_0, inputs[0]);
    set_input(model_->u_1, inputs[1]);
    set_input(model_->u_2, inputs[2]);
    model_->ap_start = 1;
    NetworkRun result;
    bool ready_seen = false;
    for (int cycle = 1; cycle <= max_cycles; ++cycle) {
      model_->eval();  // settle the inputs just set
      // ap_start is taken by the edge ending a cycle in which ap_ready is high; lower it after.
      const bool ready = model_->ap_ready;
      tick();
      if (ready) {
        ready_seen = true;
        model_->ap_start = 0;
      }
      if (model_->ap_done) {
        if (!ready_seen) throw std::runtime_error("network_harness: ap_done before ap_ready");
        if (!model_->y_0_ap_vld || !model_->y_1_ap_vld || !model_->y_2_ap_vld) {
          throw std::runtime_error("network_harness: ap_done without y_k_ap_vld");
        }
        result.outputs = {sign_extend(model_->y_0, output_width_), sign_extend(model_->y_1, output_width_),
                          sign_extend(model_->y_2, output_width_)};
        result.latency_cycles = cycle;
        return result;
      }
    }
    throw std::runtime_error("network_harness: no ap_done within " + std::to_string(max_cycles) + " cycles");
  }

  std::uint64_t cycles() const { return cycles_; }

 private:
  template <class Port>
  void set_input(Port& port, std::int64_t code) {
    const std::int64_t low = -(std::int64_t{1} << (input_width_ - 1));
    const std::int64_t high = (std::int64_t{1} << (input_width_ - 1)) - 1;
    if (code < low || code > high) {
      throw std::out_of_range("network_harness: input code " + std::to_string(code) + " does not fit " +
                              std::to_string(input_width_) + " bits");
    }
    port = static_cast<Port>(static_cast<std::uint64_t>(code) & ((std::uint64_t{1} << input_width_) - 1));
  }

  static std::int64_t sign_extend(std::uint64_t value, int width) {
    const std::uint64_t mask = (std::uint64_t{1} << width) - 1;
    value &= mask;
    const std::uint64_t sign = std::uint64_t{1} << (width - 1);
    return static_cast<std::int64_t>((value ^ sign) - sign);
  }

  void eval_and_dump() {
    model_->eval();
    if (trace_) trace_->dump(context_->time());
  }

  // One full ap_clk period (two time units): rising edge, then falling edge.
  void tick() {
    model_->ap_clk = 1;
    context_->timeInc(1);
    eval_and_dump();
    model_->ap_clk = 0;
    context_->timeInc(1);
    eval_and_dump();
    ++cycles_;
    check_alive();
  }

  void check_alive() {
    if (context_->gotFinish() || context_->gotError()) {
      throw std::runtime_error("network_harness: the model stopped ($fatal or $finish); missing .mem file?");
    }
  }

  int input_width_;
  int output_width_;
  std::unique_ptr<VerilatedContext> context_;
  std::unique_ptr<Model> model_;
  std::unique_ptr<VerilatedFstC> trace_;
  std::uint64_t cycles_ = 0;
};

}  // namespace delta::rtl
