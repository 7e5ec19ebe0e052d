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

}  // namespace

RecordingPlot describe_recording(const std::string& csv_path) {
  check_input_file(csv_path);  // header_of opens it first: a FIFO would block there
  std::vector<std::string> header = header_of(csv_path);
  std::vector<std::string> optional;
  std::set<std::string> seen;
  for (const std::string& name : header) {
    if (name != "t_s" && !name.empty() && seen.insert(name).second) optional.push_back(name);
  }
  const CsvTable table = read_csv(csv_path, {"t_s"}, optional);
  const Columns c(table);
  const std::size_t n = table.rows.size();
  std::vector<double> t(n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = c.at(i, "t_s");
    if (i > 0 && t[i] < t[i - 1]) {
      throw InputError(csv_path, table.line_numbers[i],
                       "t_s goes backwards (" + format_number(t[i]) + " after " + format_number(t[i - 1]) + ")");
    }
  }
  auto column = [&](const std::string& name) {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = c.at(i, name);
    return v;
  };
  std::set<std::string> used;
  auto joint_column = [&](int j, std::initializer_list<std::string> patterns) -> std::optional<std::string> {
    for (std::string pattern : patterns) {
      pattern.replace(pattern.find('#'), 1, std::to_string(j));
      if (c.has(pattern)) return pattern;
    }
    return std::nullopt;
  };

  RecordingPlot out;
  out.rows = n;
  PlotSpec& spec = out.spec;
  PlotMarks& marks = out.marks;
  marks.as_written = true;
  // With the drives off throughout (a drag calibration, host record) the board's references and
  // the currents say nothing: no tracking against the reference, no current panel.
  const std::string drives = c.first({"drives_enabled"}).value_or("");
  bool driven = drives.empty();
  for (std::size_t i = 0; i < n && !driven; ++i) driven = c.at(i, drives) != 0.0;
  std::map<std::string, std::string> style_of;  // by series label (unique in a recording's plot)
  std::set<std::string> on_right;               // series on their panel's right axis
  auto styled = [&](const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                    const std::string& style = "") {
    style_of[label] = style;
    return series_of(label, x, y);
  };
  const std::string joint_style[3] = {"linecolor rgb '#1f77b4'", "linecolor rgb '#d62728'", "linecolor rgb '#2ca02c'"};

  // ---- joint angles ----
  PlotPanel joints{"Joint angles", "board time t [s]", "angle [deg]", {}, false};
  PlotPanel tracking{"Tracking error", "board time t [s]", "error [deg]", {}, false};
  bool any_reference = false, any_encoder = false, any_true = false;
  for (int j = 1; j <= 3; ++j) {
    const auto reference = joint_column(j, {"alpha#_ref_deg", "net#_deg"});
    const auto encoder = joint_column(j, {"alpha#_deg", "encoder#_deg"});
    const auto truth = joint_column(j, {"true_alpha#_deg", "true#_deg"});
    const std::string& style = joint_style[j - 1];
    const std::string name = "alpha" + std::to_string(j);
    if (reference) {
      joints.series.push_back(
          styled(name + " reference (" + *reference + ")", t, column(*reference), style + " dashtype 2"));
      used.insert(*reference);
      any_reference = true;
    }
    if (encoder) {
      joints.series.push_back(styled(name + " encoder (" + *encoder + ")", t, column(*encoder), style));
      used.insert(*encoder);
      any_encoder = true;
    }
    if (truth) {
      joints.series.push_back(styled(name + " true (" + *truth + ")", t, column(*truth), style + " dashtype 3"));
      used.insert(*truth);
      any_true = true;
    }
    const auto against = reference && driven ? reference : truth;
    if (encoder && against) {
      const std::vector<double> e = column(*encoder), r = column(*against);
      std::vector<double> error(n);
      for (std::size_t i = 0; i < n; ++i) error[i] = e[i] - r[i];
      tracking.series.push_back(styled(*encoder + " - " + *against, t, error, style));
    }
  }
  if (!joints.series.empty()) spec.panels.push_back(joints);
  if (!tracking.series.empty()) {
    if (!any_reference || !driven) tracking.title = "Encoder error (encoder - true angle)";
    spec.panels.push_back(tracking);
  }

  // ---- currents ----
  PlotPanel currents{"Drive currents", "board time t [s]", "current [A]", {}, false};
  for (int j = 1; j <= 3; ++j) {
    if (const auto name = joint_column(j, {"current#_a"})) {
      if (driven) currents.series.push_back(styled(*name, t, column(*name), joint_style[j - 1]));
      used.insert(*name);
    }
  }
  if (!currents.series.empty()) spec.panels.push_back(currents);

  // ---- the plate ----
  const char* axis[3] = {"x", "y", "z"};
  // z (about -70 mm) on its own axis at the right: on one scale with x and y (+-12 mm) it would
  // flatten them.
  PlotPanel plate{"Plate position", "board time t [s]", "x, y [mm]", {}, false};
  PlotPanel plate_error{"Plate error (measured - reference)", "board time t [s]", "x, y error [um]", {}, false};
  bool measured = false, referenced = false;
  for (int k = 0; k < 3; ++k) {
    const std::string a = axis[k];
    const std::string right = k == 2 ? " (right axis)" : "";
    const auto position = c.first({a + "_m"});
    const auto reference = c.first({a + "_ref_m", "ref_" + a + "_m"});
    std::vector<double> p, r;
    if (position) {
      p = column(*position);
      std::vector<double> mm(n);
      for (std::size_t i = 0; i < n; ++i) mm[i] = p[i] * 1e3;
      plate.series.push_back(styled(*position + right, t, mm, joint_style[k]));
      if (k == 2) on_right.insert(plate.series.back().label);
      used.insert(*position);
      measured = true;
    }
    if (reference) {
      r = column(*reference);
      std::vector<double> mm(n);
      for (std::size_t i = 0; i < n; ++i) mm[i] = r[i] * 1e3;
      plate.series.push_back(styled(*reference + right, t, mm, joint_style[k] + " dashtype 2"));
      if (k == 2) on_right.insert(plate.series.back().label);
      used.insert(*reference);
      referenced = true;
    }
    if (position && reference) {
      std::vector<double> um(n);
      for (std::size_t i = 0; i < n; ++i) um[i] = (p[i] - r[i]) * 1e6;
      plate_error.series.push_back(styled(*position + " - " + *reference + right, t, um, joint_style[k]));
      if (k == 2) on_right.insert(plate_error.series.back().label);
    }
  }
  if (!plate.series.empty()) {
    plate.title = measured && referenced ? "Plate position against its reference"
                  : referenced           ? "Plate reference (sent to the board)"
                                         : "Plate position (measured)";
    spec.panels.push_back(plate);
  }
  if (!plate_error.series.empty()) spec.panels.push_back(plate_error);

  // ---- anything else numeric ----
  PlotPanel other{"Other columns", "board time t [s]", "value", {}, false};
  for (std::size_t k = 0; k < table.columns.size(); ++k) {
    const std::string& name = table.columns[k];
    if (!table.present[k] || used.count(name) || not_plotted().count(name)) continue;
    if (other.series.size() == 8) break;
    other.series.push_back(styled(name, t, column(name)));
  }
  if (!other.series.empty()) spec.panels.push_back(other);

  if (spec.panels.empty()) {
    throw InputError(csv_path, 1,
                     "no column to plot besides t_s (expected e.g. alpha1_deg, alpha1_ref_deg, current1_a, x_m, "
                     "x_ref_m)");
  }

  // ---- marks on the time axis ----
  if (!drives.empty()) {
    const std::vector<double> d = column(drives);
    add_spans(
        marks.spans, t, [&](std::size_t i) { return d[i] == 0.0; }, "drives off", "#808080");
  }
  // The fault band names the causes latched where it starts (link::describe_fault: the board's
  // own, an e-stop command, an e-stop input, a drive's fault, and the joints').
  const std::vector<double> zeros(n, 0.0);
  const auto column_or_zero = [&](const char* name) { return c.has(name) ? column(name) : zeros; };
  const std::vector<double> joint_causes = column_or_zero("fault_bits"),
                            board_causes = column_or_zero("board_fault_bits"), estops = column_or_zero("estop");
  std::string fault_label = "fault";
  for (std::size_t i = 0; i < n; ++i) {
    if (joint_causes[i] == 0.0 && board_causes[i] == 0.0 && estops[i] == 0.0) continue;
    link::TelemetryPayload causes;
    causes.fault_cause = static_cast<std::uint8_t>(joint_causes[i]);
    causes.board_fault = static_cast<std::uint8_t>(board_causes[i]);
    causes.estop = estops[i] != 0.0;
    fault_label = "fault: " + link::describe_fault(causes);
    break;
  }
  if (c.has("flags")) {
    const std::vector<double> f = column("flags");
    // A run's recording holds before its stream plays (the primed start) and after it ends (the
    // stop before the disable): those frames are not the stream's (stream_sample -1). A feed hold
    // is a hold while the stream is under way.
    const std::vector<double> stream = c.has("stream_sample") ? column("stream_sample") : std::vector<double>(n, 0.0);
    add_spans(
        marks.spans, t,
        [&](std::size_t i) {
          return (static_cast<long long>(f[i]) & (1LL << board::kFlagHolding)) != 0 && stream[i] >= 0.0;
        },
        "feed hold", "#1f77b4");
    add_spans(
        marks.spans, t, [&](std::size_t i) { return (static_cast<long long>(f[i]) & (1LL << board::kFlagFault)) != 0; },
        fault_label, "#d62728");
  }
  if (c.has("holding")) {
    const std::vector<double> h = column("holding");
    add_spans(
        marks.spans, t, [&](std::size_t i) { return h[i] != 0.0; }, "feed hold", "#1f77b4");
  }
  for (const std::string fault : {"fault_bits", "fault", "board_fault_bits", "estop"}) {
    if (!c.has(fault)) continue;
    const std::vector<double> f = column(fault);
    add_spans(
        marks.spans, t, [&](std::size_t i) { return f[i] != 0.0; }, fault_label, "#d62728");
  }
  // A virtual board's truth: its safety inputs at the stop level, each named as the cause it latches.
  const char* const inputs[] = {"estop_open", "drive_fault1", "drive_fault2", "drive_fault3"};
  for (int k = 0; k < 4; ++k) {
    if (!c.has(inputs[k])) continue;
    link::TelemetryPayload cause;
    cause.board_fault = static_cast<std::uint8_t>(1 << k);  // BoardFault: the e-stop input, then drives 1-3
    const std::vector<double> f = column(inputs[k]);
    add_spans(
        marks.spans, t, [&](std::size_t i) { return f[i] != 0.0; }, link::describe_fault(cause), "#9c27b0");
  }
  if (c.has("underruns")) {  // while the drives are on (the counter also counts before a stream starts)
    const std::vector<double> u = column("underruns");
    const std::vector<double> on = drives.empty() ? std::vector<double>(n, 1.0) : column(drives);
    // A run's: while its stream had samples left to play (once its last sample has played the
    // buffer runs empty until the final hold; that is no underrun of the stream).
    std::vector<double> stream(n, 0.0);
    double last_sample = 1.0;
    if (c.has("stream_sample")) {
      stream = column("stream_sample");
      last_sample = *std::max_element(stream.begin(), stream.end());
    }
    add_spans(
        marks.spans, t,
        [&](std::size_t i) {
          return i > 0 && u[i] > u[i - 1] && on[i] != 0.0 && stream[i] >= 0.0 && stream[i] < last_sample;
        },
        "underrun", "#ff7f0e");
  }
  if (marks.spans.size() > 400) marks.spans.resize(400);  // gnuplot's objects: enough to see a pattern
  // An end that was not a normal one (e-stop, fault, link lost): from then to the recording's end.
  const std::optional<Outcome> outcome = outcome_of(csv_path);
  std::string ending;
  if (outcome && !outcome->normal() && n > 0) {
    const double tick = std::max((t.back() - t.front()) / 500.0, 1e-3);
    const double from = std::clamp(outcome->t_s, t.front(), t.back());
    marks.spans.push_back({from, std::max(t.back(), from + tick), "end: " + outcome->name, "#d62728"});
    ending = ", ended by " + outcome->name + " at " + format_number(std::round(outcome->t_s * 1e3) / 1e3) + " s";
  }

  // ---- the kind, from the columns ----
  if (any_reference && c.has("x_ref_m")) {
    out.kind = "host run recording";
  } else if (any_true && c.has("drives_enabled") && !any_reference) {
    out.kind = "virtual-board truth";
  } else if (c.has("net1_deg") || c.has("ref_x_m")) {
    out.kind = "co-simulation samples";
  } else if (any_encoder && measured) {
    out.kind = "recording (simulate, merge)";
  } else if (any_encoder) {
    out.kind = "telemetry recording (host record)";
  } else {
    out.kind = "recording";
  }
  std::string name = csv_path;
  if (const auto slash = name.rfind('/'); slash != std::string::npos) name = name.substr(slash + 1);
  const double span_s = n > 0 ? t.back() - t.front() : 0.0;
  spec.title = name + ": " + out.kind + ", " + std::to_string(n) + " rows, " +
               format_number(std::round(span_s * 1e3) / 1e3) + " s" + ending;
  spec.panel_height_px = 300;
  for (const PlotPanel& panel : spec.panels) out.panels.push_back(panel.title);
  for (const PlotPanel& panel : spec.panels) {
    marks.styles.emplace_back();
    marks.right_axis.emplace_back();
    for (const PlotSeries& series : panel.series) {
      marks.styles.back().push_back(style_of[series.label]);
      marks.right_axis.back().push_back(on_right.count(series.label) != 0);
    }
    marks.y2_labels.push_back(panel.title.rfind("Plate error", 0) == 0 ? "z error [um]"
                              : panel.title.rfind("Plate", 0) == 0     ? "z [mm]"
                                                                       : "");
  }
  return out;
}

RecordingPlot plot_recording(const std::string& csv_path, const std::string& png_path) {
  RecordingPlot out = describe_recording(csv_path);
  write_plot(png_path, out.spec, out.marks);
  return out;
}

}  // namespace delta
