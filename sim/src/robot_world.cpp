// The robot around a board, one board clock at a time (see robot_world.hpp).
#include "delta/robot_world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "delta/kinematics.hpp"

namespace delta {

// Quadrature lines that follow a target count one state per dwell.
class RobotWorld::Quadrature {
 public:
  Quadrature(int count, int home_count, int dwell) : count_(count), target_(count), home_(home_count), dwell_(dwell) {}
  void set_target(int count) { target_ = count; }
  // True when the count (and so a line) changed. The wait saturates at the dwell (a joint at rest
  // for hours must not wrap it).
  bool step() {
    if (waited_ < dwell_) ++waited_;
    if (waited_ < dwell_ || count_ == target_) return false;
    waited_ = 0;
    count_ += count_ < target_ ? 1 : -1;
    return true;
  }
  // Steps up to and including the next one that moves the count (none: `never`).
  std::uint64_t steps_to_move(std::uint64_t never) const {
    return count_ == target_ ? never : static_cast<std::uint64_t>(std::max(1, dwell_ - waited_));
  }
  // `steps` steps that do not move the count (fewer than steps_to_move()).
  void wait(std::uint64_t steps) {
    waited_ = static_cast<int>(std::min<std::uint64_t>(static_cast<std::uint64_t>(dwell_), waited_ + steps));
  }

  int count() const { return count_; }
  int a() const { return quadrature_a(count_ - home_); }
  int b() const { return quadrature_b(count_ - home_); }

