// deltactl plot's picture of a recording (see recording_plot.hpp): columns to panels, PNG via gnuplot.
#include "delta/recording_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <set>

#include "delta/board_facts.hpp"
#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/input_file.hpp"
#include "delta/link/payloads.hpp"
#include "delta/link/session.hpp"
#include "delta/output_file.hpp"
#include "delta/plot.hpp"
#include "delta/plot_marks.hpp"

namespace delta {
namespace {

// The header's column names (the first line that is not a comment), or none when the file cannot
// be read (read_csv then says why).
std::vector<std::string> header_of(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> names;
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      std::string name = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      const auto first = name.find_first_not_of(" \t");
      const auto last = name.find_last_not_of(" \t");
      names.push_back(first == std::string::npos ? "" : name.substr(first, last - first + 1));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    return names;
  }
  return {};
}

// The recording's own account of its end, when it has one: the trailer `host run` and `host
// record` write, "# outcome: OUTCOME at board time T s (exit CODE)[: why]". Read from the file's
// last 64 KiB (the trailer is its last line).
struct Outcome {
  std::string name;  // completed, stopped, e-stop, fault, link lost, drives off, ...
  double t_s = 0.0;
  int exit = 0;
  bool normal() const { return (name == "completed" || name == "stopped") && (exit == 0 || exit >= 128); }
};

std::optional<Outcome> outcome_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return std::nullopt;
  const std::streamoff size = in.tellg();
  const std::streamoff from = std::max<std::streamoff>(0, size - (64 << 10));
  in.seekg(from);
  std::string tail(static_cast<std::size_t>(size - from), '\0');
  in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  const std::string key = "# outcome: ";
  const std::size_t at = tail.rfind("\n" + key);
  if (at == std::string::npos && tail.rfind(key, 0) != 0) return std::nullopt;
  const std::size_t begin = at == std::string::npos ? key.size() : at + 1 + key.size();
  const std::string line = tail.substr(begin, tail.find('\n', begin) - begin);
  const std::size_t time = line.find(" at board time ");
  if (time == std::string::npos) return std::nullopt;
  Outcome outcome;
  outcome.name = line.substr(0, time);
  const std::string rest = line.substr(time + 15);
  const std::size_t unit = rest.find(" s");
  const std::optional<double> t = parse_decimal(rest.substr(0, unit));
  if (unit == std::string::npos || !t || !std::isfinite(*t)) return std::nullopt;
  outcome.t_s = *t;
  const std::size_t code = rest.find("(exit ", unit);
  if (code != std::string::npos) outcome.exit = std::atoi(rest.c_str() + code + 6);
  return outcome;
}

struct Columns {
  const CsvTable& table;
  std::map<std::string, std::size_t> index;
  explicit Columns(const CsvTable& t) : table(t) {
    for (std::size_t k = 0; k < t.columns.size(); ++k) {
      if (t.present[k]) index[t.columns[k]] = k;
    }
  }
  bool has(const std::string& name) const { return index.count(name) != 0; }
  // The first of `names` present.
  std::optional<std::string> first(std::initializer_list<std::string> names) const {
    for (const std::string& name : names) {
      if (has(name)) return name;
    }
    return std::nullopt;
  }
  double at(std::size_t row, const std::string& name) const { return table.rows[row][index.at(name)]; }
};

// At most about 2 * kBuckets points: the minimum and the maximum of each bucket, in time order, so
// a spike survives the thinning of a long 1 kHz recording.
constexpr std::size_t kBuckets = 1500;

