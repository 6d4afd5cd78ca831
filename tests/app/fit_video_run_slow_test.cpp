// `haha fit-video` end to end on `haha synth` frames with the real keypoint tool and an
// ORACLE fitter (tests/support/fit_video_oracle.h: the true parameters, no fitting): a
// folder of frames and an ffmpeg-encoded mp4 become datasets that read_dataset accepts,
// with the oracle's parameters, the tool's masks, the split, the report and the contact
// sheet; dropped frames are absent from the dataset and marked; a run where every frame is
// dropped fails and leaves the previous output as it was. Skips, with the reason, where
// Node, the tool's node_modules or ffmpeg are missing.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "app/fit_video_run.h"
#include "fit/fit_video_truth.h"
#include "app/keypoint_tool.h"
#include "core/subprocess.h"
#include "body/procedural_body.h"
#include "core/atomic_file.h"
#include "data/synth_dataset.h"
#include "support/data_test_util.h"
#include "support/fit_video_oracle.h"
#include "support/low_body.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using testutil::expect_error;

using test::low_body;

// Pure red pixels (the dropped-frame border) in an 8-bit image.
int red_pixels(const Image& img) {
  int n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      n += img.at(x, y, 0) == 1.0f && std::abs(img.at(x, y, 1) - 26 / 255.0f) < 1e-6f &&
           std::abs(img.at(x, y, 2) - 26 / 255.0f) < 1e-6f;
  return n;
}

void expect_same_params(const SmplxParams& a, const SmplxParams& b, const std::string& what) {
  EXPECT_EQ(a.pose, b.pose) << what;
  EXPECT_EQ(a.betas, b.betas) << what;
  for (int k = 0; k < 3; ++k) EXPECT_EQ(a.transl[k], b.transl[k]) << what;
}

class FitVideoSlowTest : public testutil::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    try {
      check_keypoint_tool(find_keypoint_tool());
    } catch (const Error& e) {
      GTEST_SKIP() << "keypoint tool not run: " << e.what();
    }
    // Four frames of the turning subject, 128 px (the tool finds the person at this size).
    SynthOptions o;
    o.size = 128;
    o.train_frames = 4;
    o.test_frames = 0;
    o.supersample = 2;
    write_synth_dataset(path("synth"), low_body(), o, false);
    truth_ = read_dataset(path("synth"));
  }
  FitVideoRunOptions options(const std::string& input) {
    FitVideoRunOptions o;
    o.input = input;
    o.out = path("out");
    o.progress = true;  // the stage lines and the tool's progress show in the test log
    return o;
  }
  Dataset truth_;
};

TEST_F(FitVideoSlowTest, FolderOfFramesBecomesADatasetWithTheOraclesParameters) {
  test::OracleFitter oracle{&truth_, {0, 1, 2, 3}, {}};
  FitVideoRunOptions o = options(path("synth/images"));
  o.test_every = 2;
  o.focal_px = 321;
  o.save_body = true;
  o.truth = path("synth");  // no body_model.npz there: the true fits are posed with low_body()
  o.crop = false;           // the frames and the tool's masks as they are (the crop and the
  o.matting = "off";        // matting: fit_video_run_test.cpp)
  const FitVideoSummary s = run_fit_video(o, low_body(), std::cref(oracle));
  EXPECT_EQ(oracle.calls, 1);
  EXPECT_EQ(oracle.seen.focal_px, 321);
  EXPECT_EQ(s.kept, 4);
  EXPECT_EQ(s.dropped, 0);
  EXPECT_EQ(s.train, 2);
  EXPECT_EQ(s.test, 2);

  const Dataset ds = read_dataset(path("out"));
  ASSERT_EQ(ds.frames.size(), 4u);
  EXPECT_EQ(ds.width, 128);
  EXPECT_EQ(ds.fps, 30);
  EXPECT_EQ(ds.premultiplied, 0);
  EXPECT_NE(ds.source.find("haha fit-video: images"), std::string::npos) << ds.source;
  EXPECT_TRUE(ds.params_true.empty());
  for (int i = 0; i < 4; ++i) {
    const DatasetFrame& f = ds.frames[size_t(i)];
    expect_same_params(f.params, truth_.frames[size_t(i)].params, "frame " + std::to_string(i));
    EXPECT_EQ(f.split, i % 2 ? Split::test : Split::train) << i;
    EXPECT_EQ(f.source_index, i);
    EXPECT_EQ(f.camera.fx, truth_.frames[0].camera.fx);
    EXPECT_EQ(f.image.data, truth_.frames[size_t(i)].image.data) << "frame " << i << ": pixels changed";
    char name[32];
    std::snprintf(name, sizeof name, "%06d.png", i);
    EXPECT_EQ(f.mask.data, read_image(path("out/work/keypoints/masks/") + name).data) << "the tool's mask, frame " << i;
  }
  EXPECT_TRUE(fs::is_regular_file(path("out/body_model.npz")));
  EXPECT_EQ(std::distance(fs::directory_iterator(path("out/work/frames")), fs::directory_iterator()), 4);

  const auto j = nlohmann::json::parse(read_text_file(path("out/fit_report.json")));
  ASSERT_EQ(j["frames"].size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(j["frames"][i]["kept"], true);
    EXPECT_EQ(j["frames"][i]["dataset_frame"], i);
    EXPECT_DOUBLE_EQ(j["frames"][i]["reprojection_px"].get<double>(), test::OracleFitter::reprojection(i));
    EXPECT_DOUBLE_EQ(j["frames"][i]["silhouette_iou"].get<double>(), test::OracleFitter::iou(i));
    // The oracle's parameters are the dataset's fits: their error against the true fits.
    const Lbs<double> lbs(low_body());
    const double pa = body_joint_pa_error_mm(lbs, truth_.frames[size_t(i)].params, lbs,
                                             truth_.params_true.empty() ? truth_.frames[size_t(i)].params
                                                                        : truth_.params_true[size_t(i)]);
    EXPECT_NEAR(j["frames"][i]["joint_error_mm"].get<double>(), pa, 1e-6) << i;
  }
  EXPECT_EQ(j["truth"], path("synth"));
  EXPECT_TRUE(j["mean_joint_error_mm"].is_number());
  EXPECT_NE(read_text_file(path("out/fit_report.txt")).find("000003.png"), std::string::npos);
  const Image sheet = read_image(path("out/fit_contact_sheet.png"));
  EXPECT_GT(sheet.width, 4 * 128);
  EXPECT_EQ(red_pixels(sheet), 0) << "no frame was dropped";
  EXPECT_TRUE(leftovers().empty());
}

