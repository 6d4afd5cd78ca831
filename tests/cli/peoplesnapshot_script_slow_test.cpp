// scripts/peoplesnapshot.sh end to end on a stand-in, never real data: one subject in
// InstantAvatar's layout (tests/support/peoplesnapshot_standin.h, 32 x 24 px, 8 frames) with
// its split given by --frames, the tiny preset and tiny step counts. The script converts,
// trains, evaluates and writes OUT/table.md: the subject's HAHA filtered and full-Gaussian
// rows carry the numbers of OUT/SUBJECT/eval.json, the published rows are there, and a
// second call skips the finished subject. A subject folder missing under PS_ROOT: one
// `haha: error:` line, exit non-zero, nothing converted or trained.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support/haha_cli.h"
#include "support/peoplesnapshot_standin.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using haha::test::kHaha;
using haha::test::slurp;

const fs::path kScript = fs::path(__FILE__).parent_path().parent_path().parent_path() / "scripts" / "peoplesnapshot.sh";

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

// The cells of the first table row that starts with `label`, after the label.
std::vector<std::string> row_cells(const std::string& table, const std::string& label, size_t nth = 0) {
  std::istringstream in(table);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("| " + label + " |", 0) != 0) continue;
    if (nth-- > 0) continue;
    std::vector<std::string> cells;
    std::istringstream cs(line.substr(label.size() + 4));
    for (std::string c; std::getline(cs, c, '|');) {
      c.erase(0, c.find_first_not_of(' '));
      c.erase(c.find_last_not_of(' ') + 1);
      if (!c.empty()) cells.push_back(c);
    }
    return cells;
  }
  return {};
}

double cell_number(const std::string& c) { return std::strtod(c.c_str(), nullptr); }

TEST(PeopleSnapshotScript, RunsTheProtocolOnAStandInAndResumes) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  ASSERT_TRUE(fs::exists(kScript)) << kScript;
  if (std::system("command -v python3 > /dev/null 2>&1") != 0) GTEST_SKIP() << "python3 is not installed";
  const fs::path dir = fs::temp_directory_path() / ("haha-ps-script-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  test::PeopleSnapshotStandinOptions so;
  so.width = 32;
  so.height = 24;
  so.frames = 8;
  so.train_rows = 2;  // frames 0, 2
  so.test_rows = 2;   // frames 4, 6
  const test::PeopleSnapshotStandin st = test::make_peoplesnapshot_standin(dir / "ps", so);
  const fs::path out = dir / "out";
  const std::string models = " --model " + q(st.smplx) + " --smpl-model " + q(st.smpl);
  const std::string redirect = " > " + q(dir / "o.txt") + " 2> " + q(dir / "e.txt");

  // A subject folder missing: one line naming it, before anything runs.
  const std::string bad = "bash " + q(kScript) + " " + q(dir / "ps") + " " + q(out) + models +
                          " --subjects 'male-3-casual male-4-casual' --haha " + q(kHaha) + redirect;
  EXPECT_NE(WEXITSTATUS(std::system(bad.c_str())), 0);
  const std::string e = slurp(dir / "e.txt");
  EXPECT_EQ(e.rfind("haha: error: ", 0), 0u) << e;
  EXPECT_NE(e.find("male-4-casual"), std::string::npos) << e;
  EXPECT_EQ(std::count(e.begin(), e.end(), '\n'), 1) << e;
  EXPECT_FALSE(fs::exists(out)) << "nothing may be converted or trained";

  const std::string cmd = "bash " + q(kScript) + " " + q(dir / "ps") + " " + q(out) + models +
                          " --smpl-correspondence " + q(st.corr) +
                          " --preset tiny --device cpu --subjects male-3-casual"
                          " --frames male-3-casual=0:4:2,4:8:2 --size 32"
                          " --train 's0.steps=5 s1.steps=20 s2.steps=10 s3.steps=10 eval.tto_steps=5'"
                          " --haha " +
                          q(kHaha) + redirect;
  ASSERT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 0) << slurp(dir / "e.txt") << slurp(dir / "o.txt");
  const fs::path ev = out / "male-3-casual" / "eval.json";
  ASSERT_TRUE(fs::exists(ev));
  const auto j = nlohmann::json::parse(slurp(ev));
  EXPECT_EQ(j.at("split"), "test");
  EXPECT_EQ(j.at("background"), "black");
  EXPECT_EQ(j.at("tto_steps"), 5);
  const std::string table = slurp(out / "table.md");
  std::printf("%s", table.c_str());

  // Our rows: the eval json's numbers, in the per-sequence table (male-3-casual is the second
  // sequence of the first pair, after female-3-casual) and in the mean over the one sequence.
  for (const auto& [label, variant] : {std::pair<std::string, std::string>{"HAHA filtered [run]", "HAHA filtered"},
                                       {"full Gaussians [run]", "full Gaussians"}}) {
    nlohmann::json v;
    for (const auto& x : j.at("variants"))
      if (x.at("name") == variant) v = x;
    ASSERT_FALSE(v.is_null()) << variant;
    ASSERT_TRUE(v["psnr"].is_number() && v["ssim"].is_number()) << v.dump();
    const double g = v["gaussians"].get<double>(), psnr = v["psnr"].get<double>(), ssim = v["ssim"].get<double>();
    EXPECT_GT(g, 0);
    EXPECT_TRUE(std::isfinite(psnr) && std::isfinite(ssim));
    EXPECT_TRUE(v["lpips"].is_null());  // no --lpips-weights
    const std::vector<std::string> row = row_cells(table, label);
    ASSERT_EQ(row.size(), 8u) << label << "\n" << table;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(row[size_t(k)], "–") << "female-3-casual was not run";
    EXPECT_EQ(row[4].back(), 'k');
    EXPECT_NEAR(cell_number(row[4]), g / 1000, 0.0051);
    EXPECT_NEAR(cell_number(row[5]), psnr, 0.0051);
    EXPECT_NEAR(cell_number(row[6]), ssim, 0.000051);
    EXPECT_EQ(row[7], "n/a");
    const std::vector<std::string> mean = row_cells(table, label, 2);  // pair tables, then the mean
    ASSERT_EQ(mean.size(), 4u) << table;
    EXPECT_NEAR(cell_number(mean[1]), psnr, 0.0051);
  }
  // The published rows, each marked with its source.
  const std::vector<std::string> ref = row_cells(table, "3DGS-Avatar [paper]");
  ASSERT_EQ(ref.size(), 8u) << table;
  EXPECT_EQ(ref[4], "37.22k");
  EXPECT_EQ(ref[5], "34.28");
  for (const char* m : {"GART [paper]", "GaussianAvatar [paper]", "HAHA (authors) [paper]"})
    EXPECT_EQ(row_cells(table, m).size(), 8u) << m;
  EXPECT_EQ(row_cells(table, "HAHA (authors) [paper]")[5], "31.46");
  EXPECT_NE(table.find("3DGS-Avatar 32.06 dB"), std::string::npos) << table;

  // Again: the finished subject is skipped, its eval json untouched, the table rewritten.
  const std::string before = slurp(ev);
  const auto mtime = fs::last_write_time(ev);
  ASSERT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 0) << slurp(dir / "e.txt");
  const std::string o = slurp(dir / "o.txt");
  EXPECT_NE(o.find("male-3-casual/eval.json exists: skipped"), std::string::npos) << o;
  EXPECT_EQ(o.find("haha train"), std::string::npos) << o;
  EXPECT_EQ(slurp(ev), before);
  EXPECT_EQ(fs::last_write_time(ev), mtime);
  EXPECT_EQ(slurp(out / "table.md"), table);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
