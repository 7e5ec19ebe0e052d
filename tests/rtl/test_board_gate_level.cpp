// The board core's gate-level netlist (yosys synth_ice40: LUTs, carries, flip-flops, DSPs and the
// block RAMs with the shipped weights and identify.mem) against its RTL, in lockstep through the
// link: the same bytes on both RX pins and the same encoder lines, every output pin equal on every
// board cycle (UART TX, PWM, direction, enable, fault and its causes, encoder errors, LEDs), and
// the netlist's own frames decoded by the host codec: identify without and with the model, the
// model loaded through its frames, telemetry, commands, setpoints played, corrupted frames counted.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "Vboard_core.h"
#include "Vboard_core_gate.h"
#include "board_link_bench.hpp"
#include "delta/gateware.hpp"
#include "delta/geometry.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/kinematics.hpp"
#include "delta/nn/weights_file.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

using link::Command;

// Every output pin of the core after a board cycle, packed.
template <typename Core>
std::uint32_t output_pins(const Core& core) {
  return static_cast<std::uint32_t>(core.uart_tx_o) | core.drive_pwm_o << 1 | core.drive_dir_o << 4 |
         core.drive_enable_o << 7 | core.joint_fault_o << 8 | core.joint_fault_cause_o << 9 |
         core.encoder_error_o << 13 | core.joint_limited_o << 16 | core.led_green_o << 17 | core.led_red_o << 18;
}

struct Outcome {
  std::vector<std::uint32_t> pins;  // after every board cycle
  std::vector<link::Frame> identify;
  std::vector<link::TelemetryPayload> telemetry;
  link::DecoderCounters host_decoder;
  int corrupted = 0;
};

// The scenario, the same for both models (two Verilated models alive in one thread hang in
// eval(), so the RTL runs first and the netlist after it): identify, the model's load, identify,
// set home, enable, 12
// setpoints around the home pose in one burst with a corrupted copy after every fourth, the
// board plays them and holds while the joints follow the references the telemetry reports, then
// disable.
template <typename Core>
Outcome run_scenario(const std::string& mem_dir, const golden::QuantisedNetwork& q, std::uint64_t seed) {
  LinkBench<Core> bench(mem_dir);
  Outcome outcome;
  bench.hook = [&] { outcome.pins.push_back(output_pins(bench.core())); };
  std::mt19937_64 random(seed);
  std::uint8_t sequence = 1;
  bench.send(link::make_identify_request(0x33));
  bench.run(2 * kCyclesPerMillisecond);
  bench.load_model(q);
  bench.send(link::make_identify_request(0x34));
  bench.send(link::make_frame(sequence++, Command::kSetHome));
  bench.run(2 * kCyclesPerMillisecond);
  bench.homed();
  bench.send(link::make_frame(sequence++, Command::kEnable));
  const Vec3 centre = forward_kinematics(Geometry::nominal(), Vec3(30.0, 30.0, 30.0)).position_m;
  for (std::uint32_t n = 0; n < 12; ++n) {
    link::SetpointPayload setpoint;
    setpoint.sample_index = n;
    const Vec3 p = centre + Vec3(0.0005 * std::sin(0.3 * n), 0.0005 * std::cos(0.3 * n) - 0.0005, 0.0);
    setpoint.input_code = golden::setpoint_input(q, golden::encode_position(q.formats, p));
    std::vector<std::uint8_t> bytes = link::encode_frame(link::make_frame(sequence++, setpoint));
    bench.send(bytes);
    if (n % 4 == 3) {
      bytes[4 + random() % board::kSetpointPayloadBytes] ^= static_cast<std::uint8_t>(1u << (random() % 8));
      bench.send(bytes);
      ++outcome.corrupted;
    }
  }
  for (int ms = 0; ms < 18; ++ms) {
    bench.run(kCyclesPerMillisecond);
    if (!bench.telemetry().empty()) {
      for (int j = 0; j < 3; ++j)
        bench.target_counts[j] = static_cast<int>(golden::round_shift(bench.telemetry().back().references[j], 8));
    }
  }
  bench.send(link::make_frame(sequence++, Command::kDisable));
  bench.run(3 * kCyclesPerMillisecond);
  outcome.identify = bench.identify_frames();
  outcome.telemetry = bench.telemetry();
  outcome.host_decoder = bench.host_decoder();
  return outcome;
}

TEST(BoardGateLevel, NetlistAndRtlAgreePinForPinOverTheLink) {
  const std::uint64_t seed = 5;
  std::cout << "seed " << seed << "\n";
  // The shipped model is the deployed one: the netlist's interpolator carries its half-plays.
  const std::string weights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
  const golden::QuantisedNetwork q = golden::quantise_file(weights, nn::read_weights_file(weights));
  ASSERT_TRUE(q.compensation.any());
  // Both load the model through the link; the netlist's block RAMs hold the build's tanh tables and
  // identify.mem (rtl/network/mem), the RTL reads the same files.
  const std::string mem_dir = std::string(DELTA_BINARY_DIR) + "/rtl/network/mem";
  const Outcome rtl = run_scenario<Vboard_core>(mem_dir, q, seed);
  const auto start = std::chrono::steady_clock::now();
  const Outcome gate = run_scenario<Vboard_core_gate>(mem_dir, q, seed);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << gate.pins.size() << " board cycles of the netlist, " << gate.pins.size() / seconds << " cycles/s\n";

  ASSERT_EQ(rtl.pins.size(), gate.pins.size());
  std::int64_t mismatches = 0;
  for (std::size_t i = 0; i < rtl.pins.size(); ++i) {
    if (rtl.pins[i] != gate.pins[i] && ++mismatches <= 5)
      ADD_FAILURE() << "cycle " << i << ": pins rtl 0x" << std::hex << rtl.pins[i] << ", netlist 0x" << gate.pins[i]
                    << std::dec;
  }
  EXPECT_EQ(mismatches, 0);

  ASSERT_EQ(gate.identify.size(), 2u);
  EXPECT_EQ(gate.identify[0].sequence, 0x33);
  EXPECT_EQ(gate.identify[1].sequence, 0x34);
  const link::IdentifyPayload identify = link::decode_identify(gate.identify[0].payload);
  EXPECT_EQ(identify.build_id, kGatewareBuildId);
  EXPECT_EQ(identify.weights_crc, 0u) << "no model before the load";
  EXPECT_EQ(link::decode_identify(gate.identify[1].payload).weights_crc, weights_crc(q));
  ASSERT_GE(gate.telemetry.size(), 20u);
  const link::TelemetryPayload& last = gate.telemetry.back();
  std::cout << gate.telemetry.size() << " telemetry frames from the netlist; played " << last.sample_index
            << ", bad frames " << last.bad_frames << ", underruns " << last.underruns << "\n";
  EXPECT_EQ(last.sample_index, 12u);
  EXPECT_EQ(last.bad_frames, gate.corrupted);
  EXPECT_FALSE(last.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_FALSE(last.has(link::TelemetryFlag::kFault));
  EXPECT_TRUE(last.has(link::TelemetryFlag::kModel));
  EXPECT_EQ(gate.host_decoder.bad_crc, 0u);
  bool drove = false;
  for (const auto& t : gate.telemetry)
    drove = drove || (t.has(link::TelemetryFlag::kDriveEnable) && t.currents != std::array<std::int16_t, 3>{});
  EXPECT_TRUE(drove) << "the netlist drove the joints";
}

}  // namespace
}  // namespace delta::test
