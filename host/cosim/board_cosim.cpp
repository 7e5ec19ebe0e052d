// Whole-robot co-simulation over the link v2 with the virtual board (see board_cosim.hpp).
#include "delta/cosim/board_cosim.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

#include "delta/gateware.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/export.hpp"
#include "delta/kinematics.hpp"
#include "delta/trajectory.hpp"

namespace delta::cosim {
namespace {

using golden::answer_deg;

std::string hex(std::uint32_t value) { return golden::hex_word(value, 32); }

}  // namespace

CosimResult run_cosim(const CosimOptions& options) {
  if (options.network == nullptr || !options.trajectory)
    throw std::invalid_argument("run_cosim: network and trajectory");
  const golden::QuantisedNetwork& network = *options.network;
  CosimResult result;

  // ---- the board (world and RTL) ----
  VirtualBoardOptions board_options;
  board_options.fidelity = options.fidelity;
  board_options.network = options.network;
  board_options.mem_dir = options.mem_dir;
  board_options.effects = options.effects;
  board_options.nominal = options.nominal;
  board_options.plant = options.plant;
  VirtualBoard board(board_options);
  if (options.period_observer) board.observe_periods(options.period_observer);
  result.home_true_alpha_deg = board.world().home_true_alpha_deg();
  VirtualBoardStream stream(board);

  // ---- the host: only the link, its weights and the trajectory ----
  link::LinkSession session(stream, options.session);
  result.identify = session.identify();
  const std::uint32_t crc = weights_crc(network);
  if (result.identify.weights_crc != crc) {
    throw std::runtime_error("cosim: the board's weights CRC " + hex(result.identify.weights_crc) +
                             " differs from the host's " + hex(crc));
  }
  if (result.identify.build_id != kGatewareBuildId) {
    throw std::runtime_error("cosim: the board's gateware build id " + hex(result.identify.build_id) +
                             " differs from this checkout's " + hex(kGatewareBuildId));
  }
  session.set_home();
  const link::TelemetryPayload enabled = session.enable();
  Vec3 counts_deg;
  for (int j = 0; j < 3; ++j) counts_deg[j] = enabled.counts[j] * kCountDeg;
  result.start_position_m = locate_plate(network, options.nominal, counts_deg);
  // The stream's first sample reaches the joints at tick T + 20 of the frame it is sent after.
  const std::int64_t first_reach_tick = static_cast<std::int64_t>(enabled.tick) + 2 * link::kTicksPerSetpoint;
  result.t0_s = first_reach_tick * link::kTickSeconds;
  const Vec3 start = result.start_position_m;
  auto reference_at = [&](double tau) -> Vec3 {
    tau = std::max(tau, 0.0);
    const double s = options.blend_s > 0.0 ? quintic_blend(tau / options.blend_s) : 1.0;
    return (1.0 - s) * start + s * options.trajectory(tau);
  };
  const std::size_t samples = static_cast<std::size_t>(std::llround(options.duration_s * 1000.0)) + 1;
  result.samples.reserve(samples);
  auto source = [&](std::size_t /*k*/, std::int64_t reach_tick) {
    bool clamped = false;
    const auto codes =
        golden::encode_position(network.formats, reference_at(reach_tick * link::kTickSeconds - result.t0_s), &clamped);
    if (clamped) ++result.clamped_positions;
    return std::array<std::int32_t, 3>{static_cast<std::int32_t>(codes[0]), static_cast<std::int32_t>(codes[1]),
                                       static_cast<std::int32_t>(codes[2])};
  };
  double next_progress = 0.1;
  auto observer = [&](const link::TelemetryPayload& t) {
    const double tau = t.tick * link::kTickSeconds - result.t0_s;
    if (options.progress && tau >= next_progress) {
      options.progress(tau);
      next_progress += 0.1;
    }
    return true;
  };

  // ---- the truth, every 1 ms of board time from t0 (the evaluation, not the host) ----
  golden::CompensationState compensation_state;  // the deployed model's play, in time order
  board.observe_truth([&](const TruthSample& truth, const RobotWorld& world) {
    const double tau = truth.t_s - result.t0_s;
    if (tau < -1e-9 || tau >= options.duration_s - 1e-9) return;
    CosimSample sample;
    sample.t_s = tau;
    sample.reference_m = reference_at(tau);
    sample.position_m = truth.position_m;
    sample.true_alpha_deg = truth.true_alpha_deg;
    sample.encoder_deg = truth.encoder_deg;
    sample.current_a = truth.current_a;
    sample.drives_enabled = truth.drives_enabled;
    if (network.compensation.any()) {
      // The deployed model: the golden compensation of the answers, in time order (what the
      // board's interpolator targets, round_shift(25 r, 4), while it follows).
      const golden::RawOutput raw =
          golden::evaluate_raw(network, golden::encode_position(network.formats, sample.reference_m));
      const std::array<std::int64_t, 3> codes = golden::compensate(network.compensation, compensation_state, raw.alpha);
      for (int j = 0; j < 3; ++j) sample.network_deg[j] = golden::decode_angle_deg(network.formats, codes[j]);
    } else {
      sample.network_deg = answer_deg(network, sample.reference_m);
    }
    // The ideal joints read their target through the backlash's present play.
    sample.network_ideal_m = world.plate_for_readings(sample.network_deg);
    const IkSolution textbook = inverse_kinematics(options.nominal, sample.reference_m);
    if (!textbook.ok()) {
      throw std::runtime_error("cosim: textbook IK at tau = " + std::to_string(tau) + " s: " + textbook.reason());
    }
    sample.textbook_ideal_m = world.plate_for_readings(textbook.alpha_deg);
    for (int j = 0; j < 3; ++j) {
      if (std::abs(sample.current_a[j]) >= kCurrentFullScaleA) ++result.full_scale_current_samples;
    }
    result.samples.push_back(sample);
  });

  result.stream = session.stream(samples, source, observer);
  if (result.stream.outcome == link::StreamReport::Outcome::kCompleted) {
    session.hold();
    session.disable();
  }
  board.observe_truth({});
  result.telemetry = session.telemetry();
  result.link = session.statistics();
  const link::TelemetryPayload& last = *session.last_telemetry();
  result.bad_frames = last.bad_frames;
  result.rejected = last.rejected;
  result.slew_limits = last.slew_limits;
  result.saturations = last.saturations;
  result.pins = board.pins();
  result.board_cycles = board.clocks();
  result.board_busy_s = board.busy_s();
  return result;
}

TrackingSummary summarise(const CosimResult& result, double from_s) {
  TrackingSummary summary;
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
  Vec3 joint_sq = Vec3::Zero();
  for (const CosimSample& sample : result.samples) {
    if (sample.t_s < from_s) continue;
    closed_loop.add(sample.position_m - sample.reference_m);
    network_ideal.add(sample.network_ideal_m - sample.reference_m);
    textbook_ideal.add(sample.textbook_ideal_m - sample.reference_m);
    const Vec3 joint_error = sample.encoder_deg - sample.network_deg;
    joint_sq += joint_error.cwiseProduct(joint_error);
    ++summary.samples;
  }
  // The board's own tracking, from telemetry in the same window: count - reference (Q24.8 counts).
  const double end_s = result.samples.empty() ? 0.0 : result.samples.back().t_s;
  Vec3 board_sq = Vec3::Zero();
  for (const link::TelemetryPayload& t : result.telemetry) {
    const double tau = t.tick * link::kTickSeconds - result.t0_s;
    if (tau < from_s || tau > end_s) continue;
    for (int j = 0; j < 3; ++j) {
      const double error_deg = (t.counts[j] - t.references[j] / 256.0) * kCountDeg;
      board_sq[j] += error_deg * error_deg;
    }
    ++summary.telemetry_frames;
  }
  if (summary.telemetry_frames > 0) {
    summary.board_joint_rms_deg = (board_sq / static_cast<double>(summary.telemetry_frames)).cwiseSqrt();
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
