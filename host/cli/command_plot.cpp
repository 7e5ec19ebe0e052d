// deltactl plot: a PNG of any recording the project writes, with the panels its columns support.
#include <algorithm>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/recording_plot.hpp"

namespace delta {
namespace {

struct PlotOptions {
  std::string in;
  std::string out;
};

const RegisterCommand command("plot", 25, [](CLI::App& root) {
  auto options = std::make_shared<PlotOptions>();
  CLI::App* sub = root.add_subcommand("plot", "A PNG of any recording: joints, tracking, currents, plate, faults");
  sub->footer(
      "\nReads a CSV the project writes and draws the panels its columns support, on board time:\n"
      "  joint angles    references (alpha*_ref_deg, net*_deg), encoders (alpha*_deg, encoder*_deg),\n"
      "                  true angles (true_alpha*_deg, true*_deg)\n"
      "  tracking error  encoder - reference (or encoder - true angle), degrees\n"
      "  currents        current*_a\n"
      "  plate           x_m,y_m,z_m against x_ref_m.. or ref_x_m.. (mm), and their difference (um);\n"
      "                  z on its own axis at the right\n"
      "  other columns   any other numeric column (not the link's counters and indices)\n"
      "With the drives off throughout (a drag) there is no tracking or current panel.\n"
      "Bands mark drives off (drives_enabled = 0), feed holds while the stream plays and faults\n"
      "(flags, fault_bits), underruns (the underruns counter going up while a stream plays) and an\n"
      "end that was not normal (an e-stop, a fault, a lost link: the '# outcome:' line host run and\n"
      "host record end their recordings with), from then to the end. Works on host run and host\n"
      "record recordings, merged and simulated recordings, virtual-board truth (--truth) and cosim\n"
      "samples (--out).\n"
      "Long recordings are thinned to the minimum and maximum of each of 1500 time buckets.\n"
      "Bad input (missing t_s, a non-numeric field, time going backwards, nothing to plot): one line\n"
      "FILE:LINE: reason, exit 2, no PNG.\n"
      "Example: deltactl plot run.csv --out run.png");
  sub->add_option("csv", options->in, "the recording (CSV with a t_s column)")->required();
  sub->add_option("--out", options->out, "the PNG to write")->required();
  sub->callback([options] {
    const RecordingPlot plot = plot_recording(options->in, options->out);
    std::cout << options->out << ": " << plot.kind << ", " << plot.rows << " rows";
    std::vector<std::string> bands;
    for (const PlotSpan& span : plot.marks.spans) {
      if (std::find(bands.begin(), bands.end(), span.label) == bands.end()) bands.push_back(span.label);
    }
    for (std::size_t k = 0; k < bands.size(); ++k) std::cout << (k ? ", " : "; bands: ") << bands[k];
    std::cout << "; panels:";
    for (std::size_t k = 0; k < plot.panels.size(); ++k) std::cout << (k ? ", " : " ") << plot.panels[k];
    std::cout << '\n';
  });
});

}  // namespace
}  // namespace delta
