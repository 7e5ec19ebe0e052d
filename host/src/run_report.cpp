// A run's accuracy: plate and joint errors by segment of the reference (see run_report.hpp).
#include "delta/run_report.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"
#include "delta/recording.hpp"
#include "delta/table.hpp"

namespace delta {
namespace {

constexpr double kTruthGapS = 0.01;  // a run row this far from the truth's rows is not measured
constexpr double kMaxAngleDeg = 360.0;
constexpr double kMaxPositionM = 1.0;

enum Column : std::size_t {
  kT,
  kAlpha1,
  kAlpha2,
  kAlpha3,
  kRef1,
  kRef2,
  kRef3,
  kXRef,
  kYRef,
  kZRef,
  kX,
  kY,
  kZ,
  kDrives,
  kNet1,  // a co-simulation's (cosim --out): its joint references and reference position
  kNet2,
  kNet3,
  kCosimXRef,
  kCosimYRef,
  kCosimZRef,
};

struct Accumulator {
  std::size_t rows = 0;
  Vec3 sum_sq = Vec3::Zero(), max_abs = Vec3::Zero();
  double sum_sq_distance = 0.0, max_distance = 0.0, max_at = 0.0;
  void add(const Vec3& e, double t) {
    ++rows;
    sum_sq += e.cwiseAbs2();
    max_abs = max_abs.cwiseMax(e.cwiseAbs());
    const double d = e.norm();
    sum_sq_distance += d * d;
    if (d > max_distance) {
      max_distance = d;
      max_at = t;
    }
  }
  Vec3 rms() const { return rows ? Vec3((sum_sq / static_cast<double>(rows)).cwiseSqrt()) : Vec3::Zero(); }
};

// The rows of the reference's dwells (true), and the dwells: greedy from each row, as long as the
// reference stays within the band of where the stretch started.
std::vector<bool> find_dwells(const RunColumns& run, const std::vector<std::size_t>& rows, std::vector<Dwell>* dwells) {
  const bool by_position = !run.reference_m.empty();
  const double band = by_position ? kDwellBandM : kDwellBandDeg;
  auto reference = [&](std::size_t i) -> const Vec3& {
    return by_position ? run.reference_m[rows[i]] : run.alpha_ref_deg[rows[i]];
  };
  std::vector<bool> at_rest(rows.size(), false);
  std::size_t i = 0;
  while (i < rows.size()) {
    std::size_t j = i + 1;
    // Consecutive driven rows only: a stretch with the drives off between is two.
    while (j < rows.size() && rows[j] == rows[j - 1] + 1 && (reference(j) - reference(i)).cwiseAbs().maxCoeff() <= band)
      ++j;
    const double duration = run.t_s[rows[j - 1]] - run.t_s[rows[i]];
    if (duration >= kDwellMinS) {
      Dwell d;
      d.start_s = run.t_s[rows[i]];
      d.duration_s = duration;
      d.rows = j - i;
      if (by_position) d.reference_m = reference(i);
      dwells->push_back(d);
      std::fill(at_rest.begin() + static_cast<std::ptrdiff_t>(i), at_rest.begin() + static_cast<std::ptrdiff_t>(j),
                true);
      i = j;
    } else {
      ++i;
    }
  }
  return at_rest;
}

// Reversals of one signal: the last row at its extreme before it moves back by more than h.
void find_reversals(const std::vector<double>& t, const std::vector<double>& v, double h, const std::string& name,
                    std::vector<Reversal>* out) {
  if (v.empty()) return;
  int direction = 0;
  double high = v[0], low = v[0], extreme = v[0];
  std::size_t extreme_at = 0;
  for (std::size_t i = 1; i < v.size(); ++i) {
    if (direction == 0) {
      high = std::max(high, v[i]);
      low = std::min(low, v[i]);
      if (v[i] - low > h || high - v[i] > h) {  // the first move: no reversal yet
        direction = v[i] - low > h ? 1 : -1;
        extreme = v[i];
        extreme_at = i;
      }
      continue;
    }
    if (direction * (v[i] - extreme) >= 0.0) {  // at or beyond the extreme (the last row at it)
      extreme = v[i];
      extreme_at = i;
    } else if (direction * (extreme - v[i]) > h) {
      out->push_back({t[extreme_at], name});
      direction = -direction;
      extreme = v[i];
      extreme_at = i;
    }
  }
}

std::string um(double metres, int decimals = 2) { return fixed(metres * 1e6, decimals); }

std::string triple(const Vec3& v, double scale, int decimals) {
  return fixed(v[0] * scale, decimals) + " / " + fixed(v[1] * scale, decimals) + " / " + fixed(v[2] * scale, decimals);
}

nlohmann::json vec(const Vec3& v, double scale) { return {v[0] * scale, v[1] * scale, v[2] * scale}; }

}  // namespace

const char* segment_name(int segment) {
  switch (segment) {
    case kMoving:
      return "moving";
    case kAtRest:
      return "at rest";
    case kReversals:
      return "reversals";
    default:
      return "all";
  }
}

RunColumns read_run_columns(const std::string& path) {
  CsvTable table =
      read_csv(path, {"t_s", "alpha1_deg", "alpha2_deg", "alpha3_deg"},
               {"alpha1_ref_deg", "alpha2_ref_deg", "alpha3_ref_deg", "x_ref_m", "y_ref_m", "z_ref_m", "x_m", "y_m",
                "z_m", "drives_enabled", "net1_deg", "net2_deg", "net3_deg", "ref_x_m", "ref_y_m", "ref_z_m"});
  // A co-simulation's recording names the same quantities otherwise: taken in their place.
  auto take = [&](std::size_t to, std::size_t from) {
    if (table.present[to] || !table.present[from]) return;
    table.present[to] = true;
    for (auto& row : table.rows) row[to] = row[from];
  };
  for (std::size_t k = 0; k < 3; ++k) {
    take(kRef1 + k, kNet1 + k);
    take(kXRef + k, kCosimXRef + k);
  }
  for (std::size_t k = kRef1; k <= kRef3; ++k) {
    if (!table.present[k]) {
      throw InputError(path, 0,
                       "missing column '" + table.columns[k] +
                           "' (the board's joint references: a host run's recording, or net1..3_deg of a cosim's)");
    }
  }
  const bool reference = table.present[kXRef] && table.present[kYRef] && table.present[kZRef];
  const bool plate = table.present[kX] && table.present[kY] && table.present[kZ];
  RunColumns run;
  run.path = path;
  run.has_drives_column = table.present[kDrives];
  const std::size_t n = table.rows.size();
  run.t_s.resize(n);
  run.line = table.line_numbers;
  run.alpha_deg.resize(n);
  run.alpha_ref_deg.resize(n);
  run.driven.resize(n);
  if (reference) run.reference_m.resize(n);
  if (plate) run.plate_m.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& row = table.rows[i];
    if (i > 0) check_time_order(table, i, kT);
    run.t_s[i] = row[kT];
    run.alpha_deg[i] = Vec3(row[kAlpha1], row[kAlpha2], row[kAlpha3]);
    run.alpha_ref_deg[i] = Vec3(row[kRef1], row[kRef2], row[kRef3]);
    for (std::size_t k = kAlpha1; k <= kRef3; ++k) {
      if (std::abs(row[k]) > kMaxAngleDeg) {
        throw InputError(path, table.line_numbers[i],
                         table.columns[k] + " is " + format_number(row[k]) + " deg: beyond 360 deg, not an angle");
      }
    }
    for (std::size_t k = kXRef; k <= kZ; ++k) {
      if (table.present[k] && std::abs(row[k]) > kMaxPositionM) {
        throw InputError(path, table.line_numbers[i],
                         table.columns[k] + " is " + format_number(row[k]) + " m: beyond 1 m, not the plate");
      }
    }
    if (reference) run.reference_m[i] = Vec3(row[kXRef], row[kYRef], row[kZRef]);
    if (plate) run.plate_m[i] = Vec3(row[kX], row[kY], row[kZ]);
    if (run.has_drives_column && row[kDrives] != 0.0 && row[kDrives] != 1.0) {
      throw InputError(path, table.line_numbers[i], "drives_enabled is " + format_number(row[kDrives]) + ": 0 or 1");
    }
    run.driven[i] = !run.has_drives_column || row[kDrives] != 0.0;
  }
  return run;
}

