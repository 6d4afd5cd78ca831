// `haha fit-video`'s run and its focal length (fit/fit_video_focal.h): the run hands the
// chosen focal to the fit, and a bad --focal-35mm is one line.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>

#include "app/fit_video_run.h"
#include "core/error.h"
#include "core/subprocess.h"
#include "fit/fit_video_focal.h"
#include "support/data_test_util.h"
#include "support/exif_jpeg.h"
#include "support/stand_in_keypoint_tool.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

using FitVideoFocalRun = testutil::TempDirTest;

// The run hands the chosen focal to the fit (a stand-in keypoint tool that finds nobody; the
// fitter records the focal and stops the run).
TEST_F(FitVideoFocalRun, RunUsesTheRecordedFocalUnlessAFlagBeatsIt) {
  if (!program_on_path("node")) GTEST_SKIP() << "node is not installed";
  test::write_stand_in_keypoint_tool(
      path("tool"),
      "import fs from 'fs'; import path from 'path';\n"
      "const [inDir, outDir] = process.argv.slice(2, 4);\n"
      "fs.mkdirSync(path.join(outDir, 'keypoints'), {recursive: true});\n"
      "for (const f of fs.readdirSync(inDir)) fs.writeFileSync(path.join(outDir, 'keypoints', f.replace('.png', '.json')),\n"
      "  JSON.stringify({format: 'haha-keypoints', version: 1, frame: f, width: 40, height: 30, people: 0, score: 0,\n"
      "                  body: null, body_world: null, left_hand: null, right_hand: null, mask: null, model: 'none'}));\n");
  ::setenv("HAHA_KEYPOINTS_TOOL", path("tool").c_str(), 1);
  fs::create_directories(path("in"));
  test::write_exif_jpeg(path("in/000.jpg"), 40, 30, 26);
  test::write_exif_jpeg(path("in/001.jpg"), 40, 30, 26);
  auto focal_seen = [&](FitVideoRunOptions o) {
    o.input = path("in");
    o.out = path("out");
    o.progress = false;
    double seen = 0;
    try {
      run_fit_video(o, BodyModel{}, [&](const std::vector<FitVideoInputFrame>&, const FitVideoOptions& vo) -> FitVideoResult {
        seen = vo.focal_px;
        throw Error("stop");
      });
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), "stop");
    }
    return seen;
  };
  FitVideoRunOptions o;
  EXPECT_NEAR(focal_seen(o), focal_px_from_35mm(26, 40, 30), 1e-3);  // EXIF
  o.fov_deg = 90, o.fov_given = true;
  EXPECT_NEAR(focal_seen(o), 20, 1e-3);  // a given --fov beats the record
  o = FitVideoRunOptions{};
  o.focal_35mm = 50;
  EXPECT_NEAR(focal_seen(o), focal_px_from_35mm(50, 40, 30), 1e-3);
  o = FitVideoRunOptions{};
  o.focal_px = 77;
  EXPECT_NEAR(focal_seen(o), 77, 1e-3);
  ::unsetenv("HAHA_KEYPOINTS_TOOL");
}

TEST(FitVideoFocal, BadFocal35mmIsOneLine) {
  FitVideoRunOptions o;
  o.input = "in";
  o.out = "out-that-does-not-exist";
  for (double mm : {-1.0, 1.0, 5000.0, double(NAN)}) {
    o.focal_35mm = mm;
    test::expect_error_at("--focal-35mm", [&] { validate_fit_video_options(o); }, {"35 mm-equivalent"});
  }
  o.focal_35mm = 26;
  o.focal_px = 500;
  test::expect_error_at("--focal-35mm", [&] { validate_fit_video_options(o); }, {"not both"});
}

}  // namespace
}  // namespace haha
