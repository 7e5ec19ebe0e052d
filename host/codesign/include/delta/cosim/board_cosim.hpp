// Whole-robot co-simulation: the Verilated board core (UART link, network RTL, clock-domain
// crossing, three joint controllers, PWM) in closed loop with three joint plants and the virtual
// robot's unmodelled effects, driven by a host that streams Cartesian references over the UART.
//
//   host: p_ref(t) -> raw input codes -> UART request --> board_core (RTL)
//     network -> joint references -> joint controllers -> PWM + direction
//   drives: PWM duty -> current (0.5 A full scale, averaged over one PWM period)
//   plants: current -> true joint angle a_j (sim/joint_plant: motor, gearbox, friction, gravity)
//   sensors: a -> encoder reading (encoder_scale, transmission_error, backlash, joint_offset,
//     0.01 deg counts) -> quadrature A/B --> board_core
//   plate: true geometry FK(a) -> frame_misalignment -> measured position p (compared with p_ref)
//
// Parts: the world (sim/robot_world.hpp: plants, sensors, encoders, PWM averaging), the board
// (the Verilated board core and its serial line, rtl/board/sim) and the host side (link_v1.hpp:
// frames and one request in flight, bytes only).
//
// Time base: the board core is the Verilated test build (rtl/CMakeLists.txt): SimClocksPerPeriod
// board cycles per 100 us control period, i.e. a 20 MHz board clock, and a UART of
// SimClocksPerBit board cycles per bit (5 Mbaud). The plants are integrated every 20 board
// cycles (1 us).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/effects.hpp"
#include "delta/geometry.hpp"
#include "delta/joint_plant.hpp"

namespace delta::cosim {

// The Verilated test build's clock and link (rtl/board/delta_board_pkg.sv, Sim*), and the board's home.
constexpr double kBoardClockHz = static_cast<double>(board::kSimClocksPerPeriod * board::kControlRateHz);
constexpr int kClocksPerBit = static_cast<int>(board::kSimClocksPerBit);
constexpr int kHomeCount = static_cast<int>(board::kHomeCount);
constexpr double kCurrentFullScaleA = board::kCurrentFullScaleMilliamp / 1000.0;
constexpr double kCountDeg = board::kEncoderCountMicrodeg * 1e-6;

struct CosimOptions {
  std::string mem_dir;  // the network's .mem files (golden::write_export)
  EffectSet effects;    // the virtual robot
  Geometry nominal = Geometry::nominal();
  std::function<Vec3(double t_s)> trajectory;  // reference plate position, measured frame [m]
  double duration_s = 1.0;
  double blend_s = 0.3;  // smooth start from the home pose
  double record_rate_hz = 1000.0;
  JointPlantParameters plant;
  // Formats of the network (input codes): encode a position for the UART request.
  std::function<std::array<std::int64_t, 3>(const Vec3& position_m, bool* clamped)> encode_position;
  std::function<double(std::int64_t raw)> decode_angle_deg;
  std::function<void(double simulated_s)> progress;  // called every 0.1 s of simulated time
};

struct CosimSample {
  double t_s = 0.0;
  Vec3 reference_m = Vec3::Zero();     // what the host sent (blended trajectory)
  Vec3 position_m = Vec3::Zero();      // measured plate position (frame_misalignment applied)
  Vec3 true_alpha_deg = Vec3::Zero();  // plant angles
  Vec3 encoder_deg = Vec3::Zero();     // what the board counts (0.01 deg)
  Vec3 network_deg = Vec3::Zero();     // the last network answer (joint references)
  Vec3 current_a = Vec3::Zero();       // drive currents (PWM decoded)
  bool drives_enabled = false;
  // Where the plate would be if the encoders read exactly (through the backlash's present play)
  // the network's answer (the network's own error), or the textbook model's inverse kinematics
  // of the reference (what the network corrects).
  Vec3 network_ideal_m = Vec3::Zero();
  Vec3 textbook_ideal_m = Vec3::Zero();
};

struct CosimResult {
  std::vector<CosimSample> samples;
  Vec3 home_true_alpha_deg = Vec3::Zero();  // plant angles at which the encoders read 30.00 deg
  std::size_t round_trips = 0;              // UART request/answer pairs
  std::size_t naks = 0;
  std::size_t clamped_positions = 0;  // references outside the 32-bit input code
  double first_answer_s = -1.0;
  int encoder_error_bits = 0;                  // board's sticky flags (bit j: joint j)
  bool joint_limited = false;                  // a joint controller saturated an operand or state
  int fault_cause_bits = 0;                    // joint_axes' latched fault causes (0: no fault, torque on)
  std::size_t full_scale_current_samples = 0;  // recorded samples with some |current| at 0.5 A
  std::uint64_t board_cycles = 0;
};

// Throws std::runtime_error if the home pose cannot be found or a pose is unreachable.
CosimResult run_cosim(const CosimOptions& options);

// Plate tracking statistics over t >= from_s: per-axis RMS and the largest distance [m].
struct ErrorStats {
  Vec3 rms_m = Vec3::Zero();
  double rms_distance_m = 0.0;
  double max_distance_m = 0.0;
};
struct TrackingSummary {
  ErrorStats closed_loop;             // position_m - reference
  ErrorStats network_ideal;           // network_ideal_m - reference
  ErrorStats textbook_ideal;          // textbook_ideal_m - reference
  Vec3 joint_rms_deg = Vec3::Zero();  // encoder - network reference
  std::size_t samples = 0;
};
TrackingSummary summarise(const CosimResult& result, double from_s);

}  // namespace delta::cosim
