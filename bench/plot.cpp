#include "bench/plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/subprocess.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace haha {

namespace {

// A double-quoted gnuplot string: backslashes and quotes escaped, line breaks flattened
// (the terminal is `noenhanced`, so _ ^ { } print as themselves).
std::string quoted(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '\\' || c == '"') o += '\\';
    o += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return o + "\"";
}

std::string first_line(const std::string& s) {
  std::istringstream in(s);
  std::string line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t^") != std::string::npos) {
      // gnuplot prints the offending script line, then a caret line, then the message:
      // the message is the informative part.
      last = line;
      if (line.find("rror") != std::string::npos || line.find("warning") != std::string::npos) return line;
    }
  return last.empty() ? "no output" : last;
}

// The PNG terminal this gnuplot has: pngcairo (antialiased) when built in, else png.
const std::string& png_terminal() {
  static const std::string t = [] {
    std::string out;
    if (run_capture("gnuplot -e \"set terminal pngcairo\"", out) == 0 && out.find("unknown") == std::string::npos)
      return std::string("pngcairo");
    return std::string("png");
  }();
  return t;
}

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

}  // namespace

bool gnuplot_available() {
  static const bool ok = [] {
    std::string out;
    return run_capture("gnuplot --version", out) == 0 && out.find("gnuplot") != std::string::npos;
  }();
  return ok;
}

