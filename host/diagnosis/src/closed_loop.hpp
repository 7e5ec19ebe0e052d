// Closed-loop telemetry (the host's 1 kHz recording of a `host run`): what its readings say of the
// angle behind them (internal to the diagnosis library; used by diagnose and merge).
//
// The controller holds each reading at its reference. The angle behind the reading (the
// backlash's output, or the angle itself on a joint without play) stops just past the boundary
// between two counts that it crossed last, until the next step of the reference pushes it across
// the next one: the reading leads that angle by almost half a count in the direction of its last
// step, where a drag's angle moves on through the count and a reading's error is uniform. Fitted
// as it is, the lead is a backlash 0.008 deg narrower on every joint (1.8 noise floors on a
// held-out drag). Measured on the model board (4 runs of 240-300 s, two robots, every joint:
// reading - angle along the last step's direction, against the reading's speed over 0.1 s): 0.0043
// deg at rest and when slow, 0.0033 at 1.25 deg/s, 0.0017 at 2.5 and 0 above 7 deg/s, where the
// angle moves on through every count; a joint without play dithers by a count (its reading turns
// back at 11-62 % of its steps, a joint with play at 0.7-2.7 %, a drag's at 0.1-0.2 %) and leads
// by 0.0041 at rest, 0.0025 at 1 deg/s. The reading less that lead is within 0.0005 deg of the
// angle on average in every speed band.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "delta/diagnosis/diagnose.hpp"
#include "delta/geometry.hpp"

namespace delta::diagnosis::closed_loop {

constexpr double kTelemetrySpacingS = 0.005;  // median row spacing at or below this: telemetry
constexpr double kReversingSteps = 0.005;     // of a joint's steps turning back: closed loop
constexpr double kDitherSteps = 0.05;         // a joint without play, dithering by a count
constexpr double kSpeedHalfWindowS = 0.05;    // the reading's speed over +-50 ms
constexpr std::size_t kLeastSteps = 200;      // steps of a joint before its turns count

struct Lead {
  double speed_deg_s, play_counts, dither_counts;
};
constexpr std::array<Lead, 11> kLeads = {{{0.0, 0.43, 0.41},
                                          {0.15, 0.43, 0.38},
                                          {0.25, 0.43, 0.35},
                                          {0.4, 0.42, 0.32},
                                          {0.6, 0.40, 0.28},
                                          {0.85, 0.37, 0.25},
                                          {1.25, 0.33, 0.24},
                                          {1.75, 0.26, 0.23},
                                          {2.5, 0.17, 0.18},
                                          {4.0, 0.07, 0.07},
                                          {7.0, 0.01, 0.01}}};

// The lead in counts at a reading's speed (deg/s), linear between the measured points.
inline double lead_counts(double speed_deg_s, bool dithering) {
  if (speed_deg_s >= kLeads.back().speed_deg_s) return 0.0;
  for (std::size_t k = 1; k < kLeads.size(); ++k) {
    if (speed_deg_s < kLeads[k].speed_deg_s) {
      const Lead& a = kLeads[k - 1];
      const Lead& b = kLeads[k];
      const double s = (speed_deg_s - a.speed_deg_s) / (b.speed_deg_s - a.speed_deg_s);
      return dithering ? a.dither_counts + s * (b.dither_counts - a.dither_counts)
                       : a.play_counts + s * (b.play_counts - a.play_counts);
    }
  }
  return 0.0;
}

struct Readings {
  bool closed_loop = false;
  std::array<bool, 3> dithering{};  // joints whose reading dithers by a count (no play)
  std::vector<Vec3> angle_deg;      // closed loop: each reading less its lead
  std::vector<Vec3> speed_deg_s;    // closed loop: each reading's speed over +-kSpeedHalfWindowS
  std::vector<Vec3> way;            // closed loop: the direction of each joint's last step (0: none yet)
};

// Whether readings (time order) are closed-loop telemetry: rows at most kTelemetrySpacingS apart
// (median) and a joint whose reading turns back at more than kReversingSteps of at least
// kLeastSteps steps. If so, the angle behind each reading, its speed and its last step's direction.
inline Readings read_closed_loop(const std::vector<double>& t, const std::vector<Vec3>& reading_deg, double count_deg) {
  Readings out;
  const std::size_t n = t.size();
  if (n < 1000) return out;
  std::vector<double> spacing(n - 1);
  for (std::size_t i = 1; i < n; ++i) spacing[i - 1] = t[i] - t[i - 1];
  std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2), spacing.end());
  if (!(spacing[spacing.size() / 2] <= kTelemetrySpacingS)) return out;
  for (int j = 0; j < 3; ++j) {
    std::size_t steps = 0, turns = 0;
    double last = 0.0;
    for (std::size_t i = 1; i < n; ++i) {
      const double step = reading_deg[i][j] - reading_deg[i - 1][j];
      if (step == 0.0) continue;
      const double way = step > 0 ? 1.0 : -1.0;
      turns += last != 0.0 && way != last ? 1 : 0;
      ++steps;
      last = way;
    }
    const double reversing = steps > 1 ? static_cast<double>(turns) / static_cast<double>(steps - 1) : 0.0;
    out.dithering[static_cast<std::size_t>(j)] = steps >= kLeastSteps && reversing > kDitherSteps;
    out.closed_loop = out.closed_loop || (steps >= kLeastSteps && reversing > kReversingSteps);
  }
  if (!out.closed_loop) return out;
  out.angle_deg.assign(n, Vec3::Zero());
  out.speed_deg_s.assign(n, Vec3::Zero());
  out.way.assign(n, Vec3::Zero());
  for (int j = 0; j < 3; ++j) {
    double way = 0.0;
    std::size_t lo = 0, hi = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (i > 0) {
        const double step = reading_deg[i][j] - reading_deg[i - 1][j];
        if (step != 0.0) way = step > 0 ? 1.0 : -1.0;
      }
      while (t[lo] < t[i] - kSpeedHalfWindowS) ++lo;
      while (hi + 1 < n && t[hi + 1] <= t[i] + kSpeedHalfWindowS) ++hi;
      const double span = t[hi] - t[lo];
      const double speed = span > 0 ? std::abs(reading_deg[hi][j] - reading_deg[lo][j]) / span : 0.0;
      out.speed_deg_s[i][j] = speed;
      out.way[i][j] = way;
      out.angle_deg[i][j] =
          reading_deg[i][j] - way * lead_counts(speed, out.dithering[static_cast<std::size_t>(j)]) * count_deg;
    }
  }
  return out;
}