PlotSeries series_of(const std::string& label, const std::vector<double>& t, const std::vector<double>& y) {
  PlotSeries s{label, {}, {}, false};
  const std::size_t n = std::min(t.size(), y.size());
  const std::size_t bucket = n > 2 * kBuckets ? (n + kBuckets - 1) / kBuckets : 1;
  for (std::size_t begin = 0; begin < n; begin += bucket) {
    const std::size_t end = std::min(n, begin + bucket);
    if (bucket == 1) {
      s.x.push_back(t[begin]);
      s.y.push_back(y[begin]);
      continue;
    }
    const auto [low, high] = std::minmax_element(y.begin() + static_cast<std::ptrdiff_t>(begin),
                                                 y.begin() + static_cast<std::ptrdiff_t>(end));
    const auto a = std::min(low, high), b = std::max(low, high);
    s.x.push_back(t[static_cast<std::size_t>(a - y.begin())]);
    s.y.push_back(*a);
    if (b != a) {
      s.x.push_back(t[static_cast<std::size_t>(b - y.begin())]);
      s.y.push_back(*b);
    }
  }
  return s;
}

// Spans of rows where `on(row)` holds, as [t_first, t_last] (a single row: a short band).
void add_spans(std::vector<PlotSpan>& spans, const std::vector<double>& t, const std::function<bool(std::size_t)>& on,
               const std::string& label, const std::string& colour) {
  const double tick = t.size() > 1 ? std::max((t.back() - t.front()) / 500.0, 1e-4) : 1e-3;
  std::optional<std::size_t> start;
  for (std::size_t i = 0; i <= t.size(); ++i) {
    const bool active = i < t.size() && on(i);
    if (active && !start) start = i;
    if (!active && start) {
      const double from = t[*start], to = std::max(t[i - 1], from + tick);
      if (!spans.empty() && spans.back().label == label && from - spans.back().to < tick) {
        spans.back().to = to;  // flicker: one band
      } else {
        spans.push_back({from, to, label, colour});
      }
      start.reset();
    }
  }
}

const std::set<std::string>& not_plotted() {
  // Indices, counters and bit fields: marks on the time axis, or nothing a curve would show.
  static const std::set<std::string> names = {
      "t_s",         "sample_index", "stream_sample",    "fill",      "tau_s",          "bad_frames",   "rejected",
      "slew_limits", "flags",        "fault_bits",       "underruns", "drives_enabled", "saturations",  "fault",
      "holding",     "tick",         "board_fault_bits", "estop",     "estop_open",     "drive_fault1", "drive_fault2",
      "drive_fault3"};
  return names;
}

// The joints' colours, alpha1 to alpha3 (and x, y, z on the plate panels).
const std::string& joint_style(int k) {
  static const std::string styles[3] = {"linecolor rgb '#1f77b4'", "linecolor rgb '#d62728'",
                                        "linecolor rgb '#2ca02c'"};
  return styles[k];
}

// The recording's table: t_s required, every other column of its header optional.
CsvTable read_recording(const std::string& csv_path) {
  check_input_file(csv_path);  // header_of opens it first: a FIFO would block there
  std::vector<std::string> header = header_of(csv_path);
  std::vector<std::string> optional;
  std::set<std::string> seen;
  for (const std::string& name : header) {
    if (name != "t_s" && !name.empty() && seen.insert(name).second) optional.push_back(name);
  }
  return read_csv(csv_path, {"t_s"}, optional);
}

// The board times of the rows, refused where they go backwards.
std::vector<double> board_times(const std::string& csv_path, const Columns& c) {
  const std::size_t n = c.table.rows.size();
  std::vector<double> t(n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = c.at(i, "t_s");
    if (i > 0 && t[i] < t[i - 1]) {
      throw InputError(csv_path, c.table.line_numbers[i],
                       "t_s goes backwards (" + format_number(t[i]) + " after " + format_number(t[i - 1]) + ")");
    }
  }
  return t;
}

// What the pieces of a recording's picture share: its columns and board times, the series'
// styles and right axes as the panels choose them, the columns a panel shows, and what was found
// (the recording's kind is told from it).
struct PlotBuilder {
  const Columns& c;
  const std::vector<double>& t;
  const std::size_t n;
  std::string drives;   // the drives_enabled column, or ""
  bool driven = false;  // drives on at some row (or no drives_enabled column)
  RecordingPlot& out;
  std::map<std::string, std::string> style_of;  // by series label (unique in a recording's plot)
  std::set<std::string> on_right;               // series on their panel's right axis
  std::set<std::string> used;                   // columns shown on the named panels
  bool any_reference = false, any_encoder = false, any_true = false, measured = false;

