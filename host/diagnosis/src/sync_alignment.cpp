// The clocks from the board's stage sync output (sync_alignment.hpp).
#include "sync_alignment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "delta/geometry.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"

namespace delta::diagnosis {
namespace {

constexpr double kInvertedOfLevel = 0.75;  // a phase shift beyond this (of level_s) reads as an inverted input
constexpr double kMatchOfLevel = 0.25;     // a change this far (of level_s) from the board's is not one
constexpr double kMismatchShare = 0.02;    // of the changes, above which the logs do not belong together
constexpr int kSearchSteps = 200;          // of the searches along the rate
constexpr double kUniformSd = 0.28867513;  // standard deviation of a uniform distribution per unit width

std::string milliseconds(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", seconds * 1e3);
  return text;
}

struct Change {
  double a, b;  // the stage samples either side of it (its clock)
  double t;     // its board time, relative to their mean
};

// The stage's log and the alignment as it stands (offset_s is corrected by the changes' phase).
struct SyncLog {
  const std::string& stage_path;
  const std::vector<double>& stage_t;
  const std::vector<int>& sync;
  double offset_s, rate, level_s;
  // The board time of the change before stage sample k, at the alignment as it stands.
  double board_time(std::size_t k) const { return (0.5 * (stage_t[k - 1] + stage_t[k]) - offset_s) / (1.0 + rate); }
};

// The level changes between two samples no further apart than max_gap: the sample after each.
std::vector<std::size_t> level_changes(const SyncLog& log, double max_gap) {
  std::vector<std::size_t> after;
  for (std::size_t k = 1; k < log.stage_t.size(); ++k) {
    if (log.sync[k] != log.sync[k - 1] && log.stage_t[k] - log.stage_t[k - 1] <= max_gap) after.push_back(k);
  }
  return after;
}

// A change to level 1 falls at an odd multiple of level_s, to 0 at an even one: each change's
// board time less level x level_s is, modulo 2 level_s, the error of the alignment given. Their
// circular mean corrects an alignment up to level_s off (the changes are then matched to the
// board's at the corrected one; merge checks it against the positions).
void correct_phase(SyncLog& log, const std::vector<std::size_t>& after, SyncAlignment& out) {
  const double level_s = log.level_s;
  double cosines = 0.0, sines = 0.0;
  for (std::size_t k : after) {
    const double angle = kPi * (log.board_time(k) - log.sync[k] * level_s) / level_s;
    cosines += std::cos(angle);
    sines += std::sin(angle);
  }
  if (cosines == 0.0 && sines == 0.0) return;
  out.shift_s = std::atan2(sines, cosines) * level_s / kPi;
  // An input that inverts the level puts every change one level off: a shift of about level_s
  // either way. Positions that cannot fix the clocks (an ellipse: a time shift of it is an affine
  // map of it) would fit there too, so it is refused here, not left to them; a data alignment
  // really that far off is refused with it (drag longer).
  if (std::abs(out.shift_s) > kInvertedOfLevel * level_s) {
    throw InputError(log.stage_path, 0,
                     "its sync column looks inverted: its level changes fall " + milliseconds(out.shift_s) +
                         " ms (one level is " + milliseconds(level_s) +
                         " ms) off the clocks the positions give (a sync input that inverts the level: log "
                         "stage_sync_o as it is; or the positions' clocks that far off: drag longer)");
  }
  log.offset_s += out.shift_s * (1.0 + log.rate);
  out.corrected_lost_alignment = std::abs(out.shift_s) > kMatchOfLevel * level_s;
}

// Each change matched to the board's at the alignment as it stands: its stage samples and the
// board time of the board's change. None when there is no change; InputError when more than
// kMismatchShare of them match none (or fewer than two match).
std::vector<Change> matched_changes(const SyncLog& log, const std::vector<std::size_t>& after) {
  const double level_s = log.level_s;
  std::vector<Change> changes;
  const std::size_t seen = after.size();
  std::size_t mismatched = 0;
  for (std::size_t k : after) {
    const double board = log.board_time(k);
    const double n = std::round(board / level_s);
    const bool odd = std::fmod(n, 2.0) != 0.0;
    if (n < 1 || std::abs(board - n * level_s) > kMatchOfLevel * level_s || odd != (log.sync[k] == 1)) {
      ++mismatched;
      continue;
    }
    changes.push_back({log.stage_t[k - 1], log.stage_t[k], n * level_s});
  }
  if (seen == 0) return changes;
  if (static_cast<double>(mismatched) > kMismatchShare * static_cast<double>(seen) || changes.size() < 2) {
    throw InputError(log.stage_path, 0,
                     "its sync column does not follow the board's sync output (" + std::to_string(mismatched) +
                         " of its " + std::to_string(seen) + " level changes more than " +
                         format_number(kMatchOfLevel * level_s) +
                         " s from one, or the wrong way, at the clocks their phase gives): the logs do not belong "
                         "together, or the stage's input is not the board's stage_sync_o");
  }
  return changes;
}

// A least-squares line through the changes' midpoints against their board times (relative to
// their mean): the start, and the answer when no alignment leaves every change between its
// samples (a stage that samples its input late).
struct MidpointLine {
  double mean_mid = 0.0;  // the midpoints' mean
  double stt = 0.0;       // sum of the squared board times
  double scale_ls = 0.0;  // the slope: 1 + rate
  double sigma = 0.0;     // the midpoints' residual standard deviation
};

std::optional<MidpointLine> midpoint_line(const std::vector<Change>& changes, double count) {
  MidpointLine line;
  double stm = 0.0;
  for (const Change& c : changes) line.mean_mid += 0.5 * (c.a + c.b);
  line.mean_mid /= count;
  for (const Change& c : changes) {
    line.stt += c.t * c.t;
    stm += c.t * (0.5 * (c.a + c.b) - line.mean_mid);
  }
  if (!(line.stt > 0.0)) return std::nullopt;
  line.scale_ls = stm / line.stt;
  double ss = 0.0;
  for (const Change& c : changes) {
    const double e = 0.5 * (c.a + c.b) - line.mean_mid - line.scale_ls * c.t;
    ss += e * e;
  }
  line.sigma = std::sqrt(ss / std::max(1.0, count - 2.0));
  return line;
}

// The region: at scale s (1 + rate), the centre's offset o' lies in [lo(s), hi(s)); its width
// hi - lo is concave in s.
double bounds(const std::vector<Change>& changes, double s, double* lo, double* hi) {
  *lo = -std::numeric_limits<double>::infinity();
  *hi = std::numeric_limits<double>::infinity();
  for (const Change& c : changes) {
    *lo = std::max(*lo, c.a - s * c.t);
    *hi = std::min(*hi, c.b - s * c.t);
  }
  return *hi - *lo;
}

// The centre of the region every change leaves, with its spread, into `out`; false when no
// alignment leaves every change between its samples.
bool centre_of_region(const std::vector<Change>& changes, const MidpointLine& line, double t_mean, SyncAlignment& out) {
  const double scale_ls = line.scale_ls;
  const double reach = std::max(50.0 * line.sigma / std::sqrt(line.stt), 1e-6);
  double left = scale_ls - reach, right = scale_ls + reach, lo = 0.0, hi = 0.0;
  for (int step = 0; step < kSearchSteps; ++step) {  // the widest point (ternary search)
    const double m1 = left + (right - left) / 3.0, m2 = right - (right - left) / 3.0;
    if (bounds(changes, m1, &lo, &hi) < bounds(changes, m2, &lo, &hi)) {
      left = m1;
    } else {
      right = m2;
    }
  }
  const double widest = 0.5 * (left + right);
  if (!(bounds(changes, widest, &lo, &hi) > 0.0)) return false;
  // Each end of the feasible range of s, where the width comes to zero.
  auto end_of = [&](double inside, double outside) {
    for (int step = 0; step < kSearchSteps; ++step) {
      const double mid = 0.5 * (inside + outside);
      (bounds(changes, mid, &lo, &hi) > 0.0 ? inside : outside) = mid;
    }
    return inside;
  };
  const double s_lo = end_of(widest, scale_ls - 2.0 * reach), s_hi = end_of(widest, scale_ls + 2.0 * reach);
  const double s_centre = 0.5 * (s_lo + s_hi);
  double least = std::numeric_limits<double>::infinity(), most = -least;
  for (int k = 0; k <= 50; ++k) {
    bounds(changes, s_lo + (s_hi - s_lo) * k / 50.0, &lo, &hi);
    least = std::min(least, lo);
    most = std::max(most, hi);
  }
  bounds(changes, s_centre, &lo, &hi);
  const double centre = 0.5 * (lo + hi);
  out.consistent = true;
  out.rate = s_centre - 1.0;
  out.rate_sd = kUniformSd * (s_hi - s_lo);
  out.offset_s = centre - s_centre * t_mean;
  const double centre_sd = kUniformSd * (most - least);
  out.offset_sd_s = std::sqrt(centre_sd * centre_sd + t_mean * t_mean * out.rate_sd * out.rate_sd);
  return true;
}

}  // namespace

double max_stage_gap(const std::vector<double>& stage_t) {
  if (stage_t.size() < 2) return 0.0;
  std::vector<double> spacing(stage_t.size() - 1);
  for (std::size_t k = 1; k < stage_t.size(); ++k) spacing[k - 1] = stage_t[k] - stage_t[k - 1];
  std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2), spacing.end());
  return 3.0 * spacing[spacing.size() / 2];
}

