// Whole-robot co-simulation around the Verilated board core (see board_cosim.hpp).
#include "delta/cosim/board_cosim.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "Vboard_core.h"
#include "delta/board_facts.hpp"
#include "delta/kinematics.hpp"
#include "delta/link_v1.hpp"
#include "delta/robot_world.hpp"
#include "delta/rtl/board_clock.hpp"
#include "delta/rtl/uart_line.hpp"
#include "delta/trajectory.hpp"
#include "verilated.h"

namespace delta::cosim {

CosimResult run_cosim(const CosimOptions& options) {
  CosimResult result;
  // The world: plants, sensor effects, encoders, PWM averaging, with the board's facts.
  BoardInterface board_interface;
  board_interface.board_clock_hz = kBoardClockHz;
  board_interface.pwm_period_cycles = static_cast<int>(board::kPwmPeriodCycles);
  board_interface.current_full_scale_a = kCurrentFullScaleA;
  board_interface.home_count = kHomeCount;
  board_interface.count_deg = kCountDeg;
  RobotWorld world(board_interface, options.effects, options.nominal, options.plant);
  result.home_true_alpha_deg = world.home_true_alpha_deg();

  // The board: the Verilated board core behind its UART pins.
  auto context = std::make_unique<VerilatedContext>();
  const std::string plusarg = "+delta_mem_dir=" + options.mem_dir;
  const char* argv[] = {"cosim", plusarg.c_str()};
  context->commandArgs(2, argv);
  auto core = std::make_unique<Vboard_core>(context.get(), "board");
  core->uart_rx_i = 1;
  core->encoder_a_i = 0;
  core->encoder_b_i = 0;
  core->rst_ni = 0;
  core->rst_network_ni = 0;
  for (int i = 0; i < 4; ++i) rtl::clock_board(*core);
  core->rst_ni = 1;
  core->rst_network_ni = 1;
  rtl::UartLine line(kClocksPerBit);

  // The host: streams the reference, one request in flight, knowing only the bytes it gets.
  auto reference_at = [&](double t) -> Vec3 {
    const double s = options.blend_s > 0.0 ? quintic_blend(t / options.blend_s) : 1.0;
    return (1.0 - s) * world.home_measured_m() + s * options.trajectory(t);
  };
  link_v1::LinkV1Client host(kClocksPerBit);
  Vec3 sent_reference = world.home_measured_m();
  Vec3 network_deg = Vec3::Constant(kHomeCount * kCountDeg);

  const auto total_cycles = static_cast<std::uint64_t>(std::llround(options.duration_s * kBoardClockHz));
  const auto record_every =
      static_cast<std::uint64_t>(std::max(1.0, std::round(kBoardClockHz / options.record_rate_hz)));
  const auto progress_every = static_cast<std::uint64_t>(0.1 * kBoardClockHz);

  for (std::uint64_t cycle = 0; cycle < total_cycles; ++cycle) {
    const double t = static_cast<double>(cycle) / kBoardClockHz;
    // Host: the next request as soon as the previous answer is in.
    if (host.idle()) {
      bool clamped = false;
      sent_reference = reference_at(t);
      line.send(host.request(options.encode_position(sent_reference, &clamped)));
      if (clamped) ++result.clamped_positions;
    }
    core->uart_rx_i = line.rx_pin();
    core->encoder_a_i = world.encoder_a();
    core->encoder_b_i = world.encoder_b();

    rtl::clock_board(*core);

    if (line.sample_tx_pin(core->uart_tx_o)) host.receive(line.byte());
    if (!line.sending() && host.elapse()) {
      if (const auto codes = link_v1::parse_answer(host.answer())) {
        ++result.round_trips;
        if (result.first_answer_s < 0.0) result.first_answer_s = t;
        for (int o = 0; o < 3; ++o) network_deg[o] = options.decode_angle_deg((*codes)[o]);
      } else {
        ++result.naks;
      }
    }

    world.step({core->drive_pwm_o, core->drive_dir_o, static_cast<bool>(core->drive_enable_o)});

    if (cycle % record_every == 0) {
      CosimSample sample;
      // The ideal joints read their target through the backlash's present play.
      sample.network_ideal_m = world.plate_for_readings(network_deg);
      const IkSolution textbook = inverse_kinematics(options.nominal, sent_reference);
      if (!textbook.ok())
        throw std::runtime_error("cosim: textbook IK at t = " + std::to_string(t) + " s: " + textbook.reason());
      sample.textbook_ideal_m = world.plate_for_readings(textbook.alpha_deg);
      sample.t_s = t;
      sample.reference_m = sent_reference;
      sample.position_m = world.measured_position_m();
      sample.true_alpha_deg = world.true_alpha_deg();
      sample.encoder_deg = world.encoder_deg();
      sample.network_deg = network_deg;
      sample.current_a = world.current_a();
      sample.drives_enabled = core->drive_enable_o;
      for (int j = 0; j < 3; ++j) {
        if (std::abs(sample.current_a[j]) >= kCurrentFullScaleA) ++result.full_scale_current_samples;
      }
      result.samples.push_back(sample);
    }
    if (options.progress && cycle % progress_every == 0 && cycle > 0) options.progress(t);
  }
  result.encoder_error_bits = core->encoder_error_o;
  result.joint_limited = core->joint_limited_o;
  result.fault_cause_bits = core->joint_fault_cause_o;
  result.board_cycles = total_cycles;
  core->final();
  return result;
}

TrackingSummary summarise(const CosimResult& result, double from_s) {
  TrackingSummary summary;
  Vec3 joint_sq = Vec3::Zero();
  struct Accumulator {
    Vec3 sum_sq = Vec3::Zero();
    double distance_sq = 0.0, max_distance = 0.0;
    void add(const Vec3& error) {
      sum_sq += error.cwiseProduct(error);
      distance_sq += error.squaredNorm();
      max_distance = std::max(max_distance, error.norm());
    }
    ErrorStats stats(double n) const { return {(sum_sq / n).cwiseSqrt(), std::sqrt(distance_sq / n), max_distance}; }
  } closed_loop, network_ideal, textbook_ideal;
  for (const CosimSample& sample : result.samples) {
    if (sample.t_s < from_s) continue;
    closed_loop.add(sample.position_m - sample.reference_m);
    network_ideal.add(sample.network_ideal_m - sample.reference_m);
    textbook_ideal.add(sample.textbook_ideal_m - sample.reference_m);
    const Vec3 joint_error = sample.encoder_deg - sample.network_deg;
    joint_sq += joint_error.cwiseProduct(joint_error);
    ++summary.samples;
  }
  if (summary.samples == 0) return summary;
  const double n = static_cast<double>(summary.samples);
  summary.closed_loop = closed_loop.stats(n);
  summary.network_ideal = network_ideal.stats(n);
  summary.textbook_ideal = textbook_ideal.stats(n);
  summary.joint_rms_deg = (joint_sq / n).cwiseSqrt();
  return summary;
}

}  // namespace delta::cosim
