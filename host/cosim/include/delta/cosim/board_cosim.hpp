// Whole-robot co-simulation: the lab's host (delta::controller: the plan, the streaming loop, the
// recording's rows) runs against the virtual board (virtual_board.hpp: the Verilated board core as
// built or the model board, the robot world, the serial line) in the board's own time, and the
// world's ground truth is compared with what the host asked for.
//
//   host: identify (checked against its weights), set home, the plan from the pose the encoders
//     report (controller::start_at_rest, StreamPlan: a checked jerk-limited approach, the path
//     entered and left by rate ramps), enable, hold, controller::StreamingLoop (the lead sent, then
//     enable; 1 kHz setpoints paced by telemetry, every deadline kept in board time:
//     BoardTimeClock), hold, disable  --bytes-->  virtual board
//   truth (every 1 ms of board time): plate as the measuring stage sees it, plant angles
//
// The host side is the code `deltactl host run` runs; only its clock differs (the loop's sleep
// advances the board). The reference at each truth sample is the stream sample whose answer is the
// joint reference at that tick, as the lab's recording keeps it (controller::TelemetryRecord).
//
// Time: board time since reset; t = board time - t0, where t0 is the tick at which stream sample 0
// became the joint reference; tau is the path time of the sample in effect (-1 in the approach).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "delta/controller/host_run.hpp"
#include "delta/controller/realtime.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/cosim/virtual_board.hpp"
#include "delta/effects.hpp"
#include "delta/geometry.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/joint_plant.hpp"
#include "delta/link/payloads.hpp"
#include "delta/link/session.hpp"
#include "delta/run_report.hpp"

namespace delta::cosim {

struct CosimOptions {
  BoardFidelity fidelity = BoardFidelity::kRtl;  // the Verilated board or the model board
  std::string mem_dir;                           // the network's .mem files and identify.mem (golden::write_export)
  const golden::QuantisedNetwork* network = nullptr;  // the host's weights (the same as in mem_dir)
  // The W.json read (optional): a deployed model's joint ripple table shapes the setpoints sent.
  const nn::WeightsFile* model = nullptr;
  // The network's trained range (W.json input_min, input_max): the plan is checked against it as
  // `host run` checks it. The default admits any reachable point.
  Vec3 trained_min_m = Vec3::Constant(-1.0), trained_max_m = Vec3::Constant(1.0);
  EffectSet effects;  // the virtual robot
  Geometry nominal = Geometry::nominal();
  std::string trajectory = "experiment1";  // as `host run --trajectory`: NAME, FILE.csv or move:...
  double duration_s = 1.0;                 // of trajectory time (0: the trajectory's own length)
  controller::StreamLimits limits;         // the plan's checked limits (host run's)
  JointPlantParameters plant;
  link::SessionOptions session;
  // Called every 0.1 s of board time from the enable: (done, of about) seconds.
  std::function<void(double done_s, double total_s)> progress;
  VirtualBoard::PeriodObserver period_observer;  // every 10 kHz control period of board time
};

// The loop's clock in board time: sleeping steps the virtual board to the deadline.
class BoardTimeClock final : public controller::LoopClock {
 public:
  explicit BoardTimeClock(VirtualBoard& board) : board_(board) {}
  std::int64_t now_ns() override;
  void sleep_until_ns(std::int64_t deadline_ns) override;

 private:
  VirtualBoard& board_;
};

struct CosimSample {                   // every 1 ms of board time from t0 to the end of the stream
  double t_s = 0.0;                    // board time since t0
  double tau_s = -1.0;                 // path time of the stream sample in effect (-1: the approach)
  Vec3 reference_m = Vec3::Zero();     // that sample's position as sent (its codes decoded)
  Vec3 position_m = Vec3::Zero();      // measured plate position (frame_misalignment applied)
  Vec3 true_alpha_deg = Vec3::Zero();  // plant angles
  Vec3 encoder_deg = Vec3::Zero();     // what the board counts (0.01 deg)
  Vec3 network_deg = Vec3::Zero();     // the network's answer for the reference (the joint reference due now)
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
  std::vector<link::TelemetryPayload> telemetry;     // every frame the host received
  std::vector<controller::TelemetryRecord> records;  // the stream's rows, as `host run` records them
  link::IdentifyPayload identify;
  link::LinkStatistics link;
  controller::StreamingResult stream;           // the lab's streaming loop's account
  std::size_t approach_samples = 0;             // of stream.planned: the straight move to the path's start
  std::uint32_t underruns_while_streaming = 0;  // the board's underrun counter from stream sample 0 to the end
  double t0_s = 0.0;                            // board time of tau = 0
  Vec3 start_position_m = Vec3::Zero();         // where the plan starts (controller::start_at_rest at the home count)
  Vec3 home_true_alpha_deg = Vec3::Zero();      // plant angles at which the encoders read 30.00 deg
  std::size_t full_scale_current_samples = 0;   // recorded samples with some |current| at 0.5 A
  BoardPins pins;                               // sticky flags at the end (after disable)
  std::uint16_t bad_frames = 0;                 // board counters at the end (last telemetry)
  std::uint16_t rejected = 0;
  std::uint16_t slew_limits = 0;
  std::uint16_t saturations = 0;
  std::uint64_t board_cycles = 0;
  double board_busy_s = 0.0;  // wall time in the board and the world (VirtualBoard::busy_s)
};

// The trajectory breaks a limit (the host's check before any motion, as `host run`'s): the
// message names the file, line and reason; the command exits 2.
struct PlanRefused : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Throws PlanRefused if the plan fails its check (a sample beyond the limits or the trained range);
// std::runtime_error if the home pose cannot be found, the board's identify differs from the host's
// weights, or the link fails (link::LinkError). A stream that ends early (a fault) is a result:
// stream.outcome.
CosimResult run_cosim(const CosimOptions& options);

// Where the host's network answers `alpha_deg` (the host controller's, delta/golden/board_network.hpp).
using golden::locate_plate;

// Plate tracking statistics over the samples with path time tau >= from_s: per-axis RMS and the
// largest distance [m].
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

// The run-report (delta/run_report.hpp) of the samples with path time tau >= from_s and the drives
// on: the virtual robot's plate against the reference moving, at rest (each dwell, settled or not)
// and through reversals; the joints: encoder - the network's answer due.
RunReport run_report_of(const CosimResult& result, double from_s);

}  // namespace delta::cosim
