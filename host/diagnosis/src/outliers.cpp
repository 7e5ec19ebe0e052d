// Detection of isolated glitch rows (stage or encoder) so they neither fit nor judge the model.
#include "outliers.hpp"

#include <algorithm>
#include <cmath>
#include <set>

namespace delta::diagnosis {
namespace {

// Median absolute deviation from zero, scaled to a normal standard deviation.
double robust_sigma(std::vector<double> values) {
  if (values.empty()) return 0.0;
  for (double& value : values) value = std::abs(value);
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return 1.4826 * values[values.size() / 2];
}

// Spike of a 3-vector series at i; zero where i has no regular neighbours.
template <typename Get>
Vec3 spike(const std::vector<Sample>& rows, std::size_t i, Get get) {
  return get(rows[i]) - 0.5 * (get(rows[i - 1]) + get(rows[i + 1]));
}

// One series (position or angles): rows where the spike passes the threshold and the pattern.
template <typename Get>
void flag_spikes(const std::vector<Sample>& rows, const std::vector<bool>& judged, double minimum, Get get,
                 std::vector<double>& size) {
  std::vector<Vec3> spikes(rows.size(), Vec3::Zero());
  std::vector<double> components;
  for (std::size_t i = 1; i + 1 < rows.size(); ++i) {
    if (!judged[i]) continue;
    spikes[i] = spike(rows, i, get);
    for (int k = 0; k < 3; ++k) components.push_back(spikes[i][k]);
  }
  const double threshold = std::max(20.0 * robust_sigma(components), minimum);
  for (std::size_t i = 2; i + 2 < rows.size(); ++i) {
    const double norm = spikes[i].norm();
    if (!judged[i] || norm <= threshold) continue;
    // Neighbours of a one-row glitch g carry -g/2 each.
    bool pattern = true;
    for (std::size_t n : {i - 1, i + 1}) {
      const double along = -spikes[n].dot(spikes[i]) / (norm * norm);
      if (!(along > 0.25 && along < 0.75)) pattern = false;
    }
    if (pattern) size[i] = norm;
  }
}

}  // namespace

std::vector<Outlier> find_outliers(const std::vector<Sample>& rows, const std::string& recording,
                                   double encoder_step_deg) {
  std::vector<Outlier> outliers;
  if (rows.size() < 5) return outliers;
  const double usual = usual_interval_s(rows);
  std::vector<bool> judged(rows.size(), false);
  for (std::size_t i = 1; i + 1 < rows.size(); ++i)
    judged[i] = regular_step(rows, i, usual) && regular_step(rows, i + 1, usual);
  std::vector<double> position_spike(rows.size(), 0.0), angle_spike(rows.size(), 0.0);
  flag_spikes(
      rows, judged, 2e-6, [](const Sample& s) { return s.position_m; }, position_spike);
  flag_spikes(
      rows, judged, 3.0 * encoder_step_deg, [](const Sample& s) { return s.alpha_deg; }, angle_spike);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (position_spike[i] == 0.0 && angle_spike[i] == 0.0) continue;
    Outlier outlier;
    outlier.recording = recording;
    outlier.row = i + 1;
    outlier.t_s = rows[i].t_s;
    outlier.position_spike_mm = position_spike[i] * 1e3;
    outlier.angle_spike_deg = angle_spike[i];
    outliers.push_back(outlier);
  }
  return outliers;
}

double usual_interval_s(const std::vector<Sample>& rows) {
  std::vector<double> steps;
  for (std::size_t i = 1; i < rows.size(); ++i) steps.push_back(rows[i].t_s - rows[i - 1].t_s);
  if (steps.empty()) return 0.0;
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  return steps[steps.size() / 2];
}

bool regular_step(const std::vector<Sample>& rows, std::size_t i, double usual_s) {
  return i > 0 && i < rows.size() && std::abs(rows[i].t_s - rows[i - 1].t_s - usual_s) <= 0.25 * usual_s;
}

std::vector<Sample> without_outliers(const std::vector<Sample>& rows, const std::vector<Outlier>& outliers) {
  std::set<std::size_t> skip;
  for (const Outlier& outlier : outliers) skip.insert(outlier.row - 1);
  std::vector<Sample> kept;
  kept.reserve(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!skip.count(i)) kept.push_back(rows[i]);
  }
  return kept;
}

}  // namespace delta::diagnosis
