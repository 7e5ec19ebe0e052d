// The phases of merging a run with the measuring stage's log (merge.hpp has the method and its
// figures; merge.cpp runs the phases in order):
//   the encoders' plate (merge_encoders.cpp): the readings between their counts, each joint's
//     direction of play, the rows where a joint may sit inside its play;
//   the coarse alignment (merge_coarse.cpp): binned plate paths correlated over every lag, then an
//     affine map with the play on finer bins, a first rate from windows of the run;
//   the fine fit (merge_fine.cpp): Gauss-Newton on the clocks with the robot's unknown effects
//     profiled out, outliers dropped pass by pass, and the sandwich covariance.
// Internal to delta::diagnosis (and its tests): the phases refuse what merge_logs refuses, with the
// same InputError naming the file.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "delta/diagnosis/merge.hpp"
#include "delta/geometry.hpp"
#include "delta/input_error.hpp"

#include "sync_alignment.hpp"

namespace delta::diagnosis::merging {

constexpr double kMonomialScaleM = 0.01;  // the unit of the plate in the fits: 10 mm
constexpr double kMinOverlapS = 10.0;     // of the logs, in the coarse alignment

// The two logs as merge_logs takes them (their paths name the files in errors).
struct Logs {
  const std::string& run_path;
  const std::vector<double>& run_t;
  const std::vector<Vec3>& run_alpha_deg;
  const std::string& stage_path;
  const std::vector<double>& stage_t;
  const std::vector<Vec3>& stage_m;
};

[[noreturn]] inline void refuse(const std::string& path, const std::string& reason) {
  throw InputError(path, 0, reason);
}

inline std::string fixed3(double value) {
  char text[64];
  std::snprintf(text, sizeof text, "%.3f", value);
  return text;
}

// ---- the encoders' plate ----

// The run's readings as the fits take them.
struct EncoderPlate {
  bool closed_loop = false;                      // closed-loop telemetry (closed_loop.hpp), not a drag
  std::vector<Vec3> alpha_deg;                   // the angles behind the readings
  std::vector<Vec3> position_m;                  // their nominal FK (NaN where it fails)
  std::vector<std::array<double, 3>> direction;  // of each joint's last move (+-1, 0 before any)
  std::vector<bool> play_band;                   // rows where a joint may sit inside its play (in_play)
};
EncoderPlate encoder_plate(const std::vector<double>& run_t, const std::vector<Vec3>& run_alpha_deg,
                           const Geometry& nominal);

// The readings between their counts: a reading changes when the angle crosses the boundary between
// two counts, halfway between the two readings, at about halfway between the two samples; between
// two crossings in the same direction the angle is interpolated linearly in time (within the count
// it holds, by construction). Between two crossings of the same boundary (the joint turned within
// a count) it is taken halfway between the boundary and the reading; before the first crossing and
// after the last, the reading.
std::vector<Vec3> dequantise(const std::vector<double>& t, const std::vector<Vec3>& alpha_deg);

// Rows where a joint may sit inside its play, its reading telling nothing of the plate's motion:
// from a reversal of the joint's true motion until the encoder follows again. Seen from the
// encoders, a hold (the reading unchanged) that the joint does not enter and leave moving the same
// way: a reversal, the hold before the first move, the hold at the end. Left in, the play's dead
// band reads as a lag (the encoders stand still while the stage moves on) and biases the clock
// offset by tens of milliseconds. Nothing is marked when that would leave less than a third of the
// rows (a closed loop dithering by a count: every hold is a reversal).
std::vector<bool> in_play(const std::vector<Vec3>& alpha_deg);

// The stage log, interpolated (cubic Hermite, Catmull-Rom slopes) where its samples are no further
// apart than max_stage_gap.
class StageCurve {
 public:
  StageCurve(const std::vector<double>& t, const std::vector<Vec3>& p) : t_(t), p_(p), max_gap_(max_stage_gap(t)) {}
  double first() const { return t_.front(); }
  double last() const { return t_.back(); }
  // False outside the log or across a gap.
  bool at(double tau, Vec3* position, Vec3* velocity) const;

