// The clocks from the board's stage sync output (sync_alignment.hpp).
#include "sync_alignment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

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
  const double max_gap = max_stage_gap(stage_t);

  // The level changes between two samples no further apart than max_gap: the sample after each,
  // and its board time at the alignment as it stands (offset_s is corrected below).
  std::vector<std::size_t> after;
  for (std::size_t k = 1; k < stage_t.size(); ++k) {
    if (sync[k] != sync[k - 1] && stage_t[k] - stage_t[k - 1] <= max_gap) after.push_back(k);
  }
  auto board_time = [&](std::size_t k) { return (0.5 * (stage_t[k - 1] + stage_t[k]) - offset_s) / (1.0 + rate); };

  // A change to level 1 falls at an odd multiple of level_s, to 0 at an even one: each change's
  // board time less level x level_s is, modulo 2 level_s, the error of the alignment given. Their
  // circular mean corrects an alignment up to level_s off (the changes are then matched to the
  // board's at the corrected one; merge checks it against the positions).
  double cosines = 0.0, sines = 0.0;
  for (std::size_t k : after) {
    const double angle = kPi * (board_time(k) - sync[k] * level_s) / level_s;
    cosines += std::cos(angle);
    sines += std::sin(angle);
  }
  if (cosines != 0.0 || sines != 0.0) {
    out.shift_s = std::atan2(sines, cosines) * level_s / kPi;
    // An input that inverts the level puts every change one level off: a shift of about level_s
    // either way. Positions that cannot fix the clocks (an ellipse: a time shift of it is an affine
    // map of it) would fit there too, so it is refused here, not left to them; a data alignment
    // really that far off is refused with it (drag longer).
    if (std::abs(out.shift_s) > kInvertedOfLevel * level_s) {
      throw InputError(stage_path, 0,
                       "its sync column looks inverted: its level changes fall " + milliseconds(out.shift_s) +
                           " ms (one level is " + milliseconds(level_s) +
                           " ms) off the clocks the positions give (a sync input that inverts the level: log "
                           "stage_sync_o as it is; or the positions' clocks that far off: drag longer)");
    }
    offset_s += out.shift_s * (1.0 + rate);
    out.corrected_lost_alignment = std::abs(out.shift_s) > kMatchOfLevel * level_s;
  }

  std::vector<Change> changes;
  const std::size_t seen = after.size();
  std::size_t mismatched = 0;
  for (std::size_t k : after) {
    const double board = board_time(k);
    const double n = std::round(board / level_s);
    const bool odd = std::fmod(n, 2.0) != 0.0;
    if (n < 1 || std::abs(board - n * level_s) > kMatchOfLevel * level_s || odd != (sync[k] == 1)) {
      ++mismatched;
      continue;
    }
    changes.push_back({stage_t[k - 1], stage_t[k], n * level_s});
  }
  if (seen == 0) return out;
  if (static_cast<double>(mismatched) > kMismatchShare * static_cast<double>(seen) || changes.size() < 2) {
    throw InputError(stage_path, 0,
                     "its sync column does not follow the board's sync output (" + std::to_string(mismatched) +
                         " of its " + std::to_string(seen) + " level changes more than " +
                         format_number(kMatchOfLevel * level_s) +
                         " s from one, or the wrong way, at the clocks their phase gives): the logs do not belong "
                         "together, or the stage's input is not the board's stage_sync_o");
  }
  out.changes = changes.size();
  const auto count = static_cast<double>(changes.size());
  double t_mean = 0.0;
  for (const Change& c : changes) t_mean += c.t;
  t_mean /= count;
  for (Change& c : changes) c.t -= t_mean;

  // A least-squares line through the changes' midpoints: the start, and the answer when no
  // alignment leaves every change between its samples (a stage that samples its input late).
  double stt = 0.0, stm = 0.0, mean_mid = 0.0;
  for (const Change& c : changes) mean_mid += 0.5 * (c.a + c.b);
  mean_mid /= count;
  for (const Change& c : changes) {
    stt += c.t * c.t;
    stm += c.t * (0.5 * (c.a + c.b) - mean_mid);
  }
  if (!(stt > 0.0)) return out;
  const double scale_ls = stm / stt;
  double ss = 0.0;
  for (const Change& c : changes) {
    const double e = 0.5 * (c.a + c.b) - mean_mid - scale_ls * c.t;
    ss += e * e;
  }
  const double sigma = std::sqrt(ss / std::max(1.0, count - 2.0));

  // The region: at scale s (1 + rate), the centre's offset o' lies in [lo(s), hi(s)); its width
  // hi - lo is concave in s.
  auto bounds = [&](double s, double* lo, double* hi) {
    *lo = -std::numeric_limits<double>::infinity();
    *hi = std::numeric_limits<double>::infinity();
    for (const Change& c : changes) {
      *lo = std::max(*lo, c.a - s * c.t);
      *hi = std::min(*hi, c.b - s * c.t);
    }
    return *hi - *lo;
  };
  const double reach = std::max(50.0 * sigma / std::sqrt(stt), 1e-6);
  double left = scale_ls - reach, right = scale_ls + reach, lo = 0.0, hi = 0.0;
  for (int step = 0; step < kSearchSteps; ++step) {  // the widest point (ternary search)
    const double m1 = left + (right - left) / 3.0, m2 = right - (right - left) / 3.0;
    if (bounds(m1, &lo, &hi) < bounds(m2, &lo, &hi)) {
      left = m1;
    } else {
      right = m2;
    }
  }
  const double widest = 0.5 * (left + right);
  if (bounds(widest, &lo, &hi) > 0.0) {
    // Each end of the feasible range of s, where the width comes to zero.
    auto end_of = [&](double inside, double outside) {
      for (int step = 0; step < kSearchSteps; ++step) {
        const double mid = 0.5 * (inside + outside);
        (bounds(mid, &lo, &hi) > 0.0 ? inside : outside) = mid;
      }
      return inside;
    };
    const double s_lo = end_of(widest, scale_ls - 2.0 * reach), s_hi = end_of(widest, scale_ls + 2.0 * reach);
    const double s_centre = 0.5 * (s_lo + s_hi);
    double least = std::numeric_limits<double>::infinity(), most = -least;
    for (int k = 0; k <= 50; ++k) {
      bounds(s_lo + (s_hi - s_lo) * k / 50.0, &lo, &hi);
      least = std::min(least, lo);
      most = std::max(most, hi);
    }
    bounds(s_centre, &lo, &hi);
    const double centre = 0.5 * (lo + hi);
    out.consistent = true;
    out.rate = s_centre - 1.0;
    out.rate_sd = kUniformSd * (s_hi - s_lo);
    out.offset_s = centre - s_centre * t_mean;
    const double centre_sd = kUniformSd * (most - least);
    out.offset_sd_s = std::sqrt(centre_sd * centre_sd + t_mean * t_mean * out.rate_sd * out.rate_sd);
    return out;
  }
  out.rate = scale_ls - 1.0;
  out.rate_sd = sigma / std::sqrt(stt);
  out.offset_s = mean_mid - scale_ls * t_mean;
  const double centre_sd = sigma / std::sqrt(count);
  out.offset_sd_s = std::sqrt(centre_sd * centre_sd + t_mean * t_mean * out.rate_sd * out.rate_sd);
  return out;
}

}  // namespace delta::diagnosis