PlateTrack plate_from_run(const RunColumns& run) {
  PlateTrack track;
  track.source = "the run's own x_m,y_m,z_m";
  track.measured.assign(run.t_s.size(), !run.plate_m.empty());
  track.plate_m = run.plate_m.empty() ? std::vector<Vec3>(run.t_s.size(), Vec3::Zero()) : run.plate_m;
  return track;
}

PlateTrack plate_from_truth(const RunColumns& run, const std::string& truth_path) {
  const CsvTable truth = read_csv(truth_path, {"t_s", "x_m", "y_m", "z_m"});
  for (std::size_t i = 1; i < truth.rows.size(); ++i) check_time_order(truth, i, 0);
  PlateTrack track;
  track.source = "the virtual board's truth " + truth_path + " (board time)";
  track.measured.assign(run.t_s.size(), false);
  track.plate_m.assign(run.t_s.size(), Vec3::Zero());
  std::size_t k = 0;  // truth.rows[k].t <= t < truth.rows[k + 1].t
  for (std::size_t i = 0; i < run.t_s.size(); ++i) {
    const double t = run.t_s[i];
    while (k + 1 < truth.rows.size() && truth.rows[k + 1][0] <= t) ++k;
    const auto& a = truth.rows[k];
    const Vec3 pa(a[1], a[2], a[3]);
    if (k + 1 >= truth.rows.size() || a[0] > t) {
      if (std::abs(a[0] - t) < 1e-9) {  // exactly at the first or last row
        track.measured[i] = true;
        track.plate_m[i] = pa;
      }
      continue;
    }
    const auto& b = truth.rows[k + 1];
    if (t - a[0] > kTruthGapS || b[0] - t > kTruthGapS) continue;
    const double s = b[0] > a[0] ? (t - a[0]) / (b[0] - a[0]) : 0.0;
    track.measured[i] = true;
    track.plate_m[i] = (1.0 - s) * pa + s * Vec3(b[1], b[2], b[3]);
  }
  return track;
}