 private:
  Vec3 slope(std::size_t k) const {
    const std::size_t a = k == 0 ? 0 : k - 1, b = std::min(k + 1, t_.size() - 1);
    return (p_[b] - p_[a]) / (t_[b] - t_[a]);
  }
  const std::vector<double>& t_;
  const std::vector<Vec3>& p_;
  double max_gap_ = 0.0;
};

// ---- the coarse alignment ----

// Plate positions averaged on absolute bins [k dt, (k + 1) dt).
struct Binned {
  std::int64_t first = 0;  // index of bin 0
  std::vector<Vec3> mean;
  std::vector<int> count;
  std::size_t valid = 0;
  std::vector<std::array<Vec3, 3>> play;  // the run's: each joint's Jacobian column times its mean direction
};

// An affine map between binned plate paths with each joint's play:
// stage = a (run - run_mean) + b + sum_j play_j a0 c_j (c_j the bin's play regressor, a0 the
// affine map fitted without the play).
struct Affine {
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity(), a0 = Eigen::Matrix3d::Identity();
  Vec3 b = Vec3::Zero(), run_mean = Vec3::Zero(), play = Vec3::Zero();
  Vec3 operator()(const Binned& run, std::size_t k) const {
    Vec3 p = b + a * (run.mean[k] - run_mean);
    for (std::size_t j = 0; j < 3; ++j) p += play[static_cast<Eigen::Index>(j)] * (a0 * run.play[k][j]);
    return p;
  }
};

// The clocks roughly aligned: t_stage = offset_s + (1 + rate) t_board, and the affine map (with
// each joint's play) from the encoders' plate to the stage's at that alignment.
struct CoarseAlignment {
  double correlation = 0.0;  // of the 0.5 s bins at the best lag
  double offset_s = 0.0;
  double rate = 0.0;
  Affine affine;
};
// Refuses logs that do not overlap enough, or whose plate paths do not correlate.
CoarseAlignment align_coarsely(const Logs& logs, const EncoderPlate& plate, const Geometry& nominal);

// The holds of a drag's readings in which a joint turned back inside its play and came out the same
// way (the reading held, the hold entered and left moving the same way: in_play does not see it)
// while the plate moved: the stage, mapped back to the encoders' plate (the inverse of the coarse
// affine map) and through the nominal inverse kinematics, gives each arm's motion within the hold;
// an arm that falls back from the furthest it reached since the hold began (the reading's step,
// the arm at the edge of its play pushing) by more than a tenth of a count has left that edge.
// Every row of such a hold: the arm inside its play says nothing of the reading, and the reading
// between its counts (interpolated in time over the hold) is off where the joint stood still. A
// joint barely moving on a sweep (its range a few degrees over ten minutes) turns inside its play
// for most of the drag; left in, those rows bias the clock offset by milliseconds.
std::vector<bool> turned_inside_play(const std::vector<double>& t, const std::vector<Vec3>& alpha_deg,
                                     const StageCurve& curve, double offset, double rate, const Affine& affine,
                                     const Geometry& geometry);

// ---- the fine fit ----

constexpr int kMonomials = 20;  // 1, x, y, z, their products up to the third degree

// One row of the fine fit's design (an axis of a run row): its nonzero columns, in increasing
// order.
constexpr int kRowNonzeros = 2 + kMonomials + 3 + 3 * 4;
struct SparseRow {
  int size = 0;
  std::array<int, kRowNonzeros> column{};
  std::array<double, kRowNonzeros> value{};
  void add(int c, double v) {
    column[static_cast<std::size_t>(size)] = c;
    value[static_cast<std::size_t>(size++)] = v;
  }
  double dot(const Eigen::VectorXd& theta) const {
    double sum = 0.0;
    for (int k = 0; k < size; ++k)
      sum += value[static_cast<std::size_t>(k)] * theta[column[static_cast<std::size_t>(k)]];
    return sum;
  }
  // h (upper triangle) += row' row, g += row' y.
  void accumulate(double y, Eigen::MatrixXd* h, Eigen::VectorXd* g) const;
};

// The fine fit (merge.hpp, step 2 and 3) from the coarse alignment: construct it (the fit rows, at
// most 20000 evenly thinned, and their Jacobians; refused when too few), run() its passes, then
// finish() for the figures.
class FineFit {
 public:
  FineFit(const Logs& logs, const EncoderPlate& plate, const StageCurve& curve, const Geometry& nominal,
          const CoarseAlignment& coarse);
  // The passes of Gauss-Newton on (clocks, play), each ending by dropping outliers.
  void run();
  // The residual at the alignment found, the covariance, the offset and rate into *out (fit_rows,
  // residual_rms_m, motion_rms_m, offset_signal_left, rate_signal_left, offset_s, offset_sd_s,
  // rate_ppm, rate_sd_ppm); refuses logs that still differ by too much.
  void finish(MergeResult* out);
  // The RMS residual of the kept fit rows at an alignment (centre: t_stage at the rows' mean board
  // time), the nuisance refitted there.
  double residual_rms_at(double centre, double rate);
  double t_mean() const { return t_mean_; }
  double rate() const { return rate_; }