  PlotBuilder(const Columns& columns, const std::vector<double>& times, RecordingPlot& plot)
      : c(columns), t(times), n(times.size()), out(plot) {
    // With the drives off throughout (a drag calibration, host record) the board's references and
    // the currents say nothing: no tracking against the reference, no current panel.
    drives = c.first({"drives_enabled"}).value_or("");
    driven = drives.empty();
    for (std::size_t i = 0; i < n && !driven; ++i) driven = c.at(i, drives) != 0.0;
  }

  std::vector<double> column(const std::string& name) const {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = c.at(i, name);
    return v;
  }

  // The first of `patterns` present, '#' replaced by the joint's number.
  std::optional<std::string> joint_column(int j, std::initializer_list<std::string> patterns) const {
    for (std::string pattern : patterns) {
      pattern.replace(pattern.find('#'), 1, std::to_string(j));
      if (c.has(pattern)) return pattern;
    }
    return std::nullopt;
  }

  PlotSeries styled(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                    const std::string& style = "") {
    style_of[label] = style;
    return series_of(label, x, y);
  }

  // A span of marks on the time axis where `on(row)` holds.
  void mark(const std::function<bool(std::size_t)>& on, const std::string& label, const std::string& colour) {
    add_spans(out.marks.spans, t, on, label, colour);
  }
};

// The joint angles (references, encoders, true angles) and the tracking error of each encoder
// against its reference while driven, or else against the true angle.
void add_joint_panels(PlotBuilder& b) {
  PlotPanel joints{"Joint angles", "board time t [s]", "angle [deg]", {}, false};
  PlotPanel tracking{"Tracking error", "board time t [s]", "error [deg]", {}, false};
  for (int j = 1; j <= 3; ++j) {
    const auto reference = b.joint_column(j, {"alpha#_ref_deg", "net#_deg"});
    const auto encoder = b.joint_column(j, {"alpha#_deg", "encoder#_deg"});
    const auto truth = b.joint_column(j, {"true_alpha#_deg", "true#_deg"});
    const std::string& style = joint_style(j - 1);
    const std::string name = "alpha" + std::to_string(j);
    if (reference) {
      joints.series.push_back(
          b.styled(name + " reference (" + *reference + ")", b.t, b.column(*reference), style + " dashtype 2"));
      b.used.insert(*reference);
      b.any_reference = true;
    }
    if (encoder) {
      joints.series.push_back(b.styled(name + " encoder (" + *encoder + ")", b.t, b.column(*encoder), style));
      b.used.insert(*encoder);
      b.any_encoder = true;
    }
    if (truth) {
      joints.series.push_back(b.styled(name + " true (" + *truth + ")", b.t, b.column(*truth), style + " dashtype 3"));
      b.used.insert(*truth);
      b.any_true = true;
    }
    const auto against = reference && b.driven ? reference : truth;
    if (encoder && against) {
      const std::vector<double> e = b.column(*encoder), r = b.column(*against);
      std::vector<double> error(b.n);
      for (std::size_t i = 0; i < b.n; ++i) error[i] = e[i] - r[i];
      tracking.series.push_back(b.styled(*encoder + " - " + *against, b.t, error, style));
    }
  }
  PlotSpec& spec = b.out.spec;
  if (!joints.series.empty()) spec.panels.push_back(joints);
  if (!tracking.series.empty()) {
    if (!b.any_reference || !b.driven) tracking.title = "Encoder error (encoder - true angle)";
    spec.panels.push_back(tracking);
  }
}

// The drive currents, while the drives are on at some row (their columns count as shown either way).
void add_current_panel(PlotBuilder& b) {
  PlotPanel currents{"Drive currents", "board time t [s]", "current [A]", {}, false};
  for (int j = 1; j <= 3; ++j) {
    if (const auto name = b.joint_column(j, {"current#_a"})) {
      if (b.driven) currents.series.push_back(b.styled(*name, b.t, b.column(*name), joint_style(j - 1)));
      b.used.insert(*name);
    }
  }
  if (!currents.series.empty()) b.out.spec.panels.push_back(currents);
}

