// The focal length of `haha fit-video` (fit/fit_video_focal.h): the 35 mm-equivalent
// conversion, metadata parsing, what a video's tag and an image's EXIF record, the order of
// precedence. That the run hands the chosen focal to the fit: tests/app/fit_video_focal_run_test.cpp.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "fit/fit_video_focal.h"
#include "core/subprocess.h"
#include "core/error.h"
#include "io/image.h"
#include "support/data_test_util.h"
#include "support/exif_jpeg.h"

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
  std::string jpeg(const std::string& name, int w, int h, int mm) {
    const std::string p = path(name);
    test::write_exif_jpeg(p, w, h, mm);
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

}  // namespace
}  // namespace haha
