// gnuplot back end for PNG plots: the script, data inline, goes to gnuplot's input; no temporary folder.
#include "delta/plot.hpp"
#include "delta/plot_marks.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "delta/input_error.hpp"
#include "delta/output_file.hpp"

extern char** environ;

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

// A PNG ends with its IEND chunk: gnuplot exits 0 even when a full disk cut the file short.
bool is_complete_png(const std::string& path) {
  std::ifstream png(path, std::ios::binary | std::ios::ate);
  static const char kEnd[] = {'I', 'E', 'N', 'D', '\xae', '\x42', '\x60', '\x82'};
  if (!png || png.tellg() < static_cast<std::streamoff>(sizeof(kEnd))) return false;
  png.seekg(-static_cast<std::streamoff>(sizeof(kEnd)), std::ios::end);
  char tail[sizeof(kEnd)];
  return static_cast<bool>(png.read(tail, sizeof(tail))) && std::equal(tail, tail + sizeof(tail), kEnd);
}

}  // namespace

void render_gnuplot_png(const std::string& png_path, const std::string& script) {
  OutputFile output(png_path);  // refuses a missing folder before gnuplot runs
  const std::string output_line = "set output " + quoted(output.writing_path()) + "\n";
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> log(std::tmpfile(), std::fclose);  // unlinked already
  int input[2];
  if (!log || ::pipe(input) != 0) throw std::runtime_error("cannot start gnuplot (no pipe or temporary file)");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, input[0], 0);
  posix_spawn_file_actions_adddup2(&actions, ::fileno(log.get()), 2);
  posix_spawn_file_actions_addclose(&actions, input[1]);
  char* arguments[] = {const_cast<char*>("gnuplot"), nullptr};
  pid_t child = 0;
  const int spawned = ::posix_spawnp(&child, "gnuplot", &actions, nullptr, arguments, environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(input[0]);
  if (spawned != 0) {
    ::close(input[1]);
    throw std::runtime_error("gnuplot not found (scripts/setup.sh installs gnuplot-nox)");
  }
  const auto previous_pipe_handler = ::signal(SIGPIPE, SIG_IGN);  // gnuplot may stop reading early
  for (const std::string* text : {&output_line, &script}) {       // no joined copy of a large script
    for (std::size_t done = 0; done < text->size();) {
      const ssize_t count = ::write(input[1], text->data() + done, text->size() - done);
      if (count < 0 && errno == EINTR) continue;
      if (count <= 0) break;
      done += static_cast<std::size_t>(count);
    }
  }
  ::close(input[1]);
  ::signal(SIGPIPE, previous_pipe_handler);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::rewind(log.get());
    char first_line[200] = "";
    if (!std::fgets(first_line, sizeof(first_line), log.get())) first_line[0] = '\0';
    std::string message(first_line);
    while (!message.empty() && (message.back() == '\n' || message.back() == '\r')) message.pop_back();
    throw std::runtime_error("gnuplot failed drawing " + png_path + ": " + quoted_excerpt(message, 120));
  }
  if (std::filesystem::is_regular_file(output.writing_path()) && !is_complete_png(output.writing_path())) {
    throw InputError(png_path, 0, "could not be written completely (disk full?); nothing written");
  }
  output.commit();
}

void write_plot(const std::string& png_path, const PlotSpec& spec) { write_plot(png_path, spec, PlotMarks{}); }

void write_plot(const std::string& png_path, const PlotSpec& spec, const PlotMarks& marks) {
  std::ostringstream script;
  const int height = spec.panel_height_px * static_cast<int>(spec.panels.size()) + 60;
  for (std::size_t p = 0; p < spec.panels.size(); ++p) {
    for (std::size_t s = 0; s < spec.panels[p].series.size(); ++s) {
      const PlotSeries& series = spec.panels[p].series[s];
      script << "$panel" << p << "_" << s << " << EOD\n";
      for (std::size_t i = 0; i < series.x.size() && i < series.y.size(); ++i) {
        script << format_number(series.x[i]) << ' ' << format_number(series.y[i]) << '\n';
      }
      script << "EOD\n";
    }
  }
  script << "set terminal pngcairo " << (marks.as_written ? "noenhanced " : "") << "size " << spec.width_px << ","
         << height << " font 'sans,10'\n"
         << "set multiplot layout " << spec.panels.size() << ",1 title " << quoted(spec.title) << "\n"
         << "set grid\nset key outside right top\n";
  if (marks.as_written) script << "set lmargin at screen 0.07\nset rmargin at screen 0.74\n";  // one time axis
  std::vector<std::string> span_labels;  // one legend entry per label, in first-seen order
  for (std::size_t k = 0; k < marks.spans.size(); ++k) {
    const PlotSpan& span = marks.spans[k];
    script << "set object " << k + 1 << " rect from first " << format_number(span.from) << ", graph 0 to first "
           << format_number(span.to) << ", graph 1 behind fillcolor rgb " << quoted(span.colour)
           << " fillstyle transparent solid 0.18 noborder\n";
    if (std::find(span_labels.begin(), span_labels.end(), span.label) == span_labels.end()) {
      span_labels.push_back(span.label);
    }
  }
  for (std::size_t p = 0; p < spec.panels.size(); ++p) {
    const PlotPanel& panel = spec.panels[p];
    script << "set title " << quoted(panel.title) << "\nset xlabel " << quoted(panel.x_label) << "\nset ylabel "
           << quoted(panel.y_label) << "\n"
           << (panel.log_y ? "set logscale y\n" : "unset logscale y\n");
    auto on_right = [&](std::size_t s) {
      return p < marks.right_axis.size() && s < marks.right_axis[p].size() && marks.right_axis[p][s];
    };
    bool right_axis = false;
    for (std::size_t s = 0; s < panel.series.size(); ++s) right_axis |= on_right(s);
    if (right_axis) {
      script << "set ytics nomirror\nset y2tics\nset y2label "
             << quoted(p < marks.y2_labels.size() ? marks.y2_labels[p] : std::string()) << "\n";
    } else {
      script << "set ytics mirror\nunset y2tics\nunset y2label\n";
    }
    script << "plot ";
    for (std::size_t s = 0; s < panel.series.size(); ++s) {
      const PlotSeries& series = panel.series[s];
      script << (s ? ", " : "") << "$panel" << p << "_" << s << " using 1:2 " << (on_right(s) ? "axes x1y2 " : "")
             << "with " << (series.points ? "linespoints pt 7 ps 0.6" : "lines") << " lw 1.2 "
             << (p < marks.styles.size() && s < marks.styles[p].size() ? marks.styles[p][s] : "") << " title "
             << quoted(series.label);
    }
    for (const std::string& label : span_labels) {
      const auto span =
          std::find_if(marks.spans.begin(), marks.spans.end(), [&](const PlotSpan& s) { return s.label == label; });
      script << ", keyentry with boxes fillcolor rgb " << quoted(span->colour)
             << " fillstyle transparent solid 0.18 noborder title " << quoted(label);
    }
    script << "\n";
  }
  script << "unset multiplot\n";
  render_gnuplot_png(png_path, script.str());
}

}  // namespace delta
