// The robot around a board, one board clock at a time: drive pins in, encoder lines out.
//
//   drives: PWM duty -> current (full scale at 100 % duty, the pins averaged over each plant step)
//   plants: current -> true joint angle (joint_plant: motor, gearbox, friction, gravity), solved
//     exactly once per plant step (JointPlant::advance; the board's control period)
//   sensors: true angle -> encoder reading (encoder_scale, transmission_error, backlash,
//     joint_offset, counts) -> quadrature A/B lines, one state per quadrature dwell at most
//   plate: true geometry FK(true angles) -> frame_misalignment -> what the measuring stage sees
//   home switches: joint j's closes at and above its reference angle, where the encoder, coming
//     from below (the backlash's play taken up), reads the home count: the robot's joint_offset
//     and the rest of its sensor chain are the reference's per-joint error (docs/homing.md)
//
// Plain C++/Eigen, no board model: the co-simulation and the virtual board bind it to an RTL
// or a model of the board, whose facts (clock, PWM period, home count) come in BoardInterface.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "delta/effects.hpp"
#include "delta/geometry.hpp"
#include "delta/joint_plant.hpp"

namespace delta {

// What the world needs to know of the board's pins and clock.
struct BoardInterface {
  double board_clock_hz = 0.0;
  int pwm_period_cycles = 0;          // PWM period in board cycles
  double current_full_scale_a = 0.0;  // current at 100 % duty
  int home_count = 0;                 // encoder count at the board's reset
  double count_deg = 0.01;            // one encoder count
  int plant_divider = 20;             // board cycles per plant step (the board's control period)
  // The plant steps in the cycle plant_lead cycles before each multiple of plant_divider (cycle
  // k plant_divider - 1 - plant_lead): its encoder moves reach the board before the period starts.
  int plant_lead = 0;
  int quadrature_dwell = 4;  // board cycles per quadrature state, at least
};

// The board's drive outputs during one board cycle.
struct DrivePins {
  int pwm = 0;        // bit j: joint j's PWM level
  int direction = 0;  // bit j: 1 = negative current
  bool enable = false;
};

// The drive pins over a run of board cycles in which only a free-running PWM phase counter moves:
// in cycle i of the run (0, 1, ...) joint j's PWM level is
//   enable && (phase + i) mod pwm_period_cycles < duty[j],
// direction and enable as given (the board's PWM compare with its duties held).
struct DrivePattern {
  int phase = 0;              // the PWM phase counter the first cycle's level was compared with
  std::array<int, 3> duty{};  // PWM cycles high per period (>= the period: always high)
  int direction = 0;          // as DrivePins
  bool enable = false;
  DrivePins pins(std::uint64_t cycle, int pwm_period_cycles) const;  // the pins of cycle i of the run
};

class RobotWorld {
 public:
  // Places the plants where the encoders read the home count (the arms on their home fixture)
  // with the plate at rest there. Throws std::runtime_error if no such pose exists.
  RobotWorld(const BoardInterface& board, const EffectSet& effects, const Geometry& nominal,
             const JointPlantParameters& plant);
  ~RobotWorld();
  RobotWorld(const RobotWorld&) = delete;
  RobotWorld& operator=(const RobotWorld&) = delete;

  // One board cycle with the drive pins the board showed in it: the drive's average, the plants
  // once every plant_divider cycles (with the pins' average since the last plant step); then the
  // encoder lines of the next cycle, one quadrature state closer to the reading.
  void step(const DrivePins& pins);

  // Board cycles from now up to and including the next one whose step() integrates the plants or
  // moves an encoder line (at least 1): the cycles before it change only counters.
  std::uint64_t cycles_to_event() const;
  // `cycles` board cycles (1 .. cycles_to_event()) with the drive pins of `pattern`: exactly what
  // as many step() calls with those pins do, the cycles before the last without calling step().
  void advance(std::uint64_t cycles, const DrivePattern& pattern);

  int encoder_a() const { return lines_a_; }       // bit j: joint j's A line for the next board cycle
  int home_switches() const { return switches_; }  // bit j: joint j's home switch closed
  int encoder_b() const { return lines_b_; }
  std::uint64_t cycle() const { return cycle_; }
  double time_s() const { return static_cast<double>(cycle_) / board_.board_clock_hz; }

