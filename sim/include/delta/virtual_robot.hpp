// The virtual robot: true geometry plus the SPEC effects, measured the way the paper's rig does.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "delta/effects.hpp"
#include "delta/geometry.hpp"
#include "delta/trajectory.hpp"

namespace delta {

// One row of a recording: time, measured joint angles and measured plate position.
struct Sample {
  double t_s = 0.0;
  Vec3 alpha_deg = Vec3::Zero();
  Vec3 position_m = Vec3::Zero();
  // How much each joint's reading counts in a fit (1; the diagnosis sets 0 where a reading cannot
  // be predicted from the plate, see host/diagnosis/src/closed_loop.hpp). Not part of any file.
  Vec3 fit_weight = Vec3::Ones();
};

struct RecordingOptions {
  std::size_t samples = 0;       // 0: the trajectory's default
  double rate_hz = 0.0;          // 0: the trajectory's default
  double angle_noise_deg = 0.0;  // extra white noise on the angles before quantisation (seeded)
  std::uint64_t seed = 1;
  bool quantise = true;  // encoder counts of 0.01 deg and stage counts of 6.87 nm
};

struct SimulationReport {
  std::vector<Sample> samples;
  std::size_t unreachable = 0;    // poses the true robot cannot reach (skipped, counted)
  std::string first_unreachable;  // reason for the first one, for the error message
};

class VirtualRobot {
 public:
  explicit VirtualRobot(const EffectSet& effects, const Geometry& nominal = Geometry::nominal());

  // Drag the plate along a trajectory (true plate position) and record what the rig measures.
  SimulationReport record(const Trajectory& trajectory, const RecordingOptions& options) const;

  const Geometry& true_geometry() const { return true_geometry_; }
  const EffectSet& effects() const { return effects_; }

 private:
  EffectSet effects_;
  Geometry true_geometry_;
};

}  // namespace delta
