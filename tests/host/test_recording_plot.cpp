// deltactl plot's picture of a recording (describe_recording): which panels and bands a host run
// recording gets, in the columns and the trailer run_job.cpp writes. Rows are made here, 1 kHz of
// board time, as `host run` and `host record` lay them out.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "delta/recording_plot.hpp"

namespace delta {
namespace {

namespace fs = std::filesystem;

std::string temp(const std::string& name) {
  static const fs::path folder = [] {
    const fs::path p = fs::path(::testing::TempDir()) / ("recording_plot_" + std::to_string(::getpid()));
    fs::create_directories(p);
    return p;
  }();
  return (folder / name).string();
}

// What a row of the recording is at sample i.
struct Row {
  bool drives = true;
  bool holding = false;
  long stream_sample = -1;
  bool fault = false;
  int underruns = 0;  // the board's counter
};

constexpr int kHoldingBit = 2, kFaultBit = 3;  // docs/board_link.md: flags

// A host run recording (run_job.cpp's columns) of `rows` rows, then `trailer` lines.
std::string run_recording(const std::string& name, int rows, const std::function<Row(int)>& row_at,
                          const std::string& trailer = "") {
  const std::string path = temp(name);
  std::ofstream out(path);
  out << "# deltactl host run: one row per board telemetry frame\n"
         "t_s,x_ref_m,y_ref_m,z_ref_m,alpha1_ref_deg,alpha2_ref_deg,alpha3_ref_deg,alpha1_deg,alpha2_deg,alpha3_deg,"
         "current1_a,current2_a,current3_a,fault_bits,flags,drives_enabled,sample_index,fill,tau_s,stream_sample,"
         "bad_frames,underruns,rejected,slew_limits\n";
  for (int i = 0; i < rows; ++i) {
    const Row r = row_at(i);
    const double t = 10.0 + i * 1e-3, s = std::sin(2.0 * M_PI * 0.5 * i * 1e-3);
    const int flags = (r.drives ? 1 : 0) | (r.holding ? 1 << kHoldingBit : 0) | (r.fault ? 1 << kFaultBit : 0);
    out << t << ',' << 0.005 * s << ',' << -0.004 * s << ',' << -0.0713 + 0.002 * s;
    for (int j = 0; j < 3; ++j) out << ',' << 30.0 + 3.0 * s + j;
    for (int j = 0; j < 3; ++j) out << ',' << 30.0 + 3.0 * s + j + 0.001;
    for (int j = 0; j < 3; ++j) out << ',' << (r.drives ? 0.05 * s : 0.0);
    out << ',' << (r.fault ? 4 : 0) << ',' << flags << ',' << (r.drives ? 1 : 0) << ',' << 1000 + i << ",200,"
        << (r.stream_sample >= 0 ? r.stream_sample * 1e-3 : 0.0) << ',' << r.stream_sample << ",0," << r.underruns
        << ",0,0\n";
  }
  out << trailer;
  return path;
}

std::vector<std::string> band_labels(const RecordingPlot& plot) {
  std::vector<std::string> labels;
  for (const PlotSpan& span : plot.marks.spans) labels.push_back(span.label);
  return labels;
}

// A run with one feed hold in the middle: primed (held before the stream plays), the hold, the
// final hold and the disable. Only the middle one is a feed hold. Its one underrun while the
// stream plays is banded, the board's count after the last sample has played is not.
TEST(RecordingPlot, AFeedHoldIsAHoldWhileTheStreamPlaysNotTheRunsPrimedStartOrItsStop) {
  const std::string path = run_recording("held.csv", 3000, [](int i) {
    Row r;
    if (i < 200) {
      r.holding = true;  // primed: the lead is sent while the board holds
    } else if (i < 1200) {
      r.stream_sample = i - 200;
    } else if (i < 1500) {
      r.holding = true;  // the operator's hold: the stream's sample stays
      r.stream_sample = 1000;
    } else if (i < 2600) {
      r.stream_sample = i - 500;
      r.underruns = i < 2000 ? 0 : 1;  // one underrun while the stream plays
    } else if (i < 2700) {
      r.stream_sample = 2099;  // the last sample played: the buffer runs empty before the stop
      r.underruns = i < 2650 ? 1 : 2;
    } else if (i < 2800) {
      r.holding = true;  // the stop: hold, then disable (not the stream's frames)
      r.underruns = 2;
    } else {
      r.drives = false;
      r.underruns = 2;
    }
    return r;
  });
  const RecordingPlot plot = describe_recording(path);
  std::vector<PlotSpan> holds;
  for (const PlotSpan& span : plot.marks.spans) {
    if (span.label == "feed hold") holds.push_back(span);
  }
  ASSERT_EQ(holds.size(), 1u) << "bands: " << ::testing::PrintToString(band_labels(plot));
  EXPECT_NEAR(holds[0].from, 11.2, 1e-9);
  EXPECT_NEAR(holds[0].to, 11.499, 1e-9);
  // Likewise an underrun: the one while the stream plays, not the empty buffer after its end.
  std::vector<PlotSpan> underruns;
  for (const PlotSpan& span : plot.marks.spans) {
    if (span.label == "underrun") underruns.push_back(span);
  }
  ASSERT_EQ(underruns.size(), 1u) << "bands: " << ::testing::PrintToString(band_labels(plot));
  EXPECT_NEAR(underruns[0].from, 12.0, 1e-9);
  // The disable at the end is drives off; without a trailer nothing says the end was not normal.
  for (const PlotSpan& span : plot.marks.spans) EXPECT_EQ(span.label.rfind("end: ", 0), std::string::npos);
  EXPECT_EQ(holds[0].label, "feed hold");
}

// An e-stopped run (its trailer says so) is banded from the e-stop to the recording's end, and its
// title says how it ended; a completed run's trailer adds no band.
TEST(RecordingPlot, AnEstoppedOrFaultedRunIsBandedFromItsEndNotPlottedAsANormalEnd) {
  auto row = [](int i) {
    Row r;
    r.stream_sample = i < 1500 ? i : -1;
    r.drives = i < 1510;
    return r;
  };
  const RecordingPlot stopped = describe_recording(run_recording(
      "estop.csv", 2000, row, "# outcome: e-stop at board time 11.5 s (exit 3): tty: e-stop on request: drives off\n"));
  bool banded = false;
  for (const PlotSpan& span : stopped.marks.spans) {
    if (span.label != "end: e-stop") continue;
    banded = true;
    EXPECT_NEAR(span.from, 11.5, 1e-9);
    EXPECT_NEAR(span.to, 11.999, 1e-9);
  }
  EXPECT_TRUE(banded) << ::testing::PrintToString(band_labels(stopped));
  EXPECT_NE(stopped.spec.title.find("ended by e-stop at 11.5 s"), std::string::npos) << stopped.spec.title;
  const RecordingPlot lost = describe_recording(
      run_recording("lost.csv", 2000, row, "# outcome: link lost at board time 11.2 s (exit 4): no telemetry\n"));
  EXPECT_EQ(lost.marks.spans.back().label, "end: link lost");
  // A run that completed but exited 3 (the board did not hold at the end) is not a normal end either.
  const RecordingPlot unheld = describe_recording(
      run_recording("unheld.csv", 2000, row, "# outcome: completed at board time 11.5 s (exit 3): no hold\n"));
  EXPECT_EQ(unheld.marks.spans.back().label, "end: completed");
  const RecordingPlot completed = describe_recording(
      run_recording("completed.csv", 2000, row, "# outcome: completed at board time 11.5 s (exit 0)\n"));
  for (const PlotSpan& span : completed.marks.spans) EXPECT_EQ(span.label.rfind("end: ", 0), std::string::npos);
  EXPECT_EQ(completed.spec.title.find("ended by"), std::string::npos) << completed.spec.title;
}

// The fault band names the causes latched where it starts, the board's own (its safety inputs,
// an e-stop command) beside the joints'; a truth's safety inputs are banded by the cause they latch.
TEST(RecordingPlot, TheFaultBandNamesTheBoardsCauses) {
  const std::string path = temp("board_fault.csv");
  {
    std::ofstream out(path);
    out << "t_s,alpha1_deg,flags,fault_bits,board_fault_bits,estop\n";
    for (int i = 0; i < 200; ++i) {
      const bool faulted = i >= 100;
      out << i * 1e-3 << ',' << i * 0.01 << ',' << (faulted ? 8 : 1) << ",0," << (faulted ? 4 : 0) << ','
          << (faulted ? 1 : 0) << '\n';
    }
  }
  const RecordingPlot plot = describe_recording(path);
  const std::vector<std::string> labels = band_labels(plot);
  ASSERT_FALSE(labels.empty());
  for (const std::string& label : labels) EXPECT_EQ(label, "fault: e-stop command, drive 2 fault");
  const std::string truth = temp("truth_inputs.csv");
  {
    std::ofstream out(truth);
    out << "t_s,x_m,drives_enabled,estop_open,drive_fault1,drive_fault2,drive_fault3\n";
    for (int i = 0; i < 200; ++i) out << i * 1e-3 << ",0.001,1," << (i >= 50 ? 1 : 0) << ",0,0," << (i >= 150) << '\n';
  }
  const std::vector<std::string> inputs = band_labels(describe_recording(truth));
  EXPECT_NE(std::find(inputs.begin(), inputs.end(), "e-stop input open"), inputs.end())
      << ::testing::PrintToString(inputs);
  EXPECT_NE(std::find(inputs.begin(), inputs.end(), "drive 3 fault"), inputs.end()) << ::testing::PrintToString(inputs);
  EXPECT_EQ(std::find(inputs.begin(), inputs.end(), "drive 1 fault"), inputs.end());
}

// On the plate panels z (about -71 mm) has an axis of its own; x and y (millimetres about 0)
// share the left one, so their motion is not flattened.
TEST(RecordingPlot, ThePlatesZHasItsOwnAxis) {
  const RecordingPlot plot = describe_recording(run_recording("plate.csv", 1000, [](int i) {
    Row r;
    r.stream_sample = i;
    return r;
  }));
  int plate_panels = 0;
  ASSERT_EQ(plot.marks.right_axis.size(), plot.spec.panels.size());
  for (std::size_t p = 0; p < plot.spec.panels.size(); ++p) {
    const PlotPanel& panel = plot.spec.panels[p];
    if (panel.title.rfind("Plate", 0) != 0) continue;
    ++plate_panels;
    bool x = false, y = false, z = false;
    ASSERT_EQ(plot.marks.right_axis[p].size(), panel.series.size());
    for (std::size_t s = 0; s < panel.series.size(); ++s) {
      const PlotSeries& series = panel.series[s];
      const bool is_z = series.label.rfind("z_", 0) == 0;
      EXPECT_EQ(plot.marks.right_axis[p][s], is_z) << panel.title << ": " << series.label;
      z |= is_z;
      x |= series.label.rfind("x_", 0) == 0;
      y |= series.label.rfind("y_", 0) == 0;
    }
    EXPECT_TRUE(x && y && z) << panel.title;
    EXPECT_FALSE(plot.marks.y2_labels[p].empty()) << panel.title;
  }
  EXPECT_GE(plate_panels, 1);
}

// A drag (host record: the drives off throughout) has the board's references and currents in its
// columns, but no tracking against a reference the drives never followed and no currents; a run
// (drives on) has both panels.
TEST(RecordingPlot, ADragHasNoTrackingOrCurrentPanels) {
  auto has_panel = [](const RecordingPlot& plot, const std::string& title) {
    for (const std::string& panel : plot.panels) {
      if (panel.rfind(title, 0) == 0) return true;
    }
    return false;
  };
  const RecordingPlot drag = describe_recording(run_recording("drag.csv", 1000, [](int) {
    Row r;
    r.drives = false;
    return r;
  }));
  EXPECT_FALSE(has_panel(drag, "Tracking error")) << ::testing::PrintToString(drag.panels);
  EXPECT_FALSE(has_panel(drag, "Drive currents")) << ::testing::PrintToString(drag.panels);
  EXPECT_TRUE(has_panel(drag, "Joint angles"));
  const RecordingPlot run = describe_recording(run_recording("driven.csv", 1000, [](int i) {
    Row r;
    r.stream_sample = i;
    return r;
  }));
  EXPECT_TRUE(has_panel(run, "Tracking error")) << ::testing::PrintToString(run.panels);
  EXPECT_TRUE(has_panel(run, "Drive currents")) << ::testing::PrintToString(run.panels);
}

}  // namespace
}  // namespace delta
