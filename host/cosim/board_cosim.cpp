// Whole-robot co-simulation: the lab's host against the virtual board in board time (see board_cosim.hpp).
#include "delta/cosim/board_cosim.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

#include "delta/controller/run_job.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/export.hpp"
#include "delta/kinematics.hpp"
#include "delta/nn/trained_model.hpp"

namespace delta::cosim {
namespace {

using golden::answer_deg;

std::string hex(std::uint32_t value) { return golden::hex_word(value, 32); }

// The world at a truth instant, for what needs the reference (known once the telemetry names the
// sample in effect): the backlash's present lag.
struct TruthRow {
  TruthSample truth;
  Vec3 lag_deg = Vec3::Zero();
};

void check_identity(const link::IdentifyPayload& identify, const golden::QuantisedNetwork& network) {
  const std::uint32_t crc = weights_crc(network);
  if (identify.weights_crc != crc) {
    throw std::runtime_error("cosim: the board's weights CRC " + hex(identify.weights_crc) +
                             " differs from the host's " + hex(crc));
  }
  if (identify.build_id != kGatewareBuildId) {
    throw std::runtime_error("cosim: the board's gateware build id " + hex(identify.build_id) +
                             " differs from this checkout's " + hex(kGatewareBuildId));
  }
}

// The truth rows from t0 to the end of the stream, each with the stream sample the recording names
// at the nearest frame, in time order.
void join_truth(const CosimOptions& options, const std::vector<TruthRow>& rows, const RobotWorld& world,
                CosimResult& result) {
  const golden::QuantisedNetwork& network = *options.network;
  const nn::WeightsFile model = options.model != nullptr ? *options.model : nn::WeightsFile{};
  const auto& records = result.records;
  auto first = std::find_if(records.begin(), records.end(),
                            [](const controller::TelemetryRecord& r) { return r.stream_sample >= 0; });
  if (first == records.end()) return;
  const std::int64_t t0_tick = first->telemetry.tick;
  const std::int64_t end_tick = records.back().telemetry.tick;
  result.t0_s = static_cast<double>(t0_tick) * link::kTickSeconds;
  result.underruns_while_streaming = records.back().telemetry.underruns - first->telemetry.underruns;
  golden::CompensationState compensation_state;  // the deployed model's play, in time order
  std::size_t r = static_cast<std::size_t>(first - records.begin());
  for (const TruthRow& row : rows) {
    const auto tick = static_cast<std::int64_t>(std::llround(row.truth.t_s / link::kTickSeconds));
    if (tick < t0_tick || tick > end_tick) continue;
    while (r + 1 < records.size() && records[r + 1].telemetry.tick <= tick) ++r;
    // The frame nearest in time names the reference (the truth comes 0.9 ms into a frame's
    // millisecond, where the interpolation has nearly reached the next frame's answer).
    const bool next_is_nearer =
        r + 1 < records.size() && records[r + 1].telemetry.tick - tick < tick - records[r].telemetry.tick;
    const controller::TelemetryRecord& record = records[next_is_nearer ? r + 1 : r];
    CosimSample sample;
    sample.t_s = row.truth.t_s - result.t0_s;
    sample.tau_s = record.tau_s;
    sample.reference_m = record.reference_m;
    sample.position_m = row.truth.position_m;
    sample.true_alpha_deg = row.truth.true_alpha_deg;
    sample.encoder_deg = row.truth.encoder_deg;
    sample.current_a = row.truth.current_a;
    sample.drives_enabled = row.truth.drives_enabled;
    if (network.compensation.any()) {
      // The deployed model: the golden compensation of the answers, in time order (what the
      // board's interpolator targets, round_shift(25 r, 4), while it follows).
      const golden::RawOutput raw = golden::evaluate_raw(
          network, golden::encode_position(network.formats, nn::shape_setpoint(model, sample.reference_m)));
      const std::array<std::int64_t, 3> codes = golden::compensate(network.compensation, compensation_state, raw.alpha);
      for (int j = 0; j < 3; ++j) sample.network_deg[j] = golden::decode_angle_deg(network.formats, codes[j]);
    } else {
      sample.network_deg = answer_deg(network, nn::shape_setpoint(model, sample.reference_m));
    }
    // The ideal joints read their target through the backlash's play at that instant.
    sample.network_ideal_m = world.plate_for_readings(sample.network_deg, row.lag_deg);
    const IkSolution textbook = inverse_kinematics(options.nominal, sample.reference_m);
    if (!textbook.ok()) {
      throw std::runtime_error("cosim: textbook IK at t = " + std::to_string(sample.t_s) + " s: " + textbook.reason());
    }
    sample.textbook_ideal_m = world.plate_for_readings(textbook.alpha_deg, row.lag_deg);
    for (int j = 0; j < 3; ++j) {
      if (std::abs(sample.current_a[j]) >= kCurrentFullScaleA) ++result.full_scale_current_samples;
    }
    result.samples.push_back(sample);
  }
}

// The end of a run as controller::RunJob ends it: hold and disable after a completed or stopped
// stream, disable after anything else.
void stop_board(link::LinkSession& session, const controller::StreamingResult& stream) {
  using Outcome = controller::StreamingResult::Outcome;
  if (stream.outcome == Outcome::kCompleted || stream.outcome == Outcome::kStopped) {
    session.hold();
    session.disable();
  } else if (stream.outcome != Outcome::kLinkLost) {
    session.disable();
  }
}

}  // namespace

std::int64_t BoardTimeClock::now_ns() {
  return static_cast<std::int64_t>(std::llround(static_cast<double>(board_.clocks()) * 1e9 / kBoardClockHz));
}

void BoardTimeClock::sleep_until_ns(std::int64_t deadline_ns) {
  const std::int64_t now = now_ns();
  if (deadline_ns <= now) return;
  board_.step(static_cast<std::uint64_t>(std::ceil(static_cast<double>(deadline_ns - now) * kBoardClockHz / 1e9)));
}

CosimResult run_cosim(const CosimOptions& options) {
  if (options.network == nullptr) throw std::invalid_argument("run_cosim: network");
  const golden::BoardWeights weights{*options.network, options.trained_min_m, options.trained_max_m,
                                     options.model != nullptr ? *options.model : nn::WeightsFile{}};
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

  // ---- the host: only the link, its weights and the trajectory; the lab's plan and loop ----
  link::LinkSession session(stream, options.session);
  result.identify = session.identify();
  check_identity(result.identify, weights.network);
  const link::TelemetryPayload homed = session.set_home();
  result.start_position_m = controller::start_at_rest(weights, homed);
  const controller::Path path = controller::load_path(options.trajectory, options.duration_s);
  controller::StreamPlan plan(path, result.start_position_m, options.limits);
  if (auto violation = controller::check_plan(plan, options.trajectory, weights.trained_min_m, weights.trained_max_m,
                                              options.limits, &weights.model)) {
    throw PlanRefused(*violation + "; nothing sent");
  }
  result.approach_samples = plan.approach_samples();

  // ---- the truth, every 1 ms of board time (the evaluation, not the host) ----
  std::vector<TruthRow> truth;
  truth.reserve(plan.size() + 1000);
  const double total_s = static_cast<double>(plan.size()) / controller::kStreamRateHz;
  double enabled_s = -1.0, next_progress_s = 0.1;
  board.observe_truth([&](const TruthSample& sample, const RobotWorld& world) {
    if (enabled_s < 0.0) return;
    truth.push_back({sample, world.backlash_lag_deg()});
    if (options.progress && sample.t_s - enabled_s >= next_progress_s) {
      options.progress(sample.t_s - enabled_s, total_s);
      next_progress_s += 0.1;
    }
  });

  // ---- enable, hold, the streaming loop in board time (it sends the lead, then enables) ----
  session.enable();
  enabled_s = board.time_s();
  session.hold();
  controller::RecordQueue queue(plan.capacity() + 4096);  // drained after the run: room for every frame
  BoardTimeClock clock(board);
  controller::StreamingOptions streaming;
  streaming.session = session.options();
  streaming.clock = &clock;
  static const volatile std::sig_atomic_t kNoStop = 0;
  controller::StreamingLoop loop(session, plan, weights, result.start_position_m, queue, streaming, kNoStop);
  loop.run();
  result.stream = loop.result();
  stop_board(session, result.stream);
  board.observe_truth({});
  controller::TelemetryRecord record;
  while (queue.pop(record)) result.records.push_back(record);
  join_truth(options, truth, board.world(), result);

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

RunReport run_report_of(const CosimResult& result, double from_s) {
  RunColumns run;
  run.path = "the co-simulation";
  run.has_drives_column = true;
  for (std::size_t i = 0; i < result.samples.size(); ++i) {
    const CosimSample& sample = result.samples[i];
    run.t_s.push_back(sample.t_s);
    run.line.push_back(i + 1);
    run.alpha_deg.push_back(sample.encoder_deg);
    run.alpha_ref_deg.push_back(sample.network_deg);
    run.driven.push_back(sample.drives_enabled && sample.tau_s >= from_s);
    run.reference_m.push_back(sample.reference_m);
    run.plate_m.push_back(sample.position_m);
  }
  PlateTrack plate = plate_from_run(run);
  plate.source = "the virtual robot's plate (truth)";
  return make_run_report(run, &plate);
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
    if (sample.tau_s < from_s) continue;
    closed_loop.add(sample.position_m - sample.reference_m);
    network_ideal.add(sample.network_ideal_m - sample.reference_m);
    textbook_ideal.add(sample.textbook_ideal_m - sample.reference_m);
    const Vec3 joint_error = sample.encoder_deg - sample.network_deg;
    joint_sq += joint_error.cwiseProduct(joint_error);
    ++summary.samples;
  }
  // The board's own tracking, from the recording's rows in the same window: count - reference
  // (Q24.8 counts).
  Vec3 board_sq = Vec3::Zero();
  for (const controller::TelemetryRecord& r : result.records) {
    if (r.tau_s < from_s) continue;
    for (int j = 0; j < 3; ++j) {
      const double error_deg = r.telemetry.following_error_deg(j);
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
