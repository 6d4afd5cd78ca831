// The focal length of `haha fit-video` (app/fit_video_focal.h): the 35 mm-equivalent
// conversion, metadata parsing, what a video's tag and an image's EXIF record, the order of
// precedence, and that the run hands the chosen focal to the fit.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "app/fit_video_focal.h"
#include "app/fit_video_run.h"
#include "app/subprocess.h"
#include "core/error.h"
#include "io/image.h"
#include "support/data_test_util.h"
#include "support/stand_in_keypoint_tool.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

TEST(FitVideoFocal, ThirtyFiveMillimetreEquivalentIsOnTheFrameDiagonal) {
  // A 3:2 frame is the 36 x 24 mm frame itself: 36 mm across 3600 px is 3600 px.
  EXPECT_NEAR(focal_px_from_35mm(36, 3600, 2400), 3600, 1e-9);
  EXPECT_NEAR(focal_px_from_35mm(18, 2400, 3600), 1800, 1e-9);  // portrait: the same diagonal
  // 26 mm on a 1920 x 1080 video: 26 x 2202.9 / 43.267.
  EXPECT_NEAR(focal_px_from_35mm(26, 1920, 1080), 26 * std::hypot(1920.0, 1080.0) / 43.26661530556787, 1e-9);
  EXPECT_NEAR(focal_px_from_fov(90, 512), 256, 1e-9);
  EXPECT_NEAR(focal_px_from_fov(55, 512), 491.77, 0.01);  // the default guess on the test video
}

TEST(FitVideoFocal, MetadataValuesParse) {
  EXPECT_EQ(parse_focal_35mm("26"), 26.0);
  EXPECT_EQ(parse_focal_35mm("50.00mm"), 50.0);
  EXPECT_EQ(parse_focal_35mm(" 27 mm "), 27.0);
  EXPECT_EQ(parse_focal_35mm("13MM"), 13.0);
  for (const char* bad : {"", "mm", "abc", "-26", "0", "3", "1e3", "26.5.1", "2500", "26 mm f/1.6", "nan", "inf"})
    EXPECT_FALSE(parse_focal_35mm(bad).has_value()) << bad;
}

TEST(FitVideoFocal, PrecedenceFocalThen35mmThenFovThenRecordThenGuess) {
  RecordedFocal rec{true, "26", "the video's tag"};
  const double exif_px = focal_px_from_35mm(26, 640, 480);
  EXPECT_EQ(choose_focal(700, 0, 55, false, rec, 640, 480).focal_px, 700);
  EXPECT_NEAR(choose_focal(0, 35, 55, true, rec, 640, 480).focal_px, focal_px_from_35mm(35, 640, 480), 1e-9);
  EXPECT_NEAR(choose_focal(0, 0, 70, true, rec, 640, 480).focal_px, focal_px_from_fov(70, 640), 1e-9);
  const FocalChoice from_record = choose_focal(0, 0, 55, false, rec, 640, 480);
  EXPECT_NEAR(from_record.focal_px, exif_px, 1e-9);
  EXPECT_NE(from_record.source.find("26.0 mm"), std::string::npos) << from_record.source;
  EXPECT_NE(from_record.source.find("the video's tag"), std::string::npos) << from_record.source;
  const FocalChoice guess = choose_focal(0, 0, 55, false, RecordedFocal{}, 640, 480);
  EXPECT_NEAR(guess.focal_px, focal_px_from_fov(55, 640), 1e-9);
  EXPECT_NE(guess.source.find("guess"), std::string::npos) << guess.source;
  // A record that is no focal length is said to be ignored, never used.
  const FocalChoice bad = choose_focal(0, 0, 55, false, RecordedFocal{true, "iPhone back camera", "the tag"}, 640, 480);
  EXPECT_NEAR(bad.focal_px, focal_px_from_fov(55, 640), 1e-9);
  EXPECT_NE(bad.source.find("ignored"), std::string::npos) << bad.source;
}