TEST_F(FitVideoSlowTest, Mp4WithDroppedFramesAndAFailedRerun) {
  if (!program_on_path("ffmpeg")) GTEST_SKIP() << "ffmpeg is not installed";
  std::string log;
  ASSERT_EQ(run_capture("ffmpeg -nostdin -v error -framerate 10 -i " + shell_quoted(path("synth/images/%06d.png")) +
                            " -c:v libx264 -pix_fmt yuv420p -crf 12 " + shell_quoted(path("clip.mp4")),
                        log),
            0)
      << log;
  // --frames 1: keeps source frames 1, 2, 3; the oracle drops the second of them (source 2).
  test::OracleFitter oracle{&truth_, {1, 2, 3}, {1}};
  FitVideoRunOptions o = options(path("clip.mp4"));
  o.frames = "1:";
  const FitVideoSummary s = run_fit_video(o, low_body(), std::cref(oracle));
  EXPECT_EQ(s.decoded, 4);
  EXPECT_EQ(s.kept, 2);
  EXPECT_EQ(s.dropped, 1);
  EXPECT_NEAR(s.fps, 10, 1e-9);

  const Dataset ds = read_dataset(path("out"));
  ASSERT_EQ(ds.frames.size(), 2u);
  EXPECT_EQ(ds.frames[0].source_index, 1);
  EXPECT_EQ(ds.frames[1].source_index, 3);
  expect_same_params(ds.frames[0].params, truth_.frames[1].params, "kept frame 0");
  expect_same_params(ds.frames[1].params, truth_.frames[3].params, "kept frame 1");
  EXPECT_NE(ds.source.find("clip.mp4"), std::string::npos) << ds.source;

  const auto j = nlohmann::json::parse(read_text_file(path("out/fit_report.json")));
  ASSERT_EQ(j["frames"].size(), 3u);
  EXPECT_EQ(j["frames"][1]["frame"], "frame 2");
  EXPECT_EQ(j["frames"][1]["kept"], false);
  EXPECT_EQ(j["frames"][1]["reason"], "oracle says drop");
  EXPECT_TRUE(j["frames"][1]["dataset_frame"].is_null());
  EXPECT_EQ(j["frames"][2]["dataset_frame"], 1);
  const std::string table = read_text_file(path("out/fit_report.txt"));
  EXPECT_NE(table.find("dropped"), std::string::npos) << table;
  EXPECT_NE(table.find("oracle says drop"), std::string::npos) << table;
  // The dropped frame's tile has its red border: a ring of at least 3 px around the shrunk tile.
  EXPECT_GT(red_pixels(read_image(path("out/fit_contact_sheet.png"))), 4 * 3 * 100);

  // A rerun where the fit keeps nothing fails and leaves the previous dataset as it was.
  const std::string before = read_text_file(path("out/dataset.json"));
  test::OracleFitter none{&truth_, {1, 2, 3}, {0, 1, 2}};
  expect_error([&] { run_fit_video(o, low_body(), std::cref(none)); }, "no frame could be fitted");
  EXPECT_EQ(read_text_file(path("out/dataset.json")), before);
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find("out."), std::string::npos) << "left behind: " << e.path();
  EXPECT_TRUE(leftovers().empty());
}

}  // namespace
}  // namespace haha
