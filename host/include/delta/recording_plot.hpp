// A picture of any recording the project writes (`deltactl plot`, and the dashboard's recordings):
// the kind is told from the columns, and the panels are those the columns support.
//
//   joint angles     alpha*_ref_deg / net*_deg (reference), alpha*_deg / encoder*_deg (encoders),
//                    true_alpha*_deg / true*_deg (the plant's true angles)
//   tracking error   encoder - reference (or encoder - true angle when there is no reference)
//   currents         current*_a
//   plate            x_m,y_m,z_m (measured, stage or truth) against x_ref_m.. / ref_x_m..
//   time marks       drives_enabled = 0 (drives off), flags' holding bit while the stream plays
//                    (stream_sample >= 0, when the column is there: not the primed start and the
//                    final stop's hold), flags' fault bit, fault_bits != 0, an underruns counter
//                    going up, and an end that was not normal: the trailer "# outcome: ..." of
//                    host run / host record naming an e-stop, a fault or a lost link
//   other            any other numeric column, except the link's counters and indices
// With the drives off throughout (drives_enabled all 0: a drag) there is no tracking against the
// board's references and no current panel. On the plate panels z has its own axis, at the right.
#pragma once

#include <string>
#include <vector>

#include "delta/plot.hpp"
#include "delta/plot_marks.hpp"

namespace delta {

struct RecordingPlot {
  std::string kind;                 // e.g. "host run recording", "virtual-board truth"
  std::size_t rows = 0;             // data rows read
  std::vector<std::string> panels;  // panel titles, top to bottom
  PlotSpec spec;                    // what is drawn
  PlotMarks marks;                  // its bands (drives off, feed hold, fault, the end) and styles
};

// Reads `csv_path` (SPEC recording rules: FILE:LINE: reason as InputError, including time going
// backwards and a file with no column to plot) and tells what its picture shows, without drawing.
RecordingPlot describe_recording(const std::string& csv_path);

// describe_recording, then the PNG, written atomically (nothing on error).
RecordingPlot plot_recording(const std::string& csv_path, const std::string& png_path);

}  // namespace delta
