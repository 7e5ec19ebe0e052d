// The merge's phases one by one (host/diagnosis/src/merge_phases.hpp), on logs made here: the
// nominal robot dragged along a seeded sweep, encoders of 0.01 deg counts at 1 kHz, a stage at
// 500 Hz on its own clock (12.345 s ahead, +150 ppm). test_merge.cpp checks the whole merge.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/effects.hpp"
#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "delta/trajectory.hpp"

#include "../../host/diagnosis/src/merge_phases.hpp"

namespace delta::diagnosis::merging {
namespace {

constexpr double kOffsetS = 12.345;
constexpr double kRate = 150e-6;

struct Drag {
  std::vector<double> run_t, stage_t;
  std::vector<Vec3> alpha, truth_deg, stage;
};

// `seconds` of the sweep `seed` from board time 3 s; the stage follows the plate of `stage_seed`'s
// sweep (the same one: logs that belong together).
Drag drag(double seconds, std::uint64_t seed = 7, std::uint64_t stage_seed = 7) {
  const Trajectory sweep = make_trajectory("sweep", seed), other = make_trajectory("sweep", stage_seed);
  const Geometry robot = Geometry::nominal();
  Drag d;
  for (std::size_t k = 0; k <= static_cast<std::size_t>(seconds * 1000); ++k) {
    const double t = 3.0 + static_cast<double>(k) * 1e-3;
    const IkSolution ik = inverse_kinematics(robot, sweep.position_m(t - 3.0));
    Vec3 a = ik.alpha_deg;
    for (int j = 0; j < 3; ++j) a[j] = quantise(a[j], kEncoderResolutionDeg);
    d.run_t.push_back(t);
    d.alpha.push_back(a);
    d.truth_deg.push_back(ik.alpha_deg);
  }
  for (std::int64_t k = static_cast<std::int64_t>(std::ceil((kOffsetS + 2.0) * 500));; ++k) {
    const double tau = static_cast<double>(k) / 500.0;
    const double t = (tau - kOffsetS) / (1 + kRate);
    if (t > seconds + 4.0) break;
    d.stage_t.push_back(tau);
    d.stage.push_back(other.position_m(std::max(0.0, t - 3.0)));
  }
  return d;
}

// A drag's logs as the phases take them, and its encoders' plate.
struct Phases {
  explicit Phases(Drag drag) : d(std::move(drag)), plate(encoder_plate(d.run_t, d.alpha, nominal)) {}
  const std::string run = "run.csv", stage = "stage.csv";
  const Drag d;
  const Geometry nominal = Geometry::nominal();
  const Logs logs{run, d.run_t, d.alpha, stage, d.stage_t, d.stage};
  const EncoderPlate plate;
};

TEST(MergePhases, DequantisedReadingsFollowTheAngleBetweenItsCounts) {
  const Drag d = drag(60.0);
  const std::vector<Vec3> between = dequantise(d.run_t, d.alpha);
  double raw = 0.0, smooth = 0.0;
  for (std::size_t i = 0; i < d.run_t.size(); ++i) {
    raw += (d.alpha[i] - d.truth_deg[i]).squaredNorm();
    smooth += (between[i] - d.truth_deg[i]).squaredNorm();
  }
  raw = std::sqrt(raw / (3.0 * d.run_t.size()));
  smooth = std::sqrt(smooth / (3.0 * d.run_t.size()));
  // The readings are off by a uniform quantisation error (0.01 / sqrt(12) = 0.0029 deg RMS).
  EXPECT_NEAR(raw, kEncoderResolutionDeg / std::sqrt(12.0), 0.0005);
  EXPECT_LT(smooth, raw / 5) << "readings " << raw << " deg RMS, between their counts " << smooth;
}

TEST(MergePhases, InPlayMarksTheHoldsThatDoNotContinueAMove) {
  // Joint 1 up 1 deg, then down; joints 2 and 3 rise all along: only joint 1's reversal, the holds
  // before the first move and at the end are marked.
  std::vector<Vec3> alpha;
  for (int k = 0; k <= 2000; ++k) {
    const double up = k <= 1000 ? k * 1e-3 : 2.0 - k * 1e-3;
    alpha.push_back(Vec3(quantise(20 + up, 0.01), quantise(20 + k * 5e-4, 0.01), quantise(30 + k * 5e-4, 0.01)));
  }
  const std::vector<bool> marked = in_play(alpha);
  EXPECT_TRUE(marked[0]) << "the hold before the first move";
  EXPECT_TRUE(marked[2000]) << "the hold at the end";
  EXPECT_TRUE(marked[1000]) << "the reversal";
  std::size_t count = 0;
  for (std::size_t k = 0; k < marked.size(); ++k) count += marked[k] ? 1 : 0;
  EXPECT_LT(count, 60u) << "only the holds at the ends and the reversal (a count lasts 10-20 rows)";
  EXPECT_FALSE(marked[500]);
  EXPECT_FALSE(marked[1500]);
}

TEST(MergePhases, TheCoarseAlignmentFindsTheStagesClockToAFewMilliseconds) {
  const Phases p(drag(120.0));
  EXPECT_FALSE(p.plate.closed_loop) << "a drag's readings";
  const CoarseAlignment coarse = align_coarsely(p.logs, p.plate, p.nominal);
  EXPECT_GT(coarse.correlation, 0.99);
  EXPECT_NEAR(coarse.offset_s, kOffsetS, 5e-3);
  EXPECT_NEAR(coarse.rate, kRate, 100e-6);
}

TEST(MergePhases, TheFineFitFindsTheClocksToTensOfMicroseconds) {
  const Phases p(drag(120.0));
  const CoarseAlignment coarse = align_coarsely(p.logs, p.plate, p.nominal);
  const StageCurve curve(p.d.stage_t, p.d.stage);
  FineFit fit(p.logs, p.plate, curve, p.nominal, coarse);
  fit.run();
  MergeResult out;
  fit.finish(&out);
  std::cout << "offset error " << (out.offset_s - kOffsetS) * 1e6 << " us (coarse "
            << (coarse.offset_s - kOffsetS) * 1e6 << "), rate error " << out.rate_ppm - kRate * 1e6 << " ppm (coarse "
            << (coarse.rate - kRate) * 1e6 << "), residual " << out.residual_rms_m * 1e9 << " nm\n";
  // A 2-minute drag: the nuisance takes up some of a clock error (merge.hpp); still far within the
  // coarse alignment's.
  EXPECT_NEAR(out.offset_s, kOffsetS, 100e-6);
  EXPECT_LT(std::abs(out.offset_s - kOffsetS), std::abs(coarse.offset_s - kOffsetS) / 4);
  EXPECT_NEAR(out.rate_ppm, kRate * 1e6, 1.0);
  EXPECT_LT(out.residual_rms_m, 1e-6) << "the nominal robot: only the encoders' counts are left";
  EXPECT_GT(out.fit_rows, 1000u);
  // Away from the clocks found, the positions fit worse.
  const double centre = out.offset_s + (1 + fit.rate()) * fit.t_mean();
  EXPECT_LT(fit.residual_rms_at(centre, fit.rate()), 1e-6);
  EXPECT_GT(fit.residual_rms_at(centre + 0.01, fit.rate()), 3 * fit.residual_rms_at(centre, fit.rate()));
}

TEST(MergePhases, AStageOfAnotherDragIsRefusedByTheCoarseAlignment) {
  const Phases p(drag(120.0, 7, 8));
  try {
    align_coarsely(p.logs, p.plate, p.nominal);
    FAIL() << "a stage log of another sweep was aligned";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("stage.csv"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("do not belong together"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace delta::diagnosis::merging
