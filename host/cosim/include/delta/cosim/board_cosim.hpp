// Whole-robot co-simulation: a host streams a Cartesian trajectory over the board link v2 to the
// virtual board at RTL fidelity (virtual_board.hpp: the Verilated board core as built, the robot
// world, the serial line), and the world's ground truth is compared with the trajectory.
//
//   host (link::LinkSession over VirtualBoardStream): identify, set home, enable,
//     1 kHz setpoints paced by telemetry, hold, disable  --bytes-->  virtual board
//   truth (every 1 ms of board time): plate as the measuring stage sees it, plant angles
//
// The host side knows only what the link tells it and what it owns (its weights, the trajectory):
// it checks the identify reply against its weights, learns the board's tick and sample index from
// telemetry, and finds where the plate starts by inverting its own network at the encoder counts
// telemetry reports (the home count). Latency compensated: the board plays a sample at the next
// 1 ms segment after the telemetry that names it and its answer is the joint reference one
// segment later, so sample n is sent the trajectory position at its predicted reach time
// (link/session.hpp, "Timing"): 1 ms network and interpolation plus the time it waits in the
// buffer (target fill, 20 ms).
//
// Time: board time since reset (t = ticks / 10 kHz); trajectory time tau = t - t0, where t0 is the
// reach time of the first streamed sample. The reference is the trajectory blended from the start
// pose over blend_s.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "delta/cosim/virtual_board.hpp"
#include "delta/effects.hpp"
#include "delta/geometry.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/joint_plant.hpp"
#include "delta/link/payloads.hpp"
#include "delta/link/session.hpp"

namespace delta::cosim {

struct CosimOptions {
  BoardFidelity fidelity = BoardFidelity::kRtl;  // the Verilated board or the model board
  std::string mem_dir;                           // the network's .mem files and identify.mem (golden::write_export)
  const golden::QuantisedNetwork* network = nullptr;  // the host's weights (the same as in mem_dir)
  EffectSet effects;                                  // the virtual robot
  Geometry nominal = Geometry::nominal();
  std::function<Vec3(double tau_s)> trajectory;  // reference plate position, measured frame [m]
  double duration_s = 1.0;                       // of trajectory time
  double blend_s = 0.3;                          // smooth start from the start pose
  JointPlantParameters plant;
  link::SessionOptions session;
  std::function<void(double tau_s)> progress;    // called every 0.1 s of trajectory time
  VirtualBoard::PeriodObserver period_observer;  // every 10 kHz control period of board time
};

struct CosimSample {                   // every 1 ms of board time, tau in [0, duration)
  double t_s = 0.0;                    // trajectory time tau
  Vec3 reference_m = Vec3::Zero();     // the blended trajectory at tau
  Vec3 position_m = Vec3::Zero();      // measured plate position (frame_misalignment applied)
  Vec3 true_alpha_deg = Vec3::Zero();  // plant angles
  Vec3 encoder_deg = Vec3::Zero();     // what the board counts (0.01 deg)
  Vec3 network_deg = Vec3::Zero();     // the network's answer for the reference at tau (the joint reference due now)
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
  std::vector<link::TelemetryPayload> telemetry;  // every frame the host received
  link::IdentifyPayload identify;
  link::LinkStatistics link;
  link::StreamReport stream;
  double t0_s = 0.0;                        // board time of tau = 0
  Vec3 start_position_m = Vec3::Zero();     // where the host found the plate (its network inverted at the home count)
  Vec3 home_true_alpha_deg = Vec3::Zero();  // plant angles at which the encoders read 30.00 deg
  std::size_t clamped_positions = 0;        // references outside the 32-bit input code
  std::size_t full_scale_current_samples = 0;  // recorded samples with some |current| at 0.5 A
  BoardPins pins;                              // sticky flags at the end (after disable)
  std::uint16_t bad_frames = 0;                // board counters at the end (last telemetry)
  std::uint16_t rejected = 0;
  std::uint16_t slew_limits = 0;
  std::uint16_t saturations = 0;
  std::uint64_t board_cycles = 0;
  double board_busy_s = 0.0;  // wall time in the board and the world (VirtualBoard::busy_s)
};

// Throws std::runtime_error if the home pose cannot be found, a pose is unreachable, the board's
// identify differs from the host's weights, or the link fails (link::LinkError).
CosimResult run_cosim(const CosimOptions& options);

// Where the host's network answers `alpha_deg` (the host controller's, delta/golden/board_network.hpp).
using golden::locate_plate;

// Plate tracking statistics over tau >= from_s: per-axis RMS and the largest distance [m].
struct ErrorStats {
  Vec3 rms_m = Vec3::Zero();
  double rms_distance_m = 0.0;
  double max_distance_m = 0.0;
};
struct TrackingSummary {
  ErrorStats closed_loop;                   // position_m - reference
  ErrorStats network_ideal;                 // network_ideal_m - reference
  ErrorStats textbook_ideal;                // textbook_ideal_m - reference
  Vec3 joint_rms_deg = Vec3::Zero();        // encoder - network answer due (truth, 1 kHz)
  Vec3 board_joint_rms_deg = Vec3::Zero();  // telemetry: encoder count - joint reference (the board's own)
  std::size_t samples = 0;
  std::size_t telemetry_frames = 0;
};
TrackingSummary summarise(const CosimResult& result, double from_s);

}  // namespace delta::cosim