 private:
  int count_;
  int target_;
  int home_;
  int dwell_;
  int waited_ = 0;
};

namespace {

// Cycles i in [0, cycles) whose PWM level is high: (phase + i) mod period < duty (0 <= phase <
// period; period_bits >= 0 when the period is 2^period_bits: shifts instead of divisions).
std::int64_t high_cycles(int phase, int duty, std::uint64_t cycles, int period, int period_bits) {
  if (duty <= 0) return 0;
  if (duty >= period) return static_cast<std::int64_t>(cycles);
  if (phase + cycles <= static_cast<std::uint64_t>(period)) {  // within one PWM period
    return std::max<std::int64_t>(0, std::min<std::int64_t>(phase + static_cast<std::int64_t>(cycles), duty) - phase);
  }
  // below(m): the cycles in [0, m) of a pattern starting at phase 0.
  const auto below = [&](std::uint64_t m) {
    const std::uint64_t periods = period_bits >= 0 ? m >> period_bits : m / static_cast<std::uint64_t>(period);
    const std::uint64_t rest = m - periods * static_cast<std::uint64_t>(period);
    return static_cast<std::int64_t>(periods) * duty + std::min<std::int64_t>(static_cast<std::int64_t>(rest), duty);
  };
  return below(static_cast<std::uint64_t>(phase) + cycles) - below(static_cast<std::uint64_t>(phase));
}

}  // namespace

RobotWorld::RobotWorld(const BoardInterface& board, const EffectSet& effects, const Geometry& nominal,
                       const JointPlantParameters& plant)
    : board_(board),
      effects_(effects),
      stage_frame_(effects),
      true_geometry_(apply_geometry_effects(nominal, effects)),
      sensors_(effects),
      plant_parameters_(plant) {
  if (!(board.board_clock_hz > 0.0) || board.pwm_period_cycles <= 0 || board.plant_divider <= 0 ||
      board.plant_lead < 0 || board.plant_lead >= board.plant_divider) {
    throw std::invalid_argument(
        "RobotWorld: board clock, PWM period and plant divider must be positive, the plant lead below the divider");
  }
  plant_phase_ = board.plant_lead;
  if ((board.pwm_period_cycles & (board.pwm_period_cycles - 1)) == 0) {
    pwm_period_bits_ = __builtin_ctz(static_cast<unsigned>(board.pwm_period_cycles));
  }
  plant_step_s_ = board.plant_divider / board.board_clock_hz;
  // Home: the encoders read the home count with the plate at rest there.
  for (int j = 0; j < 3; ++j) home_true_alpha_deg_[j] = true_angle_for_reading(j, board.home_count * board.count_deg);
  const FkSolution home = forward_kinematics(true_geometry_, home_true_alpha_deg_);
  if (!home.ok()) throw std::runtime_error("the robot's home pose: " + home.reason());
  home_measured_m_ = apply_frame_misalignment(effects, home.position_m);
  // The home switches: where the reading, coming from below through the backlash, is the home count.
  for (int j = 0; j < 3; ++j) {
    const double half_play = effects.backlash_deg ? 0.5 * (*effects.backlash_deg)[j] : 0.0;
    switch_true_alpha_deg_[j] = true_angle_for_reading(j, board.home_count * board.count_deg + half_play);
  }

  for (int j = 0; j < 3; ++j) {
    plants_[j] = std::make_unique<JointPlant>(plant, home_true_alpha_deg_[j]);  // solved exactly (advance)
    encoders_[j] = std::make_unique<Quadrature>(board.home_count, board.home_count, board.quadrature_dwell);
  }
  true_alpha_deg_ = home_true_alpha_deg_;
  reading_deg_ = sensors_.update(true_alpha_deg_);  // the backlash starts centred at home
  for (auto& encoder : encoders_) encoder->step();  // the lines of the first board cycle
  update_lines();
  update_switches();
}

RobotWorld::~RobotWorld() = default;

void RobotWorld::place_arms(const Vec3& true_alpha_deg) {
  if (cycle_ != 0) throw std::invalid_argument("RobotWorld::place_arms: the world has already run");
  const FkSolution plate = forward_kinematics(true_geometry_, true_alpha_deg);
  if (!plate.ok()) throw std::invalid_argument("the arms cannot rest at these angles: " + plate.reason());
  sensors_.reset();
  reading_deg_ = sensors_.update(true_alpha_deg);  // the backlash centred where they rest
  for (int j = 0; j < 3; ++j) {
    plants_[j] = std::make_unique<JointPlant>(plant_parameters_, true_alpha_deg[j]);
    // The lines start at the board's reset state: the board counts from its home count.
    const int count = static_cast<int>(std::lround(reading_deg_[j] / board_.count_deg));
    encoders_[j] = std::make_unique<Quadrature>(count, count, board_.quadrature_dwell);
    encoders_[j]->step();
  }
  true_alpha_deg_ = true_alpha_deg;
  update_lines();
  update_switches();
}

void RobotWorld::update_switches() {
  switches_ = 0;
  for (int j = 0; j < 3; ++j) {
    if (true_alpha_deg_[j] >= switch_true_alpha_deg_[j] && ((switch_missing_ >> j) & 1) == 0) switches_ |= 1 << j;
  }
}

// The true angle at which joint j's encoder reads `reading_deg`: secant steps from the reading
// itself (the chain's slope is about 1), else bisection over +-20 deg.
double RobotWorld::true_angle_for_reading(int joint, double reading_deg) const {
  auto error = [&](double true_deg) { return sensors_.reading_without_backlash(joint, true_deg) - reading_deg; };
  {
    double x0 = reading_deg, e0 = error(x0);
    double x1 = x0 - e0;
    for (int i = 0; i < 12 && e0 != 0.0; ++i) {
      const double e1 = error(x1);
      if (e1 == 0.0 || std::abs(x1 - x0) <= 4 * std::numeric_limits<double>::epsilon() * std::abs(x1)) {
        if (std::abs(x1 - reading_deg) < 20.0) return x1;
        break;
      }
      if (e1 == e0) break;
      const double x2 = x1 - e1 * (x1 - x0) / (e1 - e0);
      x0 = x1;
      e0 = e1;
      x1 = x2;
    }
    if (e0 == 0.0 && std::abs(x0 - reading_deg) < 20.0) return x0;
  }
  double low = reading_deg - 20.0, high = reading_deg + 20.0;
  if (error(low) * error(high) > 0) {
    throw std::runtime_error("no true angle of joint " + std::to_string(joint + 1) + " reads " +
                             std::to_string(reading_deg) + " deg within +-20 deg");
  }
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (low + high);
    const double last_low = low, last_high = high;
    if (error(mid) * error(low) <= 0) {
      high = mid;
    } else {
      low = mid;
    }
    if (low == last_low && high == last_high) break;  // converged: every further step repeats this one
  }
  return 0.5 * (low + high);
}