RunReport make_run_report(const RunColumns& run, const PlateTrack* plate) {
  RunReport report;
  report.run = run.path;
  report.rows = run.t_s.size();
  report.has_reference_position = !run.reference_m.empty();
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < run.t_s.size(); ++i) {
    if (run.driven[i]) rows.push_back(i);
  }
  report.driven_rows = rows.size();
  if (rows.empty()) {
    throw InputError(run.path, 0,
                     "no row with the drives on (drives_enabled): not a run of the robot (a drag recorded with the "
                     "drives off is merged and diagnosed, not reported)");
  }
  report.first_s = run.t_s[rows.front()];
  report.last_s = run.t_s[rows.back()];

  // The reference's segments.
  const std::vector<bool> at_rest = find_dwells(run, rows, &report.dwells);
  std::vector<double> t(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) t[i] = run.t_s[rows[i]];
  std::vector<double> v(rows.size());
  const char* axis = "xyz";
  for (int k = 0; k < 3 && report.has_reference_position; ++k) {
    for (std::size_t i = 0; i < rows.size(); ++i) v[i] = run.reference_m[rows[i]][k];
    find_reversals(t, v, kReversalHysteresisM, std::string(1, axis[k]), &report.reversals);
  }
  for (int j = 0; j < 3; ++j) {
    for (std::size_t i = 0; i < rows.size(); ++i) v[i] = run.alpha_ref_deg[rows[i]][j];
    find_reversals(t, v, kReversalHysteresisDeg, "alpha" + std::to_string(j + 1), &report.reversals);
  }
  std::sort(report.reversals.begin(), report.reversals.end(),
            [](const Reversal& a, const Reversal& b) { return a.t_s < b.t_s; });
  std::vector<int> segment(rows.size(), kMoving);
  {
    std::size_t r = 0;  // the first reversal whose window may still reach t
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (at_rest[i]) {
        segment[i] = kAtRest;
        continue;
      }
      while (r < report.reversals.size() && report.reversals[r].t_s + kReversalAfterS < t[i]) ++r;
      if (r < report.reversals.size() && report.reversals[r].t_s - kReversalBeforeS <= t[i]) segment[i] = kReversals;
    }
  }

  // The figures.
  const bool plate_known = plate != nullptr && report.has_reference_position;
  if (plate == nullptr) {
    report.plate_source =
        run.plate_m.empty()
            ? "not measured: the run has no x_m,y_m,z_m (run-report --stage STAGE.csv or --truth TRUTH.csv measures it)"
            : "not measured";
  } else if (!report.has_reference_position) {
    report.plate_source = "not measured: the run has no reference position (x_ref_m,y_ref_m,z_ref_m)";
  } else {
    report.plate_source = plate->source;
    report.plate_note = plate->note;
  }
  Accumulator plate_sum[kRunSegments], joint_sum[kRunSegments];
  std::size_t dwell = 0;
  std::vector<double> dwell_sum(report.dwells.size(), 0.0), settled_sum(report.dwells.size(), 0.0);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::size_t row = rows[i];
    const Vec3 joint = run.alpha_ref_deg[row] - run.alpha_deg[row];
    joint_sum[kAllRows].add(joint, t[i]);
    joint_sum[segment[i]].add(joint, t[i]);
    if (!plate_known || !plate->measured[row]) continue;
    const Vec3 e = plate->plate_m[row] - run.reference_m[row];
    plate_sum[kAllRows].add(e, t[i]);
    plate_sum[segment[i]].add(e, t[i]);
    if (segment[i] == kAtRest) {
      while (dwell + 1 < report.dwells.size() && report.dwells[dwell].start_s + report.dwells[dwell].duration_s < t[i])
        ++dwell;
      Dwell& d = report.dwells[dwell];
      ++d.measured_rows;
      dwell_sum[dwell] += e.norm();
      d.max_distance_m = std::max(d.max_distance_m, e.norm());
      if (t[i] >= d.start_s + kDwellSettleS - 1e-9) {
        ++d.settled_rows;
        settled_sum[dwell] += e.norm();
        d.settled_max_distance_m = std::max(d.settled_max_distance_m, e.norm());
      }
    }
  }
  for (std::size_t d = 0; d < report.dwells.size(); ++d) {
    if (report.dwells[d].measured_rows > 0) {
      report.dwells[d].mean_distance_m = dwell_sum[d] / static_cast<double>(report.dwells[d].measured_rows);
    }
    if (report.dwells[d].settled_rows > 0) {
      report.dwells[d].settled_mean_distance_m = settled_sum[d] / static_cast<double>(report.dwells[d].settled_rows);
    }
  }
  report.plate_rows = plate_sum[kAllRows].rows;
  report.plate_measured = report.plate_rows > 0;
  if (plate_known && !report.plate_measured) {
    report.plate_source = "not measured: " + plate->source + " covers none of the run's rows with the drives on";
  }
  for (int s = 0; s < kRunSegments; ++s) {
    const Accumulator& p = plate_sum[s];
    report.plate[s].rows = p.rows;
    report.plate[s].rms_m = p.rms();
    report.plate[s].max_abs_m = p.max_abs;
    report.plate[s].rms_distance_m = p.rows ? std::sqrt(p.sum_sq_distance / static_cast<double>(p.rows)) : 0.0;
    report.plate[s].max_distance_m = p.max_distance;
    report.plate[s].max_at_s = p.max_at;
    report.joints[s].rows = joint_sum[s].rows;
    report.joints[s].rms_deg = joint_sum[s].rms();
    report.joints[s].max_abs_deg = joint_sum[s].max_abs;
  }
  return report;
}