 private:
  struct Normal {
    Eigen::MatrixXd h;  // upper triangle
    Eigen::VectorXd g;
    std::size_t used = 0;
  };
  void select_rows(const std::vector<bool>& turned);
  void measure_rows();
  void take_out_play();
  Vec3 beyond_affine(std::size_t r, const Vec3& s) const {
    return s - stage_at_mean_ - to_stage_ * (p_fit_[r] - p_mean_);
  }
  void design(std::size_t r, const Vec3& velocity);
  void accumulate(double at_centre, double at_rate, Normal* nm);
  Eigen::MatrixXd solve(const Normal& nm, const Eigen::MatrixXd& g, bool timing) const;
  double residuals(double at_centre, double at_rate, Eigen::VectorXd theta);
  void refuse_if_short(const Normal& nm) const;
  bool diverged(double at_centre, double at_rate) const;
  void fit_affine();
  void gauss_newton(double cost);
  bool drop_outliers(bool hold);  // false: done

  const Logs& logs_;
  const EncoderPlate& plate_;
  const StageCurve& curve_;
  const Geometry& nominal_;
  const std::size_t n_;  // run rows
  const double offset_;  // the coarse alignment's offset (the fit diverged far from it)
  double rate_ = 0.0, centre_ = 0.0;
  std::vector<std::size_t> rows_;                  // the fit rows: run rows
  std::size_t m_ = 0;                              // their number
  std::vector<std::array<Vec3, 3>> jacobian_;      // of the nominal FK (numerical, 1e-4 deg)
  double t_mean_ = 0.0, half_span_ = 0.0;          // of the fit rows' board times
  Vec3 p_mean_, alpha_lo_, alpha_hi_, count_deg_;  // the fit rows' mean plate and reading range; each
                                                   // joint's resolution
  Vec3 play_deg_;
  Eigen::Matrix3d to_stage_ = Eigen::Matrix3d::Identity();
  Vec3 stage_at_mean_;
  std::vector<Vec3> alpha_fit_, p_fit_;
  std::vector<std::array<Vec3, 3>> column_;  // each joint's Jacobian column in the stage's frame
  std::array<int, 3> knots_{}, spline_first_{};
  int columns_ = 0;
  std::array<SparseRow, 3> x_;
  std::vector<char> keep_;  // fit rows not dropped as outliers
  std::vector<Vec3> residual_;
  Normal normal_;
};

}  // namespace delta::diagnosis::merging