// The plate's position and reference (mm), and measured - reference (um).
void add_plate_panels(PlotBuilder& b) {
  const char* axis[3] = {"x", "y", "z"};
  // z (about -70 mm) on its own axis at the right: on one scale with x and y (+-12 mm) it would
  // flatten them.
  PlotPanel plate{"Plate position", "board time t [s]", "x, y [mm]", {}, false};
  PlotPanel plate_error{"Plate error (measured - reference)", "board time t [s]", "x, y error [um]", {}, false};
  bool referenced = false;
  const std::size_t n = b.n;
  for (int k = 0; k < 3; ++k) {
    const std::string a = axis[k];
    const std::string right = k == 2 ? " (right axis)" : "";
    const auto position = b.c.first({a + "_m"});
    const auto reference = b.c.first({a + "_ref_m", "ref_" + a + "_m"});
    std::vector<double> p, r;
    if (position) {
      p = b.column(*position);
      std::vector<double> mm(n);
      for (std::size_t i = 0; i < n; ++i) mm[i] = p[i] * 1e3;
      plate.series.push_back(b.styled(*position + right, b.t, mm, joint_style(k)));
      if (k == 2) b.on_right.insert(plate.series.back().label);
      b.used.insert(*position);
      b.measured = true;
    }
    if (reference) {
      r = b.column(*reference);
      std::vector<double> mm(n);
      for (std::size_t i = 0; i < n; ++i) mm[i] = r[i] * 1e3;
      plate.series.push_back(b.styled(*reference + right, b.t, mm, joint_style(k) + " dashtype 2"));
      if (k == 2) b.on_right.insert(plate.series.back().label);
      b.used.insert(*reference);
      referenced = true;
    }
    if (position && reference) {
      std::vector<double> um(n);
      for (std::size_t i = 0; i < n; ++i) um[i] = (p[i] - r[i]) * 1e6;
      plate_error.series.push_back(b.styled(*position + " - " + *reference + right, b.t, um, joint_style(k)));
      if (k == 2) b.on_right.insert(plate_error.series.back().label);
    }
  }
  if (!plate.series.empty()) {
    plate.title = b.measured && referenced ? "Plate position against its reference"
                  : referenced             ? "Plate reference (sent to the board)"
                                           : "Plate position (measured)";
    b.out.spec.panels.push_back(plate);
  }
  if (!plate_error.series.empty()) b.out.spec.panels.push_back(plate_error);
}

// Up to 8 numeric columns no other panel shows and that are no counter, index or bit field.
void add_other_panel(PlotBuilder& b) {
  const CsvTable& table = b.c.table;
  PlotPanel other{"Other columns", "board time t [s]", "value", {}, false};
  for (std::size_t k = 0; k < table.columns.size(); ++k) {
    const std::string& name = table.columns[k];
    if (!table.present[k] || b.used.count(name) || not_plotted().count(name)) continue;
    if (other.series.size() == 8) break;
    other.series.push_back(b.styled(name, b.t, b.column(name)));
  }
  if (!other.series.empty()) b.out.spec.panels.push_back(other);
}

// The fault band's label: it names the causes latched where it starts (link::describe_fault: the
// board's own, an e-stop command, an e-stop input, a drive's fault, and the joints').
std::string fault_label_of(const PlotBuilder& b) {
  const std::vector<double> zeros(b.n, 0.0);
  const auto column_or_zero = [&](const char* name) { return b.c.has(name) ? b.column(name) : zeros; };
  const std::vector<double> joint_causes = column_or_zero("fault_bits"),
                            board_causes = column_or_zero("board_fault_bits"), estops = column_or_zero("estop");
  std::string fault_label = "fault";
  for (std::size_t i = 0; i < b.n; ++i) {
    if (joint_causes[i] == 0.0 && board_causes[i] == 0.0 && estops[i] == 0.0) continue;
    link::TelemetryPayload causes;
    causes.fault_cause = static_cast<std::uint8_t>(joint_causes[i]);
    causes.board_fault = static_cast<std::uint8_t>(board_causes[i]);
    causes.estop = estops[i] != 0.0;
    fault_label = "fault: " + link::describe_fault(causes);
    break;
  }
  return fault_label;
}