  const Vec3& true_alpha_deg() const { return true_alpha_deg_; }
  const Vec3& current_a() const { return current_a_; }  // the average over the last plant step
  Vec3 encoder_deg() const;                             // the counts on the lines, in degrees
  Vec3 measured_position_m() const;                     // the plate as the stage sees it
  const Vec3& home_true_alpha_deg() const { return home_true_alpha_deg_; }
  const Vec3& switch_true_alpha_deg() const { return switch_true_alpha_deg_; }  // the home switches' angles
  // Before the first step: the arms rest at these true angles instead of the home pose (the board
  // still starts at its home count: its encoders count from there). std::invalid_argument if the
  // plate has no pose there or the world has run.
  void place_arms(const Vec3& true_alpha_deg);
  // Fault injection (tests): joint j's arm never moves (seized), or its home switch never closes.
  void seize_joint(int joint) { seized_ |= 1 << joint; }
  void remove_home_switch(int joint) { switch_missing_ |= 1 << joint; }
  // Joint j's encoder silently gains `counts` (valid quadrature steps, as from electrical noise
  // the decoder cannot tell from motion) at the first plant step at or after board cycle `cycle`.
  void slip_encoder(int joint, int counts, std::uint64_t cycle) {
    slip_joint_ = joint;
    slip_counts_ = counts;
    slip_cycle_ = cycle;
  }
  // The upper arms' mechanical stops (true angles): an arm driven into one rests against it.
  static constexpr double kEndStopLowDeg = -15.0;
  static constexpr double kEndStopHighDeg = 95.0;
  const Vec3& home_measured_m() const { return home_measured_m_; }
  // Where the stage would see the plate if the encoders read `readings_deg` through the
  // backlash's present play (the play kept, the rest of the sensor chain inverted).
  Vec3 plate_for_readings(const Vec3& readings_deg) const {
    return plate_for_readings(readings_deg, backlash_lag_deg());
  }
  // The same through a play kept from another instant (backlash_lag_deg() then).
  Vec3 plate_for_readings(const Vec3& readings_deg, const Vec3& lag_deg) const;
  // The backlash's present lag per joint: reading - reading without backlash [deg].
  Vec3 backlash_lag_deg() const;
  const Geometry& true_geometry() const { return true_geometry_; }
  const EffectSet& effects() const { return effects_; }

  // A measuring stage that drags the plate (the drives off): asked at every plant step with the
  // time of that step, it returns where it holds the plate (true base frame), or nothing when it
  // lets go. Held, the arms follow through the true geometry (the plants placed at rest there) and
  // the sensors read them with every effect.
  using Drag = std::function<std::optional<Vec3>(double t_s)>;
  void set_drag(Drag drag) { drag_ = std::move(drag); }

 private:
  class Quadrature;
  double true_angle_for_reading(int joint, double reading_deg) const;
  void update_lines();  // lines_a_, lines_b_ from the encoders

  BoardInterface board_;
  double plant_step_s_ = 0.0;  // plant_divider board cycles [s]
  int pwm_period_bits_ = -1;   // log2 of a power-of-two PWM period (-1: another period)
  EffectSet effects_;
  StageFrame stage_frame_;
  Geometry true_geometry_;
  JointSensorChain sensors_;
  std::array<std::unique_ptr<JointPlant>, 3> plants_;
  std::array<std::unique_ptr<Quadrature>, 3> encoders_;
  std::array<std::int64_t, 3> drive_sum_{};  // since the last plant step: +1 per high cycle, -1 reversed
  Vec3 true_alpha_deg_ = Vec3::Zero();
  Vec3 reading_deg_ = Vec3::Zero();
  Vec3 current_a_ = Vec3::Zero();
  Vec3 home_true_alpha_deg_ = Vec3::Zero();
  Vec3 home_measured_m_ = Vec3::Zero();
  Vec3 switch_true_alpha_deg_ = Vec3::Zero();
  int switches_ = 0;
  int seized_ = 0;          // bit j: joint j's arm does not move
  int switch_missing_ = 0;  // bit j: joint j's home switch never closes
  int slip_joint_ = -1;     // slip_encoder(): the joint, its counts, from this cycle
  int slip_counts_ = 0;
  std::uint64_t slip_cycle_ = 0;
  std::array<int, 3> slipped_{};  // counts each encoder reads beyond the sensor chain
  void update_switches();
  std::uint64_t cycle_ = 0;
  int plant_phase_ = 0;  // (cycle_ + plant_lead) mod plant_divider: the plant steps at plant_divider - 1
  int lines_a_ = 0;      // encoder_a(), encoder_b()
  int lines_b_ = 0;
  JointPlantParameters plant_parameters_;
  Drag drag_;
};

// Quadrature encoder lines `steps` counts from the start ({A, B} = 00 -> 10 -> 11 -> 01 counting
// up, as rtl/joint/quadrature_counter.sv decodes them).
inline int quadrature_a(int steps) { return ((steps % 4 + 4) % 4 + 1) / 2 % 2; }  // 0, 1, 1, 0
inline int quadrature_b(int steps) { return ((steps % 4 + 4) % 4) / 2; }          // 0, 0, 1, 1

}  // namespace delta
