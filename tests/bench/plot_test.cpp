// Plots through gnuplot (bench/plot.h): script checks, escaping, real PNGs with the data
// drawn, errors naming the file, nothing left behind on failure.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "core/error.h"
#include "bench/plot.h"
#include "io/image.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

PlotSpec simple_spec() {
  PlotSpec p;
  p.title = "time against size";
  p.subtitle = "machine: test";
  p.xlabel = "size (KB)";
  p.ylabel = "time (ms)";
  PlotSeries a;
  a.label = "series a";
  a.x = {1, 2, 3, 4};
  a.y = {1, 4, 9, 16};
  PlotSeries b;
  b.label = "series b";
  b.x = {1, 2, 3, 4};
  b.y = {2, 3, 4, 5};
  b.point_labels = {"p1", "p2", "p3", "p4"};
  p.series = {a, b};
  return p;
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("haha-plot-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Pixels that are clearly coloured (not grey / white / black): the series lines.
int coloured_pixels(const Image& img) {
  int n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const float r = img.at(x, y, 0), g = img.at(x, y, 1), b = img.at(x, y, 2);
      if (std::max({r, g, b}) - std::min({r, g, b}) > 0.3f) ++n;
    }
  return n;
}

TEST(Plot, ScriptRejectsInconsistentSeries) {
  PlotSpec p = simple_spec();
  p.series[0].y.pop_back();
  EXPECT_THROW(gnuplot_script(p, "x.png"), Error);
  p = simple_spec();
  p.series[1].point_labels.pop_back();
  EXPECT_THROW(gnuplot_script(p, "x.png"), Error);
  p = simple_spec();
  p.series.clear();
  EXPECT_THROW(gnuplot_script(p, "x.png"), Error);
  p = simple_spec();
  p.width = 10;
  EXPECT_THROW(gnuplot_script(p, "x.png"), Error);
}

TEST(Plot, NonFiniteAndNonPositiveOnLogAxisAreLeftOut) {
  PlotSpec p = simple_spec();
  p.series.resize(1);
  p.series[0].x = {1, 2, NAN, 4, -1};
  p.series[0].y = {1, INFINITY, 3, 4, 5};
  p.logx = true;
  const std::string s = gnuplot_script(p, "x.png");
  // Only (1, 1) and (4, 4) survive.
  EXPECT_NE(s.find("\n1 1 \"\" 0\n4 4 \"\" 0\nEOD"), std::string::npos) << s;
  // Nothing finite at all: an error, not an empty plot.
  p.series[0].x = {NAN, -2};
  p.series[0].y = {1, 2};
  try {
    gnuplot_script(p, "x.png");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no finite data"), std::string::npos) << e.what();
  }
}

TEST(Plot, QuotesAndBackslashesAreEscaped) {
  PlotSpec p = simple_spec();
  p.title = "a \"quoted\" title with \\ and under_score";
  const std::string s = gnuplot_script(p, "x.png");
  EXPECT_NE(s.find("\"a \\\"quoted\\\" title with \\\\ and under_score\""), std::string::npos) << s;
  EXPECT_NE(s.find("noenhanced"), std::string::npos);
}

TEST(Plot, WritesAReadablePngWithTheDataDrawn) {
  if (!gnuplot_available()) GTEST_SKIP() << "gnuplot is not installed";
  const fs::path d = temp_dir("png");
  PlotSpec p = simple_spec();
  p.title = "a \"quoted\" title_with_underscores";
  p.width = 640;
  p.height = 400;
  const std::string path = (d / "a.png").string();
  write_plot_png(path, p);
  ASSERT_TRUE(fs::exists(path));
  EXPECT_TRUE(fs::exists(d / "a.gp"));  // the script is kept beside the image
  const Image img = read_image(path);
  EXPECT_EQ(img.width, 640);
  EXPECT_EQ(img.height, 400);
  ASSERT_GE(img.channels, 3);
  const int coloured = coloured_pixels(img);
  EXPECT_GT(coloured, 200);  // two series of lines and points

  // Different data gives a different picture (the data is really drawn).
  PlotSpec q = p;
  q.series[0].y = {16, 9, 4, 1};
  const std::string path2 = (d / "b.png").string();
  write_plot_png(path2, q);
  const Image img2 = read_image(path2);
  ASSERT_EQ(img2.data.size(), img.data.size());
  size_t differ = 0;
  for (size_t i = 0; i < img.data.size(); ++i) differ += std::fabs(img.data[i] - img2.data[i]) > 0.1f;
  EXPECT_GT(differ, 100u);

  // Right axis and category axis variants render too.
  PlotSpec r = p;
  r.series[1].right_axis = true;
  r.y2label = "other (units)";
  r.xcategories = {"one", "two", "three", "four"};
  r.xtic_rotate = 30;
  for (PlotSeries& s : r.series) s.x = {0, 1, 2, 3};
  write_plot_png((d / "c.png").string(), r);
  EXPECT_GT(coloured_pixels(read_image((d / "c.png").string())), 100);
  fs::remove_all(d);
}

TEST(Plot, GnuplotFailureNamesTheFileAndLeavesNothing) {
  if (!gnuplot_available()) GTEST_SKIP() << "gnuplot is not installed";
  const fs::path d = temp_dir("fail");
  PlotSpec p = simple_spec();
  p.key = "nonsense_position";  // gnuplot rejects this
  const std::string path = (d / "bad.png").string();
  try {
    write_plot_png(path, p);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind(path + ": gnuplot failed", 0), 0u) << m;
  }
  EXPECT_FALSE(fs::exists(path));
  for (const auto& entry : fs::directory_iterator(d))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
  fs::remove_all(d);
}

}  // namespace
}  // namespace haha