void RobotWorld::step(const DrivePins& pins) {
  // Drives: the current is the PWM duty averaged over the plant step (the direction pin signs it).
  if (pins.enable) {
    for (int j = 0; j < 3; ++j) {
      if ((pins.pwm >> j) & 1) drive_sum_[j] += ((pins.direction >> j) & 1) ? -1 : 1;
    }
  }
  const bool plant_step = plant_phase_ == board_.plant_divider - 1;
  if (++plant_phase_ == board_.plant_divider) plant_phase_ = 0;
  if (plant_step) {
    for (int j = 0; j < 3; ++j) {
      current_a_[j] = board_.current_full_scale_a * static_cast<double>(drive_sum_[j]) / board_.plant_divider;
      drive_sum_[j] = 0;
      if (((seized_ >> j) & 1) != 0) continue;  // seized: the angle stays
      plants_[j]->advance(current_a_[j], plant_step_s_);
      const double angle = plants_[j]->shaft_angle_deg();
      if (angle < kEndStopLowDeg || angle > kEndStopHighDeg) {  // against a stop: at rest there
        *plants_[j] = JointPlant(plant_parameters_, std::clamp(angle, kEndStopLowDeg, kEndStopHighDeg));
      }
      true_alpha_deg_[j] = plants_[j]->shaft_angle_deg();
    }
    if (drag_) {
      if (const std::optional<Vec3> plate = drag_(time_s())) {
        const IkSolution arms = inverse_kinematics(true_geometry_, *plate);
        if (!arms.ok()) {
          throw std::runtime_error("the stage drags the plate out of reach at t = " + std::to_string(time_s()) +
                                   " s: " + arms.reason());
        }
        for (int j = 0; j < 3; ++j) *plants_[j] = JointPlant(plant_parameters_, arms.alpha_deg[j]);
        true_alpha_deg_ = arms.alpha_deg;
      }
    }
    reading_deg_ = sensors_.update(true_alpha_deg_);
    update_switches();
    if (slip_joint_ >= 0 && cycle_ >= slip_cycle_) {
      slipped_[slip_joint_] += slip_counts_;
      slip_joint_ = -1;
    }
    for (int j = 0; j < 3; ++j) {
      encoders_[j]->set_target(static_cast<int>(std::lround(reading_deg_[j] / board_.count_deg)) + slipped_[j]);
    }
  }
  ++cycle_;
  // The lines the board samples in its next cycle.
  bool moved = false;
  for (auto& encoder : encoders_) moved |= encoder->step();
  if (moved) update_lines();
}

std::uint64_t RobotWorld::cycles_to_event() const {
  std::uint64_t cycles = static_cast<std::uint64_t>(board_.plant_divider - plant_phase_);
  for (const auto& encoder : encoders_) cycles = encoder->steps_to_move(cycles);
  return cycles;
}

void RobotWorld::advance(std::uint64_t cycles, const DrivePattern& pattern) {
  // The cycles before the last: the drive's sums and the counters only.
  const std::uint64_t quiet = cycles - 1;
  if (pattern.enable) {
    for (int j = 0; j < 3; ++j) {
      const std::int64_t high =
          high_cycles(pattern.phase, pattern.duty[j], quiet, board_.pwm_period_cycles, pwm_period_bits_);
      drive_sum_[j] += ((pattern.direction >> j) & 1) ? -high : high;
    }
  }
  plant_phase_ += static_cast<int>(quiet);
  cycle_ += quiet;
  for (auto& encoder : encoders_) encoder->wait(quiet);
  step(pattern.pins(quiet, board_.pwm_period_cycles));
}

DrivePins DrivePattern::pins(std::uint64_t cycle, int pwm_period_cycles) const {
  std::uint64_t level_phase = static_cast<std::uint64_t>(phase) + cycle;
  if (level_phase >= static_cast<std::uint64_t>(pwm_period_cycles)) level_phase %= pwm_period_cycles;
  DrivePins out;
  for (int j = 0; j < 3; ++j) {
    if (enable && level_phase < static_cast<std::uint64_t>(std::max(duty[j], 0))) out.pwm |= 1 << j;
  }
  out.direction = direction;
  out.enable = enable;
  return out;
}

void RobotWorld::update_lines() {
  lines_a_ = 0;
  lines_b_ = 0;
  for (int j = 0; j < 3; ++j) {
    lines_a_ |= encoders_[j]->a() << j;
    lines_b_ |= encoders_[j]->b() << j;
  }
}

Vec3 RobotWorld::encoder_deg() const {
  Vec3 deg;
  for (int j = 0; j < 3; ++j) deg[j] = encoders_[j]->count() * board_.count_deg;
  return deg;
}

Vec3 RobotWorld::measured_position_m() const {
  const FkSolution plate = forward_kinematics(true_geometry_, true_alpha_deg_);
  if (!plate.ok()) throw std::runtime_error("plate pose at t = " + std::to_string(time_s()) + " s: " + plate.reason());
  return stage_frame_(plate.position_m);
}

Vec3 RobotWorld::backlash_lag_deg() const {
  Vec3 lag;
  for (int j = 0; j < 3; ++j) lag[j] = reading_deg_[j] - sensors_.reading_without_backlash(j, true_alpha_deg_[j]);
  return lag;
}

Vec3 RobotWorld::plate_for_readings(const Vec3& readings_deg, const Vec3& lag_deg) const {
  Vec3 alpha;
  for (int j = 0; j < 3; ++j) alpha[j] = true_angle_for_reading(j, readings_deg[j] - lag_deg[j]);
  const FkSolution plate = forward_kinematics(true_geometry_, alpha);
  if (!plate.ok()) throw std::runtime_error("plate pose for readings: " + plate.reason());
  return stage_frame_(plate.position_m);
}

}  // namespace delta
