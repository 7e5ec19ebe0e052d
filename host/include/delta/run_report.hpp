// A run's accuracy (deltactl run-report, the headline of `host run`, the dashboard's report of a
// recording): the plate against its reference and the joints against theirs, split by what the
// reference does (moving, at rest in a dwell, through a reversal).
//
// Rows: the run's rows with the drives on (column drives_enabled; a recording without it: every
// row). Errors at each row's board time t_s:
//   plate error = plate - reference (x_m,y_m,z_m against x_ref_m,y_ref_m,z_ref_m, metres; the plate
//     in the frame of whatever measured it: the stage's, the frame the model was trained in);
//   joint tracking = joint reference - encoder (alpha*_ref_deg - alpha*_deg, degrees).
// The plate comes from the run's own columns (a merged recording, `deltactl merge`), from the
// virtual board's truth (board time, linear between its 1 kHz rows) or from the stage's log aligned
// to board time by the merge (diagnosis/merge.hpp); a run without any of them reports the joints
// only and says the plate is not measured.
// The reference's segments (from x_ref_m.. when present, else the joint references):
//   at rest: a dwell, a stretch of at least kDwellMinS during which the reference stays within
//     kDwellBandM (joints: kDwellBandDeg) of where it was at the stretch's start; each dwell's
//     plate error also from kDwellSettleS after its start (settled: where a part is set down);
//   through a reversal: within [-kReversalBeforeS, +kReversalAfterS] of a reversal of any axis's
//     or any joint's reference: the last row at its extreme (a peak, or the end of a dwell there)
//     before it moves back by more than kReversalHysteresisM (joints: kReversalHysteresisDeg);
//     rows at rest are not counted here;
//   moving: every other row.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "delta/geometry.hpp"

namespace delta {

constexpr double kDwellMinS = 0.1;
constexpr double kDwellSettleS = 0.05;  // a dwell's settled figures: from this long after its start
constexpr double kDwellBandM = 1e-6;
constexpr double kDwellBandDeg = 1e-3;
constexpr double kReversalBeforeS = 0.02;
constexpr double kReversalAfterS = 0.1;
constexpr double kReversalHysteresisM = 5e-6;
constexpr double kReversalHysteresisDeg = 5e-3;

// The columns of a run (`host run`'s recording, or `merge`'s DATA.csv of one).
struct RunColumns {
  std::string path;
  std::vector<double> t_s;
  std::vector<std::size_t> line;  // file line of each row
  std::vector<Vec3> alpha_deg, alpha_ref_deg;
  std::vector<bool> driven;  // drives on (every row when the file has no drives_enabled)
  bool has_drives_column = false;
  std::vector<Vec3> reference_m;  // empty: no x_ref_m,y_ref_m,z_ref_m
  std::vector<Vec3> plate_m;      // empty: no x_m,y_m,z_m
};

// Reads RUN.csv: t_s, alpha1..3_deg and alpha1..3_ref_deg required; x_ref_m.., x_m..,
// drives_enabled optional; a co-simulation's recording (`cosim --out`: net1..3_deg, ref_x_m..)
// is read the same. InputError (file, line, reason) for csv.hpp's reasons, time going
// backwards, an angle beyond 360 deg or a position beyond 1 m.
RunColumns read_run_columns(const std::string& path);

// The plate at each of the run's rows, from one source.
struct PlateTrack {
  std::string source;          // e.g. "the run's x_m,y_m,z_m", "truth truth.csv"
  std::vector<bool> measured;  // per run row
  std::vector<Vec3> plate_m;   // per run row (valid where measured)
  std::string note;            // one line on how it was aligned ("" when nothing to say)
};

PlateTrack plate_from_run(const RunColumns& run);
// TRUTH.csv (`virtual-board --truth`: t_s board time, x_m,y_m,z_m) linear between its rows at
// each run row's time; a run row more than 10 ms from a truth row on either side is not measured.
// InputError for csv.hpp's reasons or time going backwards.
PlateTrack plate_from_truth(const RunColumns& run, const std::string& truth_path);

struct PlateFigures {
  std::size_t rows = 0;
  Vec3 rms_m = Vec3::Zero(), max_abs_m = Vec3::Zero();  // per axis
  double rms_distance_m = 0.0, max_distance_m = 0.0, max_at_s = 0.0;
};

struct JointFigures {
  std::size_t rows = 0;
  Vec3 rms_deg = Vec3::Zero(), max_abs_deg = Vec3::Zero();
};

struct Dwell {
  double start_s = 0.0, duration_s = 0.0;
  std::size_t rows = 0, measured_rows = 0;
  Vec3 reference_m = Vec3::Zero();                     // where it rests (x_ref_m..; zero when the run has none)
  double mean_distance_m = 0.0, max_distance_m = 0.0;  // of the plate error (measured rows)
  // The same from kDwellSettleS after the start on (where the part is set down, the arms settled).
  std::size_t settled_rows = 0;
  double settled_mean_distance_m = 0.0, settled_max_distance_m = 0.0;
};

struct Reversal {
  double t_s = 0.0;
  std::string signal;  // x, y, z, alpha1, alpha2, alpha3
};

enum RunSegment : int { kAllRows = 0, kMoving = 1, kAtRest = 2, kReversals = 3 };
constexpr int kRunSegments = 4;
const char* segment_name(int segment);  // "all", "moving", "at rest", "reversals"

struct RunReport {
  std::string run;
  std::size_t rows = 0, driven_rows = 0;
  double first_s = 0.0, last_s = 0.0;  // of the driven rows
  bool has_reference_position = false;
  bool plate_measured = false;
  std::string plate_source;  // where the plate came from, or why it is not measured
  std::string plate_note;
  std::size_t plate_rows = 0;  // driven rows with a plate
  PlateFigures plate[kRunSegments];
  JointFigures joints[kRunSegments];
  std::vector<Dwell> dwells;
  std::vector<Reversal> reversals;
};

// `plate`: nullptr (the joints only) or a track of the run's rows. InputError (the run's file) when
// no row has the drives on.
RunReport make_run_report(const RunColumns& run, const PlateTrack* plate);
// RUN.csv with the plate from its own columns when it has them (the dashboard, `host run`).
RunReport run_report_of_file(const std::string& path);

// The tables (stdout of run-report), the JSON (run-report --json, the dashboard) and one or two
// lines (host run's summary, the dashboard's list).
std::string report_text(const RunReport& report);
nlohmann::json report_json(const RunReport& report);
std::string report_headline(const RunReport& report);
// Pieces of report_text: the plate's table by segment, and the dwells' table ("" without dwells).
std::string plate_segments_text(const RunReport& report);
std::string dwells_text(const RunReport& report);
// The dwell with the largest settled mean plate error (nullptr: no dwell has a settled row).
const Dwell* worst_dwell(const RunReport& report);

}  // namespace delta
