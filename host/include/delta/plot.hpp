// PNG plots through gnuplot (Debian's gnuplot-nox): stacked panels of line series.
#pragma once

#include <string>
#include <vector>

namespace delta {

struct PlotSeries {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  bool points = false;  // markers instead of a line
};

struct PlotPanel {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  bool log_y = false;
};

struct PlotSpec {
  std::string title;
  std::vector<PlotPanel> panels;  // stacked top to bottom
  int width_px = 1200;
  int panel_height_px = 350;
};

// Writes a PNG atomically. Throws InputError for an output path that cannot be written (before
// gnuplot runs) or a PNG cut short, std::runtime_error when gnuplot is missing or fails.
void write_plot(const std::string& png_path, const PlotSpec& spec);

// Runs a gnuplot script (terminal and data included; `set output` is added) into png_path, with
// the same guarantees: the PNG appears complete or not at all, no temporary folder is left.
void render_gnuplot_png(const std::string& png_path, const std::string& script);

}  // namespace delta