RunReport run_report_of_file(const std::string& path) {
  const RunColumns run = read_run_columns(path);
  if (run.plate_m.empty()) return make_run_report(run, nullptr);
  const PlateTrack plate = plate_from_run(run);
  return make_run_report(run, &plate);
}

std::string plate_segments_text(const RunReport& r) {
  if (!r.plate_measured) return "";
  std::ostringstream out;
  Table plate({"plate - reference", "rows", "rms x / y / z [um]", "max |x| / |y| / |z| [um]", "rms [um]", "max [um]",
               "max at [s]"});
  for (int s = 0; s < kRunSegments; ++s) {
    const PlateFigures& p = r.plate[s];
    if (p.rows == 0) {
      plate.add_row({segment_name(s), "0", "-", "-", "-", "-", "-"});
      continue;
    }
    plate.add_row({segment_name(s), std::to_string(p.rows), triple(p.rms_m, 1e6, 2), triple(p.max_abs_m, 1e6, 2),
                   um(p.rms_distance_m), um(p.max_distance_m), fixed(p.max_at_s, 3)});
  }
  plate.print(out);
  out << '\n';
  return out.str();
}

std::string dwells_text(const RunReport& r) {
  if (r.dwells.empty()) return "";
  std::ostringstream out;
  const std::string settled = "after " + fixed(kDwellSettleS * 1e3, 0) + " ms";
  Table dwells({"dwell", "start [s]", "duration [s]", "reference x / y / z [mm]", "mean [um]", "max [um]",
                "mean " + settled + " [um]", "max " + settled + " [um]"});
  for (std::size_t d = 0; d < r.dwells.size(); ++d) {
    const Dwell& w = r.dwells[d];
    const bool measured = w.measured_rows > 0, settled_rows = w.settled_rows > 0;
    dwells.add_row({std::to_string(d + 1), fixed(w.start_s, 3), fixed(w.duration_s, 3),
                    r.has_reference_position ? triple(w.reference_m, 1e3, 3) : "-",
                    measured ? um(w.mean_distance_m) : "-", measured ? um(w.max_distance_m) : "-",
                    settled_rows ? um(w.settled_mean_distance_m) : "-",
                    settled_rows ? um(w.settled_max_distance_m) : "-"});
  }
  dwells.print(out);
  out << '\n';
  return out.str();
}

