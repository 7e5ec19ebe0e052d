// The virtual measuring stage (see measuring_stage.hpp).
#include "delta/cosim/measuring_stage.hpp"

#include <algorithm>
#include <cmath>

#include "delta/controller/stream_plan.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "delta/link/payloads.hpp"
#include "delta/output_file.hpp"
#include "delta/trajectory.hpp"

namespace delta::cosim {

MeasuringStage::MeasuringStage(const StageOptions& options, const EffectSet& effects, const Geometry& nominal)
    : options_(options), generator_(options.seed), noise_(0.0, options.noise_m) {
  if (options.mode.rfind("drag:", 0) == 0) {
    const std::string source = options.mode.substr(5);
    if (source.empty() || source.rfind("move:", 0) == 0) {
      throw InputError("--stage", 0, "drag needs a trajectory: drag:NAME or drag:FILE.csv");
    }
    controller::Path path;
    try {
      path = controller::load_path(source, 0.0);
    } catch (const std::invalid_argument& error) {
      throw InputError("--stage", 0, error.what());
    }
    const Geometry robot = apply_geometry_effects(nominal, effects);
    for (double t = 0.0;; t += 0.01) {
      const double u = std::min(t, path.duration_s());
      const IkSolution arms = inverse_kinematics(robot, path.at(u));
      if (!arms.ok()) {
        throw InputError(source, 0,
                         "the stage would drag the plate out of the robot's reach at t = " + std::to_string(u) +
                             " s: " + arms.reason());
      }
      if (u >= path.duration_s()) break;
    }
    duration_s_ = path.duration_s();
    path_ = [path = std::move(path)](double tau) { return path.at(tau); };
  } else if (options.mode != "follow") {
    throw InputError("--stage", 0, "'" + options.mode + "': choose drag:NAME, drag:FILE.csv or follow");
  }
  log_.open(options.log_path, std::ios::trunc);
  if (!log_) throw InputError(options.log_path, 0, "cannot be written");
  log_ << "# deltactl virtual-board --stage " << options.mode << ": the measuring stage's own log on its own clock\n"
       << (options.log_sync ? "t_s,x_m,y_m,z_m,sync\n" : "t_s,x_m,y_m,z_m\n");
  // The first sample at or after board time 0, on the stage's grid of whole periods of its clock.
  next_ = static_cast<std::int64_t>(std::ceil(options.clock_offset_s * options.rate_hz - 1e-9));
}

void MeasuringStage::host_bytes(const std::uint8_t* data, std::size_t size, double t_s) {
  if (!path_ || holding(t_s)) return;
  const std::vector<link::Frame> frames = decoder_.feed(data, size);  // (fed throughout: frames span reads)
  if (start_s_) return;  // armed: the stage takes hold at *start_s_ unless the board re-arms it
  if (options_.after_home_s < 0.0) {
    if (!frames.empty()) start_s_ = t_s;
    return;
  }
  // After the homing: its last command (the disable that ends `host home`), then the next
  // command's identify request (the start of `host record`).
  for (const link::Frame& frame : frames) {
    if (!homed_s_) break;
    if (frame.type == link::FrameType::kCommand) homing_ended_ = true;
    if (homing_ended_ && frame.type == link::FrameType::kIdentifyRequest) {
      start_s_ = t_s + options_.after_home_s;
      return;
    }
  }
}

void MeasuringStage::board_bytes(const std::uint8_t* data, std::size_t size, double t_s) {
  if (!path_ || options_.after_home_s < 0.0 || holding(t_s)) return;
  for (const link::Frame& frame : telemetry_decoder_.feed(data, size)) {
    if (frame.type != link::FrameType::kTelemetry) continue;
    const link::TelemetryPayload t = link::decode_telemetry(frame.payload);
    if (t.has(link::TelemetryFlag::kDriveEnable) || t.has(link::TelemetryFlag::kHoming)) {
      // The board is moving its arms (homing, or anything else) before the stage took hold: the
      // homing had not ended (a later phase, a keep-alive's identify in between); wait for its end
      // again, so that the stage never takes hold sooner than after_home_s after the drives went off.
      homed_s_.reset();
      homing_ended_ = false;
      start_s_.reset();
    } else if (!homed_s_ && t.has(link::TelemetryFlag::kReferenced)) {
      homed_s_ = t_s;
    }
  }
}

std::optional<Vec3> MeasuringStage::drag(double t_s) const {
  if (!start_s_ || !rest_m_ || t_s < *start_s_) return std::nullopt;
  const double into = t_s - *start_s_ - 1.0;  // trajectory time
  if (into >= 0.0) return path_(std::min(into, duration_s_));
  const double s = quintic_blend(t_s - *start_s_);
  return Vec3(*rest_m_ + s * (path_(0.0) - *rest_m_));
}

void MeasuringStage::sample(double t_s, const RobotWorld& world, bool sync) {
  if (path_ && start_s_ && !rest_m_ && t_s >= *start_s_) {
    const FkSolution plate = forward_kinematics(world.true_geometry(), world.true_alpha_deg());
    if (plate.ok()) rest_m_ = plate.position_m;
  }
  const Vec3 now = world.measured_position_m();
  const double scale = 1.0 + options_.clock_ppm * 1e-6;
  // The samples of the period just ended, [last_t_, t_s): the plate where it was at that instant
  // (between the period's ends, linearly), the sync output as it was over the period.
  for (;;) {
    const double t_stage = static_cast<double>(next_) / options_.rate_hz;
    const double t_board = (t_stage - options_.clock_offset_s) / scale;
    if (t_board >= t_s) break;
    ++next_;
    if (!last_position_ || t_board < last_t_s_) continue;  // (before the board started)
    const Vec3 p = *last_position_ + (t_board - last_t_s_) / (t_s - last_t_s_) * (now - *last_position_);
    log_ << format_number(t_stage);
    for (int k = 0; k < 3; ++k) log_ << ',' << format_number(quantise(p[k] + noise_(generator_), kStageResolutionM));
    if (options_.log_sync) log_ << ',' << (last_sync_ ? '1' : '0');
    log_ << '\n';
    ++samples_;
  }
  last_position_ = now;
  last_t_s_ = t_s;
  last_sync_ = sync;
}

bool MeasuringStage::finish() {
  log_.close();
  return static_cast<bool>(log_);
}

}  // namespace delta::cosim
