// The virtual measuring stage beside the virtual board (docs/contracts.md, "The lab's measurements"): a stage
// controller with its own clock that either drags the plate along a trajectory with the drives off
// (`drag`: the arms follow through the true geometry and every sensor effect) or measures the
// plate wherever the robot carries it (`follow`), and writes its own log, t_s,x_m,y_m,z_m, as a
// real stage does: on its clock t_stage = offset + (1 + ppm 1e-6) t_board, at its sample rate,
// through the frame misalignment, with its noise, quantised to 6.87 nm; and, unless told not to, a
// column `sync`: the board's stage sync output (delta_board_pkg::StageSyncBit) on the stage's
// digital input, sampled with the positions.
//
// The stage takes hold of the plate when the board first receives a valid frame (or, with
// after_home_s, that long after the next command starts once the board is homed at its references:
// after the board's telemetry first shows every joint referenced with the drives off, the homing's
// last command (the disable `host home` ends with), then the next command's identify request, that
// of `host record`; telemetry with the drives on or homing before the stage holds waits for the
// homing's end again): a quintic move from where the plate rests to the trajectory's start during one
// second, then the trajectory at its own time; at its end the stage holds the plate there.
//
// Wiring (deltactl virtual-board): the host's bytes go to host_bytes(), the board's to
// board_bytes(), drag() to the world (VirtualBoardOptions::drag), sample() to the board's period
// observer.
#pragma once

#include <cstdint>
#include <fstream>
#include <functional>
#include <optional>
#include <random>
#include <string>

#include "delta/effects.hpp"
#include "delta/geometry.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/robot_world.hpp"

namespace delta::cosim {

struct StageOptions {
  std::string mode;             // "drag:NAME", "drag:FILE.csv" or "follow"
  std::string log_path;         // STAGE.csv
  double clock_offset_s = 0.0;  // t_stage at board time 0
  double clock_ppm = 0.0;       // the stage clock's rate error
  double rate_hz = 1000.0;      // samples per second of stage time
  double noise_m = 20e-9;       // RMS per axis
  std::uint64_t seed = 1;
  bool log_sync = true;  // the board's stage_sync_o wired to the stage's input, logged as `sync`
  // >= 0: the stage takes hold this many seconds of board time after the first command that
  // follows the board's homing at its references starts (its identify request), so that `host home`
  // runs undisturbed and the drag starts with the recording; < 0: at the host's first valid frame.
  double after_home_s = -1.0;
};

class MeasuringStage {
 public:
  // Reads the trajectory (InputError: a FILE.csv's line; an unknown NAME), checks every 10 ms of it
  // reachable by the robot whose effects are given (InputError naming the first that is not), and
  // opens the log (InputError when it cannot be written).
  MeasuringStage(const StageOptions& options, const EffectSet& effects, const Geometry& nominal);

  bool drags() const { return static_cast<bool>(path_); }
  // Bytes the host sent, at board time t_s: the first valid frame starts the drag's clock (with
  // after_home_s >= 0, the identify request of the first command after the homing).
  void host_bytes(const std::uint8_t* data, std::size_t size, double t_s);
  // Bytes the board sent, at board time t_s: with after_home_s >= 0, the first telemetry frame
  // that shows the board referenced with the drives off and not homing is the homing's end; a
  // frame with the drives on or homing before the stage holds the plate waits for it again.
  void board_bytes(const std::uint8_t* data, std::size_t size, double t_s);
  // The plate's true position held by the stage at board time t_s (nothing: not holding yet).
  std::optional<Vec3> drag(double t_s) const;
  // At the start of each control period (board time t_s), with the world and the board's sync
  // output as they are then: the stage's samples in the period that just ended, each of the plate
  // where it was at the sample's instant (between the two periods' starts, linearly) and of the
  // sync output as it was over that period.
  void sample(double t_s, const RobotWorld& world, bool sync);
  // Flushes the log; false when writing failed.
  bool finish();
  void flush() { log_.flush(); }

  std::uint64_t samples() const { return samples_; }
  double drag_start_s() const { return start_s_ ? *start_s_ + 1.0 : -1.0; }
  bool after_home() const { return options_.after_home_s >= 0.0; }
  // The stage holds the plate from board time *start_s_ on.
  bool holding(double t_s) const { return start_s_ && t_s >= *start_s_; }
  double path_duration_s() const { return duration_s_; }

 private:
  StageOptions options_;
  std::function<Vec3(double)> path_;  // drag: the trajectory's true position at its own time
  double duration_s_ = 0.0;
  link::FrameDecoder decoder_{link::Receiver::kBoard};
  link::FrameDecoder telemetry_decoder_{link::Receiver::kHost};  // the board's frames (after_home_s)
  std::optional<double> start_s_;                                // board time the stage takes hold
  std::optional<double> homed_s_;  // board time the board was first seen homed (after_home_s)
  bool homing_ended_ = false;      // the host's first command after that (the homing's disable) seen
  std::optional<Vec3> rest_m_;     // where the plate rested then
  std::ofstream log_;
  std::mt19937_64 generator_;
  std::normal_distribution<double> noise_;
  std::int64_t next_ = 0;              // the next stage sample index (t_stage = next_ / rate)
  std::optional<Vec3> last_position_;  // the plate at the last period's start (board time last_t_s_)
  double last_t_s_ = 0.0;
  bool last_sync_ = false;
  std::uint64_t samples_ = 0;
};

}  // namespace delta::cosim