std::string gnuplot_script(const PlotSpec& spec, const std::string& png_path) {
  const std::string where = "plot '" + spec.title + "'";
  if (spec.width < 100 || spec.height < 100 || spec.width > 8000 || spec.height > 8000)
    fail(where, "image size must be within 100..8000 pixels");
  if (spec.series.empty()) fail(where, "no series");
  std::ostringstream s;
  const bool cairo = png_terminal() == "pngcairo";
  s << "set terminal " << png_terminal() << " size " << spec.width << "," << spec.height << " noenhanced"
    << (cairo ? " font \"DejaVu Sans,11\"" : "") << "\n";
  s << "set output " << quoted(png_path) << "\n";
  s << "set encoding utf8\n";
  // Ten distinct colours dark enough for text labels on white (gnuplot's own sixth is a
  // pale yellow).
  static const char* kColours[] = {"#1f5fa8", "#d62728", "#2ca02c", "#e07000", "#7b4fb0",
                                   "#8c564b", "#c2338f", "#138a96", "#555555", "#7a7a00"};
  for (int i = 0; i < 10; ++i) s << "set linetype " << (i + 1) << " lc rgb \"" << kColours[i] << "\"\n";
  s << "set title " << quoted(spec.title);
  {
    std::istringstream lines(spec.subtitle);
    std::string line;
    while (std::getline(lines, line)) s << " . \"\\n\" . " << quoted(line);
  }
  s << "\n";
  s << "set xlabel " << quoted(spec.xlabel) << "\nset ylabel " << quoted(spec.ylabel) << "\n";
  s << "set grid xtics ytics\n";
  // Room around the data for point labels (linear axes; log axes get explicit ranges).
  s << "set offsets " << (spec.logx ? "0, 0" : "graph 0.03, graph 0.14") << ", " << (spec.logy ? "0, 0" : "graph 0.06, graph 0.06")
    << "\n";
  s << "set key " << spec.key << " box opaque samplen 3 spacing 1.2\n";
  if (spec.logx) s << "set logscale x\n";
  if (spec.logy) s << "set logscale y\n";
  bool any_right = false;
  for (const PlotSeries& se : spec.series) any_right |= se.right_axis;
  if (any_right) s << "set y2label " << quoted(spec.y2label) << "\nset y2tics\nset ytics nomirror\n";
  if (!spec.xcategories.empty()) {
    s << "set xtics (";
    for (size_t i = 0; i < spec.xcategories.size(); ++i)
      s << (i ? ", " : "") << quoted(spec.xcategories[i]) << " " << i;
    s << ")\nset xrange [-0.5:" << num(double(spec.xcategories.size()) - 0.5) << "]\n";
  }
  if (spec.xmin < spec.xmax) s << "set xrange [" << num(spec.xmin) << ":" << num(spec.xmax) << "]\n";
  if (!spec.xtics.empty()) {
    s << "set xtics (";
    for (size_t i = 0; i < spec.xtics.size(); ++i) s << (i ? ", " : "") << num(spec.xtics[i]);
    s << ")\n";
  }
  if (!spec.x2label.empty() && spec.x2_scale != 0 && std::isfinite(spec.x2_scale) && std::isfinite(spec.x2_offset)) {
    if (spec.logx) fail(where, "a linked x2 axis needs a linear x axis");
    s << "set x2label " << quoted(spec.x2label) << "\nset x2tics\nset format x2 \"%.0f\"\nset xtics nomirror\n";
    s << "set link x2 via " << num(spec.x2_scale) << "*x+(" << num(spec.x2_offset) << ") inverse (x-("
      << num(spec.x2_offset) << "))/" << num(spec.x2_scale) << "\n";
  }
  if (spec.xtic_rotate != 0) s << "set xtics rotate by " << -spec.xtic_rotate << " left\nset rmargin 12\n";
  // Datablocks, one per series; non-finite points (and non-positive ones on a log axis)
  // are left out.
  size_t finite_points = 0;
  double min_x = INFINITY;
  for (size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& se = spec.series[i];
    if (se.x.size() != se.y.size()) fail(where, "series '" + se.label + "': x and y differ in length");
    if (!se.point_labels.empty() && se.point_labels.size() != se.x.size())
      fail(where, "series '" + se.label + "': point_labels must be empty or one per point");
    if (!se.label_below.empty() && se.label_below.size() != se.x.size())
      fail(where, "series '" + se.label + "': label_below must be empty or one per point");
    s << "$d" << i << " << EOD\n";
    for (size_t k = 0; k < se.x.size(); ++k) {
      const double x = se.x[k], y = se.y[k];
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      if ((spec.logx && x <= 0) || (spec.logy && !se.right_axis && y <= 0)) continue;
      ++finite_points;
      min_x = std::min(min_x, x);
      const bool below = se.label_below.empty() ? se.labels_below : bool(se.label_below[k]);
      s << num(x) << " " << num(y) << " " << quoted(se.point_labels.empty() ? "" : se.point_labels[k]) << " "
        << (below ? 1 : 0) << "\n";
    }
    s << "EOD\n";
  }
  if (finite_points == 0) fail(where, "no finite data points to plot");
  // Counts that start at zero: the axis starts there too (no negative tic from the offsets).
  if (!spec.logx && !(spec.xmin < spec.xmax) && spec.xcategories.empty() && min_x == 0.0) s << "set xrange [0:*]\n";
  s << "plot ";
  static const int kPointTypes[] = {7, 5, 9, 11, 13, 15, 4, 6, 8, 10};
  for (size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& se = spec.series[i];
    const std::string axes = se.right_axis ? " axes x1y2" : "";
    s << (i ? ", \\\n     " : "") << "$d" << i << " using 1:2" << axes;
    if (se.dashed)
      s << " with lines lw 2 dt 3 lc " << (i % 10 + 1);
    else
      s << " with " << (se.lines ? "linespoints" : "points") << " lw 2 lc " << (i % 10 + 1) << " pt " << kPointTypes[i % 10]
        << " ps 1.3" << (se.right_axis ? " dt 2" : "");
    s << " title " << quoted(se.label);
    if (!se.point_labels.empty())
      for (int below = 0; below < 2; ++below)  // column 4 says where each label goes
        s << ", \\\n     $d" << i << " using 1:2:(column(4) == " << below << " ? stringcolumn(3) : \"\")" << axes
          << " with labels offset char 0.6," << (below ? "-0.8" : "0.6") << " left tc lt " << (i % 10 + 1)
          << (cairo ? " font \",9\"" : "") << " notitle";
  }
  s << "\nunset output\n";
  return s.str();
}

void write_plot_png(const std::string& png_path, const PlotSpec& spec) {
  if (!gnuplot_available()) fail(png_path, "cannot draw the plot: the gnuplot command is not installed (Debian: gnuplot-nox)");
  namespace fs = std::filesystem;
  fs::path gp = fs::path(png_path);
  gp.replace_extension(".gp");
  // The kept script names the final PNG; the one that runs names the temporary file.
  write_atomically(gp.string(), [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << gnuplot_script(spec, png_path);
    if (!f.flush()) fail(gp.string(), "cannot write");
  });
  write_atomically(png_path, [&](const std::string& tmp) {
    const std::string script_path = tmp + ".gp";
    {
      std::ofstream f(script_path, std::ios::binary);
      f << gnuplot_script(spec, tmp);
      if (!f.flush()) fail(script_path, "cannot write");
    }
    std::string out;
    const int st = run_capture("gnuplot " + shell_quoted(script_path), out);
    std::error_code ec;
    fs::remove(script_path, ec);
    if (st != 0) fail(png_path, "gnuplot failed: " + first_line(out));
    if (!fs::exists(tmp) || fs::file_size(tmp) == 0) fail(png_path, "gnuplot wrote no image");
  });
}

}  // namespace haha