const Dwell* worst_dwell(const RunReport& r) {
  const Dwell* worst = nullptr;
  for (const Dwell& d : r.dwells) {
    if (d.settled_rows > 0 && (worst == nullptr || d.settled_mean_distance_m > worst->settled_mean_distance_m)) {
      worst = &d;
    }
  }
  return worst;
}

std::string report_text(const RunReport& r) {
  std::ostringstream out;
  out << "run-report: " << r.run << ", " << r.driven_rows << " of " << r.rows << " rows with the drives on, "
      << fixed(r.first_s, 3) << " .. " << fixed(r.last_s, 3) << " s of board time\n"
      << "plate: " << r.plate_source;
  if (r.plate_measured) out << ", " << r.plate_rows << " rows";
  out << '\n';
  if (!r.plate_note.empty()) out << "  " << r.plate_note << '\n';
  const std::size_t rest_rows = r.joints[kAtRest].rows, reversal_rows = r.joints[kReversals].rows;
  out << "segments of the reference (" << (r.has_reference_position ? "x/y/z_ref_m" : "the joint references")
      << "): " << r.joints[kMoving].rows << " rows moving, " << rest_rows << " at rest in " << r.dwells.size()
      << " dwells, " << reversal_rows << " through " << r.reversals.size() << " reversals\n\n";
  out << plate_segments_text(r) << dwells_text(r);
  Table joints({"joint reference - encoder", "rows", "rms 1 / 2 / 3 [deg]", "max |1| / |2| / |3| [deg]"});
  for (int s = 0; s < kRunSegments; ++s) {
    const JointFigures& j = r.joints[s];
    if (j.rows == 0) {
      joints.add_row({segment_name(s), "0", "-", "-"});
      continue;
    }
    joints.add_row({segment_name(s), std::to_string(j.rows), triple(j.rms_deg, 1.0, 4), triple(j.max_abs_deg, 1.0, 4)});
  }
  joints.print(out);
  out << "\nat rest: a dwell, at least " << fixed(kDwellMinS, 1) << " s with the reference within "
      << (r.has_reference_position ? um(kDwellBandM, 0) + " um" : fixed(kDwellBandDeg, 3) + " deg")
      << " of where it started; reversals: from " << fixed(kReversalBeforeS * 1e3, 0) << " ms before to "
      << fixed(kReversalAfterS * 1e3, 0)
      << " ms after the last row at an extreme of any axis's or joint's reference (turning back by more than "
      << um(kReversalHysteresisM, 0) << " um or " << fixed(kReversalHysteresisDeg, 3)
      << " deg), rows at rest excepted; moving: the rest\n";
  return out.str();
}

