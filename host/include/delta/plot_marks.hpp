// More for a PNG plot (plot.hpp): bands marking stretches of the x axis on every panel, a style per
// series, a second y axis, and titles printed as written.
#pragma once

#include <string>
#include <vector>

#include "delta/plot.hpp"

namespace delta {

// A stretch of the x axis marked in every panel (e.g. drives off, a feed hold, a fault), drawn as
// a translucent band behind the data; its label appears once in the legend.
struct PlotSpan {
  double from = 0.0, to = 0.0;
  std::string label;
  std::string colour;  // gnuplot colour, e.g. "#c00000"
};

struct PlotMarks {
  std::vector<PlotSpan> spans;                   // on every panel (all panels share the x axis then)
  std::vector<std::vector<std::string>> styles;  // styles[p][s]: more gnuplot style of panel p's series s
  // right_axis[p][s]: panel p's series s is drawn on a second y axis at the right, on a scale of
  // its own, labelled y2_labels[p].
  std::vector<std::vector<bool>> right_axis;
  std::vector<std::string> y2_labels;
  bool as_written = false;  // noenhanced: file and column names keep their underscores
};

// write_plot (plot.hpp) with the marks.
void write_plot(const std::string& png_path, const PlotSpec& spec, const PlotMarks& marks);

}  // namespace delta