// Bands of drives off, feed holds and faults, from the drives, flags, holding and fault columns
// and a virtual board's safety inputs.
void add_state_marks(PlotBuilder& b) {
  const std::size_t n = b.n;
  if (!b.drives.empty()) {
    const std::vector<double> d = b.column(b.drives);
    b.mark([&](std::size_t i) { return d[i] == 0.0; }, "drives off", "#808080");
  }
  const std::string fault_label = fault_label_of(b);
  if (b.c.has("flags")) {
    const std::vector<double> f = b.column("flags");
    // A run's recording holds before its stream plays (the primed start) and after it ends (the
    // stop before the disable): those frames are not the stream's (stream_sample -1). A feed hold
    // is a hold while the stream is under way.
    const std::vector<double> stream =
        b.c.has("stream_sample") ? b.column("stream_sample") : std::vector<double>(n, 0.0);
    b.mark(
        [&](std::size_t i) {
          return (static_cast<long long>(f[i]) & (1LL << board::kFlagHolding)) != 0 && stream[i] >= 0.0;
        },
        "feed hold", "#1f77b4");
    b.mark([&](std::size_t i) { return (static_cast<long long>(f[i]) & (1LL << board::kFlagFault)) != 0; }, fault_label,
           "#d62728");
  }
  if (b.c.has("holding")) {
    const std::vector<double> h = b.column("holding");
    b.mark([&](std::size_t i) { return h[i] != 0.0; }, "feed hold", "#1f77b4");
  }
  for (const std::string fault : {"fault_bits", "fault", "board_fault_bits", "estop"}) {
    if (!b.c.has(fault)) continue;
    const std::vector<double> f = b.column(fault);
    b.mark([&](std::size_t i) { return f[i] != 0.0; }, fault_label, "#d62728");
  }
  // A virtual board's truth: its safety inputs at the stop level, each named as the cause it latches.
  const char* const inputs[] = {"estop_open", "drive_fault1", "drive_fault2", "drive_fault3"};
  for (int k = 0; k < 4; ++k) {
    if (!b.c.has(inputs[k])) continue;
    link::TelemetryPayload cause;
    cause.board_fault = static_cast<std::uint8_t>(1 << k);  // BoardFault: the e-stop input, then drives 1-3
    const std::vector<double> f = b.column(inputs[k]);
    b.mark([&](std::size_t i) { return f[i] != 0.0; }, link::describe_fault(cause), "#9c27b0");
  }
}

// Bands where the underruns counter goes up while the drives are on (the counter also counts
// before a stream starts).
void add_underrun_marks(PlotBuilder& b) {
  if (!b.c.has("underruns")) return;
  const std::size_t n = b.n;
  const std::vector<double> u = b.column("underruns");
  const std::vector<double> on = b.drives.empty() ? std::vector<double>(n, 1.0) : b.column(b.drives);
  // A run's: while its stream had samples left to play (once its last sample has played the
  // buffer runs empty until the final hold; that is no underrun of the stream).
  std::vector<double> stream(n, 0.0);
  double last_sample = 1.0;
  if (b.c.has("stream_sample")) {
    stream = b.column("stream_sample");
    last_sample = *std::max_element(stream.begin(), stream.end());
  }
  b.mark(
      [&](std::size_t i) {
        return i > 0 && u[i] > u[i - 1] && on[i] != 0.0 && stream[i] >= 0.0 && stream[i] < last_sample;
      },
      "underrun", "#ff7f0e");
}

