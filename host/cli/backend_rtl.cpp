// The `rtl` inverse-kinematics back end: poses through the Verilated network RTL (delta_network.sv
// at the board's ReuseFactor 75), one ap_ctrl_hs transaction per pose; for a deployed model in
// time order the answers then pass the Verilated backlash_compensation.sv, row by row.
//
// W.json is quantised by the golden model's quantise() (which refuses weights that would
// saturate), written as the .mem files the RTL loads ($readmemh, +delta_mem_dir), and every pose
// is encoded to raw input codes exactly as the fixed back end does, so the raw output codes of
// fixed, hls and rtl must be identical.
#include <memory>
#include <string>

#include "Vbacklash_compensation.h"
#include "Vdelta_network.h"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/ik_backend.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/rtl/compensation_harness.hpp"
#include "delta/rtl/network_harness.hpp"
#include "delta/temporary_directory.hpp"

namespace delta::rtl {
namespace {

class RtlIkBackend : public IkBackend {
 public:
  explicit RtlIkBackend(const std::string& weights_path) : weights_(nn::read_weights_file(weights_path)) {
    if (weights_.network.hidden() != 25) {
      throw InputError(weights_path, 0,
                       "has " + std::to_string(weights_.network.hidden()) + " hidden neurons; the RTL is built for 25");
    }
    quantised_ = golden::quantise_file(weights_path, weights_);  // a deployed model's half-plays too
    golden::write_export(quantised_, directory_.path());
    network_ = std::make_unique<NetworkHarness<Vdelta_network>>(quantised_.formats.scaled_input_bits,
                                                                quantised_.formats.output_bits, directory_.path());
    compensation_ = std::make_unique<CompensationHarness<Vbacklash_compensation>>(
        quantised_.formats.output_bits, quantised_.formats.half_play_bits, quantised_.compensation.half_play);
  }

  bool has_raw_codes() const override { return true; }

  bool has_time_ordered_parts() const override { return weights_.deployed(); }

  std::vector<IkRow> evaluate(const std::vector<Vec3>& positions_m, bool in_time_order) override {
    const bool compensate = in_time_order && weights_.deployed();
    std::vector<IkRow> rows(positions_m.size());
    for (std::size_t i = 0; i < positions_m.size(); ++i) {
      bool clamped = false;
      const std::array<std::int64_t, 3> codes =
          golden::encode_position(quantised_.formats, nn::shape_setpoint(weights_, positions_m[i]), &clamped);
      if (clamped) ++clamped_positions_;
      // Spec step 2 on the host, as for the board's setpoints; the RTL network takes u.
      const NetworkRun run = network_->run(golden::scale_input(quantised_, codes).code);
      latency_cycles_ = run.latency_cycles;
      rows[i].raw = run.outputs;
      if (compensate) {
        if (i == 0) compensation_->restart();
        rows[i].raw = compensation_->step(run.outputs);
      }
      for (int o = 0; o < 3; ++o) {
        rows[i].alpha_deg[o] = golden::decode_angle_deg(quantised_.formats, rows[i].raw[o]);
        const std::int64_t limit = std::int64_t{1} << (quantised_.formats.output_bits - 1);
        if (run.outputs[o] == limit - 1 || run.outputs[o] == -limit) ++outputs_at_limit_;
      }
      nn::add_hybrid_math_model(weights_, positions_m[i], rows[i]);  // raw codes: the residual
    }
    return rows;
  }

  std::vector<std::string> report() const override {
    return {"rtl: delta_network.sv (Verilator), ReuseFactor 75, latency " + std::to_string(latency_cycles_) +
                " cycles per pose" + (weights_.hybrid() ? "; raw codes are the residual added to the math model" : "") +
                (weights_.deployed() ? "; deployed model: + backlash_compensation.sv in time order (" +
                                           std::to_string(compensation_->latency_cycles()) + " cycles)"
                                     : "") +
                (weights_.joint_ripple.empty() ? "" : "; positions shaped by its joint ripple table first"),
            "positions clamped to the 32-bit input code: " + std::to_string(clamped_positions_),
            "output codes at the 24-bit limit (saturated): " + std::to_string(outputs_at_limit_)};
  }

 private:
  nn::WeightsFile weights_;
  golden::QuantisedNetwork quantised_;
  TemporaryDirectory directory_{"deltactl_rtl"};
  std::unique_ptr<NetworkHarness<Vdelta_network>> network_;
  std::unique_ptr<CompensationHarness<Vbacklash_compensation>> compensation_;  // backlash_compensation.sv
  std::size_t clamped_positions_ = 0;
  std::size_t outputs_at_limit_ = 0;
  int latency_cycles_ = 0;
};

const RegisterIkBackend rtl_backend(
    "rtl", "the network RTL (rtl/network/delta_network.sv) simulated by Verilator; raw codes as 'fixed'",
    [](const std::string& weights_path) { return std::make_unique<RtlIkBackend>(weights_path); });

}  // namespace
}  // namespace delta::rtl