class FitVideoFocalFiles : public testutil::TempDirTest {
 protected:
  // A w x h JPEG, with EXIF FocalLengthIn35mmFilm when mm > 0.
  std::string jpeg(const std::string& name, int w, int h, int mm) {
    const std::string p = path(name);
    auto out = OIIO::ImageOutput::create(p);
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
    if (mm > 0) spec.attribute("Exif:FocalLengthIn35mmFilm", mm);
    std::vector<unsigned char> px(size_t(w) * h * 3, 128);
    EXPECT_TRUE(out && out->open(p, spec) && out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close());
    return p;
  }
  bool have_ffmpeg() { return program_on_path("ffmpeg") && program_on_path("ffprobe"); }
  // A 3-frame video; `tag` non-empty: the iPhone focal tag with that value.
  std::string video(const std::string& name, const std::string& tag) {
    const std::string p = path(name);
    std::string log;
    const std::string meta =
        tag.empty() ? "" : " -movflags use_metadata_tags -metadata com.apple.quicktime.camera.focal_length.35mm_equivalent=" +
                               shell_quoted(tag);
    EXPECT_EQ(run_capture("ffmpeg -nostdin -v error -f lavfi -i testsrc=size=64x48:rate=5 -frames:v 3" + meta + " " +
                              shell_quoted(p),
                          log),
              0)
        << log;
    return p;
  }
};

TEST_F(FitVideoFocalFiles, ExifFocalOfAnImage) {
  const RecordedFocal with = image_recorded_focal(jpeg("a.jpg", 32, 24, 26));
  EXPECT_TRUE(with.found);
  EXPECT_EQ(with.text, "26");
  EXPECT_NE(with.where.find("a.jpg"), std::string::npos);
  EXPECT_FALSE(image_recorded_focal(jpeg("b.jpg", 32, 24, 0)).found);
}

TEST_F(FitVideoFocalFiles, TagOfAVideo) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  const RecordedFocal with = video_recorded_focal(video("tagged.mov", "26"));
  EXPECT_TRUE(with.found);
  EXPECT_EQ(with.text, "26");
  EXPECT_FALSE(video_recorded_focal(video("plain.mp4", "")).found);
}

// The run hands the chosen focal to the fit (a stand-in keypoint tool that finds nobody; the
// fitter records the focal and stops the run).
TEST_F(FitVideoFocalFiles, RunUsesTheRecordedFocalUnlessAFlagBeatsIt) {
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
  jpeg("in/000.jpg", 40, 30, 26);
  jpeg("in/001.jpg", 40, 30, 26);
  auto focal_seen = [&](FitVideoOptions o) {
    o.input = path("in");
    o.out = path("out");
    o.progress = false;
    double seen = 0;
    try {
      run_fit_video(o, BodyModel{}, [&](const std::vector<VideoFitInputFrame>&, const VideoFitOptions& vo) -> VideoFitResult {
        seen = vo.focal_px;
        throw Error("stop");
      });
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), "stop");
    }
    return seen;
  };
  FitVideoOptions o;
  EXPECT_NEAR(focal_seen(o), focal_px_from_35mm(26, 40, 30), 1e-3);  // EXIF
  o.fov_deg = 90, o.fov_given = true;
  EXPECT_NEAR(focal_seen(o), 20, 1e-3);  // a given --fov beats the record
  o = FitVideoOptions{};
  o.focal_35mm = 50;
  EXPECT_NEAR(focal_seen(o), focal_px_from_35mm(50, 40, 30), 1e-3);
  o = FitVideoOptions{};
  o.focal_px = 77;
  EXPECT_NEAR(focal_seen(o), 77, 1e-3);
  ::unsetenv("HAHA_KEYPOINTS_TOOL");
}

TEST(FitVideoFocal, BadFocal35mmIsOneLine) {
  FitVideoOptions o;
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