SyncAlignment align_on_sync(const std::string& stage_path, const std::vector<double>& stage_t,
                            const std::vector<int>& sync, double offset_s, double rate, double level_s) {
  SyncAlignment out;
  if (stage_t.size() < 2) return out;
  SyncLog log{stage_path, stage_t, sync, offset_s, rate, level_s};
  const std::vector<std::size_t> after = level_changes(log, max_stage_gap(stage_t));
  correct_phase(log, after, out);
  std::vector<Change> changes = matched_changes(log, after);
  if (after.empty()) return out;
  out.changes = changes.size();
  const auto count = static_cast<double>(changes.size());
  double t_mean = 0.0;
  for (const Change& c : changes) t_mean += c.t;
  t_mean /= count;
  for (Change& c : changes) c.t -= t_mean;

  const std::optional<MidpointLine> line = midpoint_line(changes, count);
  if (!line) return out;
  if (centre_of_region(changes, *line, t_mean, out)) return out;
  out.rate = line->scale_ls - 1.0;
  out.rate_sd = line->sigma / std::sqrt(line->stt);
  out.offset_s = line->mean_mid - line->scale_ls * t_mean;
  const double centre_sd = line->sigma / std::sqrt(count);
  out.offset_sd_s = std::sqrt(centre_sd * centre_sd + t_mean * t_mean * out.rate_sd * out.rate_sd);
  return out;
}

}  // namespace delta::diagnosis
