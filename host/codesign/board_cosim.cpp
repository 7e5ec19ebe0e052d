// Whole-robot co-simulation around the Verilated board core (see board_cosim.hpp).
#include "delta/cosim/board_cosim.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <memory>
#include <stdexcept>

#include "Vboard_core.h"
#include "delta/rtl/board_link.hpp"
#include "delta/kinematics.hpp"
#include "delta/trajectory.hpp"
#include "verilated.h"

namespace delta::cosim {
namespace {

constexpr int kPlantDivider = 20;    // board cycles per plant step (1 us)
constexpr int kPwmPeriod = 1024;     // joint_axes' PWM period in board cycles
constexpr int kQuadratureDwell = 4;  // board cycles per quadrature state, at least
constexpr double kCurrentFullScaleA = 0.5;
constexpr double kCountDeg = 0.01;

// The true angle at which joint j's encoder reads `reading_deg` (bisection over +-20 deg).
double true_angle_for_reading(const JointSensorChain& sensors, int joint, double reading_deg) {
  auto error = [&](double true_deg) { return sensors.reading_without_backlash(joint, true_deg) - reading_deg; };
  double low = reading_deg - 20.0, high = reading_deg + 20.0;
  if (error(low) * error(high) > 0) {
    throw std::runtime_error("cosim: no true angle of joint " + std::to_string(joint + 1) + " reads " +
                             std::to_string(reading_deg) + " deg within +-20 deg");
  }
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (low + high);
    if (error(mid) * error(low) <= 0) {
      high = mid;
    } else {
      low = mid;
    }
  }
  return 0.5 * (low + high);
}

// Host side of the UART link: 8N1 at kClocksPerBit board cycles per bit, one request at a time.
class UartHost {
 public:
  bool idle() const { return tx_bits_.empty() && !awaiting_; }

  void send(const std::vector<std::uint8_t>& bytes) {
    for (std::uint8_t byte : bytes) {
      tx_bits_.push_back(0);
      for (int b = 0; b < 8; ++b) tx_bits_.push_back((byte >> b) & 1);
      tx_bits_.push_back(1);
    }
    awaiting_ = true;
    idle_cycles_ = 0;
  }

  // Level of the host's TX line for this board cycle.
  int tx_level() {
    if (tx_bits_.empty()) return 1;
    const int bit = tx_bits_.front();
    if (++tx_phase_ == kClocksPerBit) {
      tx_phase_ = 0;
      tx_bits_.pop_front();
    }
    return bit;
  }

  // The board's TX line after a board cycle. Returns true when a whole answer has arrived
  // (11 bytes, or a 1-byte NAK followed by silence); the bytes are in answer().
  bool receive(int rx) {
    if (rx_phase_ < 0) {
      if (rx == 0) rx_phase_ = 0;
    } else {
      ++rx_phase_;
      const int offset = rx_phase_ - kClocksPerBit / 2;
      if (offset % kClocksPerBit == 0) {
        const int bit_index = offset / kClocksPerBit;  // 0 start, 1..8 data, 9 stop
        if (bit_index >= 1 && bit_index <= 8) rx_byte_ |= rx << (bit_index - 1);
        if (bit_index == 9) {
          received_.push_back(static_cast<std::uint8_t>(rx_byte_));
          rx_byte_ = 0;
          rx_phase_ = -1;
          idle_cycles_ = 0;
        }
      }
    }
    if (!awaiting_ || !tx_bits_.empty()) return false;
    ++idle_cycles_;
    const bool complete = (received_.size() >= 11 && received_[0] == 0x5A) ||
                          (received_.size() == 1 && received_[0] == 0x15 && idle_cycles_ > 20 * kClocksPerBit);
    if (!complete && idle_cycles_ < 4000 * kClocksPerBit) return false;  // a lost answer times out
    answer_.assign(received_.begin(), received_.end());
    received_.clear();
    awaiting_ = false;
    return true;
  }
  const std::vector<std::uint8_t>& answer() const { return answer_; }