// The arm of a joint with play, in closed loop, does not sit at the play's end: each push of the
// reading's next count carries it there for a moment, then it falls back (by 0.018 deg on average
// at 0.2 deg/s, 0.003 at 1.5; docs/lab_loop.md). A stage sampling at 250-1000 Hz, resampled at the
// board's times, misses most of those moments, and a play fitted to it comes out narrower than the
// robot's: measured on a robot with 0.05 / 0.18 / 0.1 deg of play on a 240 s run (path B of
// scripts/closed_loop_runs.sh; truth recording), the readings less their lead fit the true play
// exactly against the true angles at 1 kHz, 0.003-0.004 deg narrow against those angles sampled at
// 250 Hz and interpolated, 0.001-0.002 at 1000 Hz half a sample off (1.1-1.2 floors held out on a
// drag). Faster than kSteadySpeedDegS the arm rides the play's end and the interpolated angles fit
// the true play exactly again (at 1.5 deg/s one joint still 0.001 narrow). So where a joint with
// play moves that fast for kLeastSteadyS each way, only those rows of it count in the fit (the
// play's state still follows every row); otherwise every row does, and the play may come out narrow.
constexpr double kSteadySpeedDegS = 2.5;
constexpr double kLeastSteadyS = 5.0;

struct FitWeights {
  std::vector<Vec3> weight;  // per row and joint: 1 counts, 0 does not
  std::array<FitRows, 3> joints{};
};

// The fit weights of closed-loop readings (read_closed_loop of the same rows): joints that do not
// dither by a count have play.
inline FitWeights fit_weights(const std::vector<double>& t, const Readings& readings) {
  FitWeights out;
  out.weight.assign(t.size(), Vec3::Ones());
  if (!readings.closed_loop) return out;
  for (int j = 0; j < 3; ++j) {
    if (readings.dithering[static_cast<std::size_t>(j)]) continue;
    double forward = 0.0, backward = 0.0;
    for (std::size_t i = 1; i < t.size(); ++i) {
      if (readings.speed_deg_s[i][j] < kSteadySpeedDegS) continue;
      (readings.way[i][j] > 0 ? forward : backward) += t[i] - t[i - 1];
    }
    const bool enough = forward >= kLeastSteadyS && backward >= kLeastSteadyS;
    out.joints[static_cast<std::size_t>(j)] = enough ? FitRows::fast_only : FitRows::too_slow;
    if (!enough) continue;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (readings.speed_deg_s[i][j] < kSteadySpeedDegS) out.weight[i][j] = 0.0;
    }
  }
  return out;
}

}  // namespace delta::diagnosis::closed_loop
