// gnuplot back end for PNG plots: data and script go to a temporary folder, gnuplot renders.
#include "delta/plot.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "delta/output_file.hpp"

namespace delta {
namespace {

std::string quoted(const std::string& text) {
  std::string escaped;
  for (char c : text) {
    if (c == '"' || c == '\\') escaped.push_back('\\');
    escaped.push_back(c);
  }
  return "\"" + escaped + "\"";
}

}  // namespace

void write_plot(const std::string& png_path, const PlotSpec& spec) {
  namespace fs = std::filesystem;
  char folder_template[] = "/tmp/deltactl-plot-XXXXXX";
  if (!::mkdtemp(folder_template)) throw std::runtime_error("cannot create a temporary folder for the plot");
  const fs::path folder(folder_template);
  const fs::path target = fs::absolute(png_path);
  const std::string partial = target.string() + ".partial.png";
  std::ofstream script(folder / "plot.gp");
  const int height = spec.panel_height_px * static_cast<int>(spec.panels.size()) + 60;
  script << "set terminal pngcairo size " << spec.width_px << "," << height << " font 'sans,10'\n"
         << "set output " << quoted(partial) << "\n"
         << "set multiplot layout " << spec.panels.size() << ",1 title " << quoted(spec.title) << "\n"
         << "set grid\nset key outside right top\n";
  for (std::size_t p = 0; p < spec.panels.size(); ++p) {
    const PlotPanel& panel = spec.panels[p];
    script << "set title " << quoted(panel.title) << "\nset xlabel " << quoted(panel.x_label)
           << "\nset ylabel " << quoted(panel.y_label) << "\n"
           << (panel.log_y ? "set logscale y\n" : "unset logscale y\n") << "plot ";
    for (std::size_t s = 0; s < panel.series.size(); ++s) {
      const PlotSeries& series = panel.series[s];
      const fs::path data = folder / ("panel" + std::to_string(p) + "_" + std::to_string(s) + ".dat");
      std::ofstream out(data);
      for (std::size_t i = 0; i < series.x.size() && i < series.y.size(); ++i) {
        out << format_number(series.x[i]) << ' ' << format_number(series.y[i]) << '\n';
      }
      script << (s ? ", " : "") << quoted(data.string()) << " using 1:2 with "
             << (series.points ? "linespoints pt 7 ps 0.6" : "lines") << " lw 1.2 title " << quoted(series.label);
    }
    script << "\n";
  }
  script << "unset multiplot\n";
  script.close();
  const std::string command = "gnuplot " + quoted((folder / "plot.gp").string()) + " 2>" +
                              quoted((folder / "gnuplot.log").string());
  const int status = std::system(command.c_str());
  std::error_code ignored;
  if (status != 0) {
    std::ifstream log(folder / "gnuplot.log");
    std::string first_line;
    std::getline(log, first_line);
    fs::remove_all(folder, ignored);
    fs::remove(partial, ignored);
    throw std::runtime_error("gnuplot failed (is gnuplot-nox installed? scripts/setup.sh installs it): " + first_line);
  }
  fs::rename(partial, target);
  fs::remove_all(folder, ignored);
}

}  // namespace delta