 private:
  std::deque<int> tx_bits_;
  int tx_phase_ = 0;
  bool awaiting_ = false;
  int rx_phase_ = -1;
  int rx_byte_ = 0;
  int idle_cycles_ = 0;
  std::vector<std::uint8_t> received_;
  std::vector<std::uint8_t> answer_;
};

// Quadrature signals that follow a target count one state per kQuadratureDwell cycles.
class QuadratureEmitter {
 public:
  explicit QuadratureEmitter(int count) : count_(count), target_(count) {}
  void set_target(int count) { target_ = count; }
  void step() {
    if (++dwell_ < kQuadratureDwell || count_ == target_) return;
    dwell_ = 0;
    count_ += count_ < target_ ? 1 : -1;
  }
  int count() const { return count_; }
  int a() const { return quadrature_a(count_ - kHomeCount); }
  int b() const { return quadrature_b(count_ - kHomeCount); }

 private:
  int count_;
  int target_;
  int dwell_ = 0;
};

}  // namespace

CosimResult run_cosim(const CosimOptions& options) {
  CosimResult result;
  const Geometry true_geometry = apply_geometry_effects(options.nominal, options.effects);

  // Home: the encoders read 30.00 deg (board_core's HomeCount) with the plate at rest there.
  JointSensorChain sensors(options.effects);
  for (int j = 0; j < 3; ++j) {
    result.home_true_alpha_deg[j] = true_angle_for_reading(sensors, j, kHomeCount * kCountDeg);
  }
  const FkSolution home = forward_kinematics(true_geometry, result.home_true_alpha_deg);
  if (!home.ok()) throw std::runtime_error("cosim: home pose: " + home.reason());
  const Vec3 home_measured_m = apply_frame_misalignment(options.effects, home.position_m);

  std::array<std::unique_ptr<JointPlant>, 3> plants;
  JointPlantParameters plant_parameters = options.plant;
  plant_parameters.substeps = 1;  // the plant step (1 us) is already short
  for (int j = 0; j < 3; ++j) plants[j] = std::make_unique<JointPlant>(plant_parameters, result.home_true_alpha_deg[j]);
  std::array<QuadratureEmitter, 3> encoders{QuadratureEmitter(kHomeCount), QuadratureEmitter(kHomeCount),
                                            QuadratureEmitter(kHomeCount)};

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
  for (int i = 0; i < 4; ++i) clock_board(*core);
  core->rst_ni = 1;
  core->rst_network_ni = 1;

  // Measured plate position if the encoders read `readings` (the static sensor chain inverted).
  auto plate_for_readings = [&](const Vec3& readings) -> Vec3 {
    Vec3 alpha;
    for (int j = 0; j < 3; ++j) alpha[j] = true_angle_for_reading(sensors, j, readings[j]);
    const FkSolution plate = forward_kinematics(true_geometry, alpha);
    if (!plate.ok()) throw std::runtime_error("cosim: plate pose for readings: " + plate.reason());
    return apply_frame_misalignment(options.effects, plate.position_m);
  };

  auto reference_at = [&](double t) -> Vec3 {
    const double s = options.blend_s > 0.0 ? quintic_blend(t / options.blend_s) : 1.0;
    return (1.0 - s) * home_measured_m + s * options.trajectory(t);
  };

  UartHost host;
  Vec3 sent_reference = home_measured_m;
  Vec3 network_deg = Vec3::Constant(kHomeCount * kCountDeg);
  std::array<std::array<std::uint8_t, kPwmPeriod>, 3> pwm_history{};
  std::array<int, 3> pwm_high{0, 0, 0};
  Vec3 current_a = Vec3::Zero();
  Vec3 true_alpha = result.home_true_alpha_deg;
  Vec3 reading = sensors.update(true_alpha);  // the backlash starts centred at home
  const auto total_cycles = static_cast<std::uint64_t>(std::llround(options.duration_s * kBoardClockHz));
  const auto record_every = static_cast<std::uint64_t>(std::max(1.0, std::round(kBoardClockHz / options.record_rate_hz)));
  const auto progress_every = static_cast<std::uint64_t>(0.1 * kBoardClockHz);

  for (std::uint64_t cycle = 0; cycle < total_cycles; ++cycle) {
    const double t = static_cast<double>(cycle) / kBoardClockHz;
    // Host: the next request as soon as the previous answer is in.
    if (host.idle()) {
      bool clamped = false;
      sent_reference = reference_at(t);
      host.send(request_frame(options.encode_position(sent_reference, &clamped)));
      if (clamped) ++result.clamped_positions;
    }
    core->uart_rx_i = host.tx_level();
    int a = 0, b = 0;
    for (int j = 0; j < 3; ++j) {
      encoders[j].step();
      a |= encoders[j].a() << j;
      b |= encoders[j].b() << j;
    }
    core->encoder_a_i = a;
    core->encoder_b_i = b;

    clock_board(*core);

    if (host.receive(core->uart_tx_o)) {
      if (const auto codes = parse_answer(host.answer())) {
        ++result.round_trips;
        if (result.first_answer_s < 0.0) result.first_answer_s = t;
        for (int o = 0; o < 3; ++o) network_deg[o] = options.decode_angle_deg((*codes)[o]);
      } else {
        ++result.naks;
      }
    }

    // Drives: the current follows the PWM duty averaged over one PWM period.
    const std::size_t slot = cycle % kPwmPeriod;
    for (int j = 0; j < 3; ++j) {
      const std::uint8_t high = (core->drive_pwm_o >> j) & 1;
      pwm_high[j] += high - pwm_history[j][slot];
      pwm_history[j][slot] = high;
    }
    if (cycle % kPlantDivider == kPlantDivider - 1) {
      for (int j = 0; j < 3; ++j) {
        const double sign = ((core->drive_dir_o >> j) & 1) ? -1.0 : 1.0;
        current_a[j] = core->drive_enable_o ? sign * kCurrentFullScaleA * pwm_high[j] / kPwmPeriod : 0.0;
        plants[j]->step(current_a[j], kPlantDivider / kBoardClockHz);
        true_alpha[j] = plants[j]->shaft_angle_deg();
      }
      reading = sensors.update(true_alpha);
      for (int j = 0; j < 3; ++j) encoders[j].set_target(static_cast<int>(std::lround(reading[j] / kCountDeg)));
    }

    if (cycle % record_every == 0) {
      CosimSample sample;
      // The backlash's present lag (reading - reading without backlash) is kept: the ideal
      // joints read their target through the same play.
      Vec3 play;
      for (int j = 0; j < 3; ++j) play[j] = reading[j] - sensors.reading_without_backlash(j, true_alpha[j]);
      sample.network_ideal_m = plate_for_readings(network_deg - play);
      const IkSolution textbook = inverse_kinematics(options.nominal, sent_reference);
      if (!textbook.ok()) throw std::runtime_error("cosim: textbook IK at t = " + std::to_string(t) + " s: " + textbook.reason());
      sample.textbook_ideal_m = plate_for_readings(textbook.alpha_deg - play);
      sample.t_s = t;
      sample.reference_m = sent_reference;
      const FkSolution plate = forward_kinematics(true_geometry, true_alpha);
      if (!plate.ok()) throw std::runtime_error("cosim: plate pose at t = " + std::to_string(t) + " s: " + plate.reason());
      sample.position_m = apply_frame_misalignment(options.effects, plate.position_m);
      sample.true_alpha_deg = true_alpha;
      for (int j = 0; j < 3; ++j) sample.encoder_deg[j] = encoders[j].count() * kCountDeg;
      sample.network_deg = network_deg;
      sample.current_a = current_a;
      sample.drives_enabled = core->drive_enable_o;
      for (int j = 0; j < 3; ++j) {
        if (std::abs(current_a[j]) >= kCurrentFullScaleA) ++result.full_scale_current_samples;
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
    ErrorStats stats(double n) const {
      return {(sum_sq / n).cwiseSqrt(), std::sqrt(distance_sq / n), max_distance};
    }
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
