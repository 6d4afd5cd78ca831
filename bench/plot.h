// Line and scatter plots as PNG through gnuplot (Debian's gnuplot-nox, pngcairo terminal,
// falling back to the libgd png terminal). A plot is described as data here, written as a
// self-contained gnuplot script (data inline), and rendered by running `gnuplot`; the
// script is kept beside the PNG so a figure can be restyled or redrawn without re-measuring.
//
// Every plot has a title, a machine/context subtitle, labelled axes (put the unit in the
// label: "render time (ms)") and a legend with one entry per series.
#pragma once

#include <string>
#include <vector>

namespace haha {

struct PlotSeries {
  std::string label;                      // legend entry
  std::vector<double> x, y;               // same length; non-finite points are left out
  std::vector<std::string> point_labels;  // empty, or one short text per point (drawn beside it)
  bool right_axis = false;                // plotted against the y2 axis
  bool lines = true;                      // points joined in the given order (else points only)
  bool dashed = false;                    // dashed line without point symbols (a reference level)
  bool labels_below = false;              // point labels below-right (default above-right)
  std::vector<bool> label_below;          // empty, or per point (overrides labels_below)
};

struct PlotSpec {
  std::string title;
  std::string subtitle;  // more title lines ('\n'-separated), e.g. the machine the numbers come from
  std::string xlabel, ylabel, y2label;  // y2label: used when a series is on the right axis
  bool logx = false, logy = false;
  int width = 960, height = 600;        // pixels
  std::string key = "top right";        // gnuplot key position ("bottom right", "top left outside", ...)
  double xmin = 0, xmax = 0;             // x range when xmin < xmax (else automatic)
  std::vector<double> xtics;            // explicit x tic positions (else automatic)
  // Secondary x axis on top, linked to x: x2 = x2_scale * x + x2_offset (e.g. storage in
  // KB against a Gaussian count). Drawn when x2label is set and x2_scale != 0.
  std::string x2label;
  double x2_scale = 0, x2_offset = 0;
  // Category axis: when non-empty, x values are indices 0..n-1 shown with these names.
  std::vector<std::string> xcategories;
  int xtic_rotate = 0;                  // degrees (long category names: 30..90)
  std::vector<PlotSeries> series;
};

// True when a `gnuplot` command runs here (checked once).
bool gnuplot_available();

// The gnuplot script that draws `spec` into `png_path` (data inline as datablocks).
// Throws haha::Error "plot '<title>': <problem>" for mismatched x/y or point_labels sizes,
// bad sizes, a log axis with no positive value, or no finite point at all.
std::string gnuplot_script(const PlotSpec& spec, const std::string& png_path);

// Writes png_path (atomically) by running gnuplot on the script, and the script itself to
// png_path with ".gp" in place of ".png". Throws haha::Error "<png_path>: <problem>" when
// gnuplot is missing or fails (its first error line is quoted).
void write_plot_png(const std::string& png_path, const PlotSpec& spec);

}  // namespace haha