// An end that was not a normal one (e-stop, fault, link lost): a band from then to the
// recording's end. Returns what the title says of it ("" for a normal end or none recorded).
std::string mark_ending(PlotBuilder& b, const std::string& csv_path) {
  const std::optional<Outcome> outcome = outcome_of(csv_path);
  std::string ending;
  const std::vector<double>& t = b.t;
  if (outcome && !outcome->normal() && b.n > 0) {
    const double tick = std::max((t.back() - t.front()) / 500.0, 1e-3);
    const double from = std::clamp(outcome->t_s, t.front(), t.back());
    b.out.marks.spans.push_back({from, std::max(t.back(), from + tick), "end: " + outcome->name, "#d62728"});
    ending = ", ended by " + outcome->name + " at " + format_number(std::round(outcome->t_s * 1e3) / 1e3) + " s";
  }
  return ending;
}

// The recording's kind, from the columns.
std::string kind_of(const PlotBuilder& b) {
  if (b.any_reference && b.c.has("x_ref_m")) return "host run recording";
  if (b.any_true && b.c.has("drives_enabled") && !b.any_reference) return "virtual-board truth";
  if (b.c.has("net1_deg") || b.c.has("ref_x_m")) return "co-simulation samples";
  if (b.any_encoder && b.measured) return "recording (simulate, merge)";
  if (b.any_encoder) return "telemetry recording (host record)";
  return "recording";
}

// The title (file name, kind, rows, span, ending), the panel list, and each series' style and axis.
void finish_spec(PlotBuilder& b, const std::string& csv_path, const std::string& ending) {
  RecordingPlot& out = b.out;
  PlotSpec& spec = out.spec;
  PlotMarks& marks = out.marks;
  std::string name = csv_path;
  if (const auto slash = name.rfind('/'); slash != std::string::npos) name = name.substr(slash + 1);
  const double span_s = b.n > 0 ? b.t.back() - b.t.front() : 0.0;
  spec.title = name + ": " + out.kind + ", " + std::to_string(b.n) + " rows, " +
               format_number(std::round(span_s * 1e3) / 1e3) + " s" + ending;
  spec.panel_height_px = 300;
  for (const PlotPanel& panel : spec.panels) out.panels.push_back(panel.title);
  for (const PlotPanel& panel : spec.panels) {
    marks.styles.emplace_back();
    marks.right_axis.emplace_back();
    for (const PlotSeries& series : panel.series) {
      marks.styles.back().push_back(b.style_of[series.label]);
      marks.right_axis.back().push_back(b.on_right.count(series.label) != 0);
    }
    marks.y2_labels.push_back(panel.title.rfind("Plate error", 0) == 0 ? "z error [um]"
                              : panel.title.rfind("Plate", 0) == 0     ? "z [mm]"
                                                                       : "");
  }
}

}  // namespace

RecordingPlot describe_recording(const std::string& csv_path) {
  const CsvTable table = read_recording(csv_path);
  const Columns c(table);
  const std::vector<double> t = board_times(csv_path, c);
  RecordingPlot out;
  out.rows = t.size();
  out.marks.as_written = true;
  PlotBuilder b(c, t, out);
  add_joint_panels(b);
  add_current_panel(b);
  add_plate_panels(b);
  add_other_panel(b);
  if (out.spec.panels.empty()) {
    throw InputError(csv_path, 1,
                     "no column to plot besides t_s (expected e.g. alpha1_deg, alpha1_ref_deg, current1_a, x_m, "
                     "x_ref_m)");
  }
  add_state_marks(b);
  add_underrun_marks(b);
  if (out.marks.spans.size() > 400) out.marks.spans.resize(400);  // gnuplot's objects: enough to see a pattern
  const std::string ending = mark_ending(b, csv_path);
  out.kind = kind_of(b);
  finish_spec(b, csv_path, ending);
  return out;
}

RecordingPlot plot_recording(const std::string& csv_path, const std::string& png_path) {
  RecordingPlot out = describe_recording(csv_path);
  write_plot(png_path, out.spec, out.marks);
  return out;
}

}  // namespace delta