nlohmann::json report_json(const RunReport& r) {
  nlohmann::json j;
  j["run"] = r.run;
  j["rows"] = r.rows;
  j["driven_rows"] = r.driven_rows;
  j["first_s"] = r.first_s;
  j["last_s"] = r.last_s;
  j["plate_measured"] = r.plate_measured;
  j["plate_source"] = r.plate_source;
  if (!r.plate_note.empty()) j["plate_note"] = r.plate_note;
  j["plate_rows"] = r.plate_rows;
  j["segments_from"] = r.has_reference_position ? "reference position" : "joint references";
  nlohmann::json plate = nlohmann::json::object(), joints = nlohmann::json::object();
  const char* keys[kRunSegments] = {"all", "moving", "at_rest", "reversals"};
  for (int s = 0; s < kRunSegments; ++s) {
    const PlateFigures& p = r.plate[s];
    if (r.plate_measured) {
      plate[keys[s]] = {{"rows", p.rows},
                        {"rms_um", vec(p.rms_m, 1e6)},
                        {"max_abs_um", vec(p.max_abs_m, 1e6)},
                        {"rms_distance_um", p.rms_distance_m * 1e6},
                        {"max_distance_um", p.max_distance_m * 1e6},
                        {"max_at_s", p.max_at_s}};
    }
    const JointFigures& q = r.joints[s];
    joints[keys[s]] = {{"rows", q.rows}, {"rms_deg", vec(q.rms_deg, 1.0)}, {"max_abs_deg", vec(q.max_abs_deg, 1.0)}};
  }
  j["plate"] = r.plate_measured ? plate : nlohmann::json(nullptr);
  j["joint_tracking"] = joints;
  nlohmann::json dwells = nlohmann::json::array();
  for (const Dwell& d : r.dwells) {
    nlohmann::json w = {{"start_s", d.start_s}, {"duration_s", d.duration_s}, {"rows", d.rows}};
    if (r.has_reference_position) w["reference_mm"] = vec(d.reference_m, 1e3);
    if (d.measured_rows > 0) {
      w["mean_um"] = d.mean_distance_m * 1e6;
      w["max_um"] = d.max_distance_m * 1e6;
    } else {
      w["mean_um"] = nullptr;
      w["max_um"] = nullptr;
    }
    w["settled_rows"] = d.settled_rows;
    w["settled_mean_um"] = d.settled_rows > 0 ? nlohmann::json(d.settled_mean_distance_m * 1e6) : nlohmann::json();
    w["settled_max_um"] = d.settled_rows > 0 ? nlohmann::json(d.settled_max_distance_m * 1e6) : nlohmann::json();
    dwells.push_back(w);
  }
  j["dwells"] = dwells;
  nlohmann::json reversals = nlohmann::json::array();
  for (const Reversal& v : r.reversals) reversals.push_back({{"t_s", v.t_s}, {"signal", v.signal}});
  j["reversals"] = reversals;
  j["definitions"] = {
      {"plate_error", "plate - reference (x_m,y_m,z_m - x_ref_m,y_ref_m,z_ref_m) at each row's board time"},
      {"joint_tracking", "alpha*_ref_deg - alpha*_deg"},
      {"rows", "the run's rows with the drives on"},
      {"at_rest", "a dwell: at least " + format_number(kDwellMinS) + " s with the reference within " +
                      format_number(kDwellBandM * 1e6) + " um (joints " + format_number(kDwellBandDeg) +
                      " deg) of where it started; settled_*: from " + format_number(kDwellSettleS * 1e3) +
                      " ms after its start"},
      {"reversals", "from " + format_number(kReversalBeforeS * 1e3) + " ms before to " +
                        format_number(kReversalAfterS * 1e3) +
                        " ms after the last row at an extreme of any axis's or joint's reference (turning back by more "
                        "than " +
                        format_number(kReversalHysteresisM * 1e6) + " um or " + format_number(kReversalHysteresisDeg) +
                        " deg), rows at rest excepted"},
      {"moving", "every other row"}};
  return j;
}

std::string report_headline(const RunReport& r) {
  const JointFigures& j = r.joints[kAllRows];
  std::string line = "joint tracking (reference - encoder, " + std::to_string(j.rows) +
                     " rows with the drives on): rms " + triple(j.rms_deg, 1.0, 4) + " deg, max " +
                     triple(j.max_abs_deg, 1.0, 4) + " deg\n";
  if (!r.plate_measured) return line + "plate: " + r.plate_source + "\n";
  const PlateFigures& p = r.plate[kAllRows];
  line += "plate - reference: rms " + um(p.rms_distance_m) + " um (x / y / z " + triple(p.rms_m, 1e6, 2) + "), max " +
          um(p.max_distance_m) + " um";
  if (r.plate[kAtRest].rows > 0) line += "; at rest rms " + um(r.plate[kAtRest].rms_distance_m) + " um";
  if (r.plate[kReversals].rows > 0) line += "; reversals rms " + um(r.plate[kReversals].rms_distance_m) + " um";
  line += "\n";
  if (const Dwell* worst = worst_dwell(r)) {
    double largest = 0.0;
    for (const Dwell& d : r.dwells) largest = std::max(largest, d.settled_max_distance_m);
    line += "where it rests (" + std::to_string(r.dwells.size()) + " dwells, from " + fixed(kDwellSettleS * 1e3, 0) +
            " ms after each stop): worst mean " + um(worst->settled_mean_distance_m) + " um (the dwell at " +
            fixed(worst->start_s, 3) + " s), max " + um(largest) + " um\n";
  }
  return line;
}

}  // namespace delta
