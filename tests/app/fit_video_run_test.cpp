// `haha fit-video` plumbing without the keypoint models: --frames parsing, video decoding
// with ffmpeg (count, size, --fps resampling), bad inputs (one error line, nothing left in
// OUT), the report and the contact-sheet overlay, the crop and the matting (a stand-in tool
// hands over prepared masks, a stand-in fitter places the body). The full run on `haha synth` frames with
// the keypoint tool is in fit_video_run_slow_test.cpp.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "fit/fit_video_crop.h"
#include "app/fit_video_input.h"
#include "fit/fit_video_report.h"
#include "app/fit_video_run.h"
#include "app/keypoint_tool.h"
#include "core/subprocess.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "core/atomic_file.h"
#include "core/interrupt.h"
#include "train/config.h"
#include "render/mesh_raster.h"
#include "support/data_test_util.h"
#include "support/low_body.h"
#include "support/stand_in_keypoint_tool.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using test::expect_error_at;
using testutil::expect_error;

// A smooth picture (lossy video codecs keep it) that moves with the frame.
Image smooth_frame(int w, int h, int frame) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.at(x, y, c) = float(0.5 + 0.4 * std::sin(0.15 * x + 0.1 * y + 0.9 * frame + 2.0 * c));
  return img;
}

double mean_abs_diff(const Image& a, const Image& b) {
  double e = 0;
  for (size_t k = 0; k < a.data.size(); ++k) e += std::abs(a.data[k] - b.data[k]);
  return e / double(a.data.size());
}

// Sets an environment variable for one scope, then restores it.
struct ScopedEnv {
  std::string name, old;
  bool had = false;
  ScopedEnv(const std::string& n, const std::string& v) : name(n) {
    if (const char* o = std::getenv(n.c_str())) had = true, old = o;
    ::setenv(n.c_str(), v.c_str(), 1);
  }
  ~ScopedEnv() {
    if (had) ::setenv(name.c_str(), old.c_str(), 1);
    else ::unsetenv(name.c_str());
  }
};

FitVideoResult never_called(const std::vector<FitVideoInputFrame>&, const FitVideoOptions&) {
  ADD_FAILURE() << "the fit must not run on bad input";
  return {};
}

class FitVideoRunTest : public testutil::TempDirTest {
 protected:
  // n frames of w x h as PNGs in DIR.
  std::string image_folder(const std::string& name, int n, int w, int h) {
    const std::string dir = path(name);
    fs::create_directories(dir);
    for (int i = 0; i < n; ++i) {
      char f[32];
      std::snprintf(f, sizeof f, "img_%03d.png", i);
      write_image((fs::path(dir) / f).string(), smooth_frame(w, h, i));
    }
    return dir;
  }
  // The same frames encoded as an H.264 mp4 at `rate` fps.
  std::string encode_mp4(const std::string& folder, double rate) {
    const std::string mp4 = path("clip.mp4");
    std::string log;
    const int st = run_capture("ffmpeg -nostdin -v error -framerate " + std::to_string(rate) + " -i " +
                                   shell_quoted(folder + "/img_%03d.png") + " -c:v libx264 -pix_fmt yuv420p " +
                                   shell_quoted(mp4),
                               log);
    EXPECT_EQ(st, 0) << log;
    return mp4;
  }
  // Nothing named OUT or OUT.* is left beside OUT.
  void expect_nothing_written(const std::string& out) {
    EXPECT_FALSE(fs::exists(out)) << out;
    const std::string stem = fs::path(out).filename().string();
    for (const auto& e : fs::directory_iterator(fs::path(out).parent_path()))
      EXPECT_NE(e.path().filename().string().rfind(stem + ".", 0), 0u) << "left behind: " << e.path();
  }
  FitVideoRunOptions options(const std::string& input) {
    FitVideoRunOptions o;
    o.input = input;
    o.out = path("out");
    o.progress = false;
    return o;
  }
  bool have_ffmpeg() { return program_on_path("ffmpeg") && program_on_path("ffprobe"); }
};

TEST_F(FitVideoRunTest, FrameRangeParsesAndSelects) {
  const FrameRange all = parse_frame_range("");
  EXPECT_EQ(select_frames(all, 4), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(select_frames(parse_frame_range("1:7:2"), 10), (std::vector<int>{1, 3, 5}));
  EXPECT_EQ(select_frames(parse_frame_range("2:"), 5), (std::vector<int>{2, 3, 4}));
  EXPECT_EQ(select_frames(parse_frame_range(":2"), 5), (std::vector<int>{0, 1}));
  EXPECT_EQ(select_frames(parse_frame_range("3"), 5), (std::vector<int>{3, 4}));
  EXPECT_EQ(select_frames(parse_frame_range("::3"), 7), (std::vector<int>{0, 3, 6}));
  EXPECT_EQ(select_frames(parse_frame_range("0:100"), 3), (std::vector<int>{0, 1, 2}));  // clipped at the end
  EXPECT_TRUE(select_frames(parse_frame_range("8:"), 5).empty());
  for (const char* bad : {"a:b", "5:2", "3:3", "0:4:0", "1:2:3:4", "-1:", "0:4:x"})
    expect_error_at("--frames", [&] { parse_frame_range(bad); }, {std::string("'") + bad + "'"});
}

TEST_F(FitVideoRunTest, FolderFramesAreSelectedAndRenumbered) {
  const std::string in = image_folder("in", 5, 40, 30);
  const InputFrames f = prepare_input_frames(in, path("work"), 0, parse_frame_range("1::2"), false);
  EXPECT_FALSE(f.is_video);
  EXPECT_EQ(f.decoded, 5);
  EXPECT_EQ(f.fps, 30);
  EXPECT_EQ(f.width, 40);
  EXPECT_EQ(f.height, 30);
  EXPECT_EQ(f.source_index, (std::vector<int>{1, 3}));
  EXPECT_EQ(f.names, (std::vector<std::string>{"img_001.png", "img_003.png"}));
  ASSERT_EQ(f.paths.size(), 2u);
  EXPECT_EQ(fs::path(f.paths[1]).filename(), "000001.png");
  const Image back = read_image(f.paths[1]);
  ASSERT_EQ(back.channels, 3);
  EXPECT_LT(mean_abs_diff(back, smooth_frame(40, 30, 3)), 0.5 / 255);  // PNG round trip: 8-bit rounding only
}

TEST_F(FitVideoRunTest, VideoDecodesToTheRightCountAndSize) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  const std::string mp4 = encode_mp4(image_folder("in", 6, 64, 48), 10);
  const InputFrames f = prepare_input_frames(mp4, path("work"), 0, {}, false);
  EXPECT_TRUE(f.is_video);
  EXPECT_EQ(f.decoded, 6);
  EXPECT_EQ(f.paths.size(), 6u);
  EXPECT_EQ(f.width, 64);
  EXPECT_EQ(f.height, 48);
  EXPECT_NEAR(f.fps, 10.0, 1e-6);
  EXPECT_EQ(f.names[2], "frame 2");
  // The decoded pixels are the encoded frame, in order (H.264 is lossy: closest, not equal).
  const Image got = read_image(f.paths[4]);
  EXPECT_LT(mean_abs_diff(got, smooth_frame(64, 48, 4)), 0.03);
  EXPECT_LT(mean_abs_diff(got, smooth_frame(64, 48, 4)), 0.5 * mean_abs_diff(got, smooth_frame(64, 48, 3)));
  EXPECT_FALSE(fs::exists(path("work/decoded")));

  // --fps 5 halves the frames; --frames applies after decoding.
  const InputFrames h = prepare_input_frames(mp4, path("work"), 5, parse_frame_range("1:"), false);
  EXPECT_EQ(h.decoded, 3);
  EXPECT_EQ(h.source_index, (std::vector<int>{1, 2}));
  EXPECT_NEAR(h.fps, 5.0, 1e-9);
  EXPECT_EQ(fs::path(h.paths[0]).filename(), "000000.png");
}

TEST_F(FitVideoRunTest, MissingInputIsOneLineAndNothingWritten) {
  const FitVideoRunOptions o = options(path("nope.mp4"));
  expect_error_at(o.input, [&] { run_fit_video(o, BodyModel{}, never_called); }, {"no such file or folder"});
  expect_nothing_written(o.out);
}

TEST_F(FitVideoRunTest, NonVideoFileIsOneLineAndNothingWritten) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  std::ofstream(path("notes.mp4")) << "this is not a video\n";
  const FitVideoRunOptions o = options(path("notes.mp4"));
  expect_error_at(o.input, [&] { run_fit_video(o, BodyModel{}, never_called); }, {"not a video ffmpeg can read"});
  expect_nothing_written(o.out);
}

TEST_F(FitVideoRunTest, EmptyFolderIsOneLineAndNothingWritten) {
  fs::create_directories(path("empty"));
  std::ofstream(path("empty/readme.txt")) << "no images here\n";
  const FitVideoRunOptions o = options(path("empty"));
  expect_error_at(o.input, [&] { run_fit_video(o, BodyModel{}, never_called); }, {"no .png or .jpg images"});
  expect_nothing_written(o.out);
}

TEST_F(FitVideoRunTest, MixedSizesAreOneLineAndNothingWritten) {
  const std::string in = image_folder("in", 3, 40, 30);
  write_image(path("in/img_002.png"), smooth_frame(32, 30, 2));
  const FitVideoRunOptions o = options(in);
  expect_error_at(path("in/img_002.png"), [&] { run_fit_video(o, BodyModel{}, never_called); },
                  {"32x30", "img_000.png is 40x30", "one size"});
  expect_nothing_written(o.out);
  // --frames that leaves out the odd image passes the check (and stops at the tool or later).
  EXPECT_EQ(prepare_input_frames(in, path("work"), 0, parse_frame_range(":2"), false).paths.size(), 2u);
}

TEST_F(FitVideoRunTest, MissingNodeSaysHowToInstallIt) {
  const std::string in = image_folder("in", 2, 40, 30);
  fs::create_directories(path("bin"));  // a PATH without node (nor anything else)
  const FitVideoRunOptions o = options(in);
  {
    ScopedEnv p("PATH", path("bin"));
    expect_error_at("node", [&] { run_fit_video(o, BodyModel{}, never_called); }, {"apt-get install nodejs npm"});
  }
  expect_nothing_written(o.out);
}

TEST_F(FitVideoRunTest, MissingFfmpegSaysHowToInstallIt) {
  std::ofstream(path("clip.mp4")) << "whatever\n";
  fs::create_directories(path("bin"));  // a PATH without ffmpeg
  const FitVideoRunOptions o = options(path("clip.mp4"));
  {
    ScopedEnv p("PATH", path("bin"));
    expect_error_at(o.input, [&] { run_fit_video(o, BodyModel{}, never_called); }, {"apt-get install ffmpeg"});
  }
  expect_nothing_written(o.out);
}

TEST_F(FitVideoRunTest, MissingToolPackagesSayHowToInstallThem) {
  if (!program_on_path("node")) GTEST_SKIP() << "node is not installed";
  const std::string in = image_folder("in", 2, 40, 30);
  fs::create_directories(path("tool"));
  std::ofstream(path("tool/keypoints.mjs")) << "process.exit(3);\n";
  const FitVideoRunOptions o = options(in);
  {
    ScopedEnv t("HAHA_KEYPOINTS_TOOL", path("tool"));
    EXPECT_EQ(find_keypoint_tool("elsewhere"), path("tool"));
    expect_error_at(path("tool/node_modules"), [&] { run_fit_video(o, BodyModel{}, never_called); },
                    {"scripts/setup-keypoints.sh"});
  }
  expect_nothing_written(o.out);
  {
    ScopedEnv t("HAHA_KEYPOINTS_TOOL", path("nowhere"));
    expect_error_at(path("nowhere/keypoints.mjs"), [&] { run_fit_video(o, BodyModel{}, never_called); },
                    {"HAHA_KEYPOINTS_TOOL"});
  }
  expect_nothing_written(o.out);
}

TEST_F(FitVideoRunTest, KeypointsFastRunsTheToolsSingleModelPath) {
  if (!program_on_path("node")) GTEST_SKIP() << "node is not installed";
  const std::string in = image_folder("in", 2, 40, 30);
  // A stand-in tool that records its arguments and fails with the tool's error line.
  test::write_stand_in_keypoint_tool(path("tool"),
                                     "import fs from 'fs';\n"
                                     "fs.writeFileSync(process.env.HAHA_TEST_ARGS, process.argv.slice(4).join(' '));\n"
                                     "console.error('keypoints: error: stand-in: stopped');\n"
                                     "process.exit(1);\n");
  ScopedEnv t("HAHA_KEYPOINTS_TOOL", path("tool")), a("HAHA_TEST_ARGS", path("args"));
  auto args = [&](const std::string& models) {
    FitVideoRunOptions o = options(in);
    o.keypoints = models;
    expect_error_at("stand-in", [&] { run_fit_video(o, BodyModel{}, never_called); }, {"stopped"});
    expect_nothing_written(o.out);
    return read_text_file(path("args"));
  };
  EXPECT_EQ(args("fast"), "--mask pose --flip off --movenet off");
  EXPECT_EQ(args("accurate"), "--mask pose");  // the tool's defaults: flip test and MoveNet on
}

TEST(FitVideoSplit, EveryNthKeptFrameAndTheHeldOutEnd) {
  FitVideoRunOptions o;
  for (int k = 0; k < 6; ++k) EXPECT_EQ(fit_video_split(o, k, 10 * k), Split::train) << k;
  o.test_every = 3;  // the 3rd, 6th, ... kept frame
  for (int k = 0; k < 6; ++k) EXPECT_EQ(fit_video_split(o, k, 0), k % 3 == 2 ? Split::test : Split::train) << k;
  o.test_every = 0;
  o.test_from = 40;  // by decoded frame number, not by kept order
  EXPECT_EQ(fit_video_split(o, 3, 39), Split::train);
  EXPECT_EQ(fit_video_split(o, 3, 40), Split::test);
  EXPECT_EQ(fit_video_split(o, 0, 45), Split::test);
  o.test_every = 2;  // both: either makes a test frame
  EXPECT_EQ(fit_video_split(o, 1, 5), Split::test);
  EXPECT_EQ(fit_video_split(o, 0, 5), Split::train);
  EXPECT_EQ(fit_video_split(o, 0, 41), Split::test);
}

TEST_F(FitVideoRunTest, SigintWhileTheKeypointToolRunsIsOneLineAndLeavesNothing) {
  if (!program_on_path("node")) GTEST_SKIP() << "node is not installed";
  const std::string in = image_folder("in", 2, 40, 30);
  // A stand-in tool that says it started and then hangs (the real one takes ~1 s a frame).
  test::write_stand_in_keypoint_tool(path("tool"),
                                     "import fs from 'fs';\n"
                                     "fs.writeFileSync(process.env.HAHA_TEST_STARTED, 'started');\n"
                                     "setTimeout(() => {}, 60000);\n");
  ScopedEnv t("HAHA_KEYPOINTS_TOOL", path("tool")), m("HAHA_TEST_STARTED", path("started"));
  install_interrupt_handler();
  clear_interrupt();
  std::thread ctrl_c([&] {  // Ctrl-C once the tool runs (the terminal would signal node too)
    for (int i = 0; i < 1000 && !fs::exists(path("started")); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ::kill(::getpid(), SIGINT);
  });
  const FitVideoRunOptions o = options(in);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    run_fit_video(o, BodyModel{}, never_called);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "interrupted");
  }
  ctrl_c.join();
  EXPECT_TRUE(fs::exists(path("started")));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10.0)
      << "the tool was not stopped";
  clear_interrupt();
  expect_nothing_written(o.out);
}

TEST_F(FitVideoRunTest, BadOptionsAreOneLine) {
  const std::string in = image_folder("in", 1, 16, 16);
  auto bad = [&](const char* where, auto edit) {
    FitVideoRunOptions o = options(in);
    edit(o);
    expect_error_at(where, [&] { validate_fit_video_options(o); }, {});
  };
  bad("--keypoints", [](FitVideoRunOptions& o) { o.keypoints = "heavy"; });
  bad("--fps", [](FitVideoRunOptions& o) { o.fps = -1; });
  bad("--fps", [](FitVideoRunOptions& o) { o.fps = NAN; });
  bad("--focal", [](FitVideoRunOptions& o) { o.focal_px = -5; });
  bad("--fov", [](FitVideoRunOptions& o) { o.fov_deg = 180; });
  bad("--test-every", [](FitVideoRunOptions& o) { o.test_every = 1; });
  bad("--test-from", [](FitVideoRunOptions& o) { o.test_from = -3; });
  bad("--robust-smoothness", [](FitVideoRunOptions& o) { o.robust_smoothness = -0.1; });
  bad("--robust-smoothness", [](FitVideoRunOptions& o) { o.robust_smoothness = NAN; });
  bad("--mask", [](FitVideoRunOptions& o) { o.mask = "rvm"; });
  bad("--frames", [](FitVideoRunOptions& o) { o.frames = "4:2"; });
  bad("--out", [](FitVideoRunOptions& o) { o.out = ""; });
  bad("--out", [&](FitVideoRunOptions& o) { o.out = in + "/"; });
  // An OUT that holds something else is never replaced.
  std::ofstream(path("precious.txt")) << "keep\n";
  fs::create_directories(path("other"));
  std::ofstream(path("other/precious.txt")) << "keep\n";
  bad(path("other").c_str(), [&](FitVideoRunOptions& o) { o.out = path("other"); });
  bad(path("precious.txt").c_str(), [&](FitVideoRunOptions& o) { o.out = path("precious.txt"); });
}

FitVideoSummary two_frame_summary() {
  FitVideoSummary s;
  s.input = "clip.mp4";
  s.out = "ds";
  s.decoded = 2;
  s.frames.resize(2);
  s.frames[0].name = "frame 0";
  s.frames[0].reprojection_px = 2.5;
  s.frames[0].silhouette_iou = 0.8;
  s.frames[0].dataset_frame = 0;
  s.frames[1].name = "frame 1";
  s.frames[1].source_index = 1;
  s.frames[1].dropped = true;
  s.frames[1].reason = "nobody in the frame";
  s.frames[1].reprojection_px = NAN;
  s.frames[1].silhouette_iou = NAN;
  s.kept = s.dropped = s.train = 1;
  summarize_fit(s);
  return s;
}

TEST_F(FitVideoRunTest, ReportNamesEveryFrameAndWhyItWasDropped) {
  const FitVideoSummary s = two_frame_summary();
  EXPECT_DOUBLE_EQ(s.mean_reprojection_px, 2.5);  // the dropped frame does not count
  const auto j = nlohmann::json::parse(fit_report_json(s));
  EXPECT_EQ(j["format"], "haha-fit-report");
  ASSERT_EQ(j["frames"].size(), 2u);
  EXPECT_EQ(j["frames"][0]["kept"], true);
  EXPECT_EQ(j["frames"][0]["split"], "train");
  EXPECT_DOUBLE_EQ(j["frames"][0]["reprojection_px"].get<double>(), 2.5);
  EXPECT_EQ(j["frames"][1]["kept"], false);
  EXPECT_EQ(j["frames"][1]["reason"], "nobody in the frame");
  EXPECT_TRUE(j["frames"][1]["reprojection_px"].is_null());
  EXPECT_TRUE(j["frames"][1]["dataset_frame"].is_null());
  const std::string table = fit_report_table(s);
  EXPECT_NE(table.find("\nframe 1       1  dropped        -       -       -  nobody in the frame\n"), std::string::npos)
      << table;
  EXPECT_NE(table.find("\nframe 0       0  train          0    2.50   0.800\n"), std::string::npos) << table;
  EXPECT_NE(table.find("nobody in the frame"), std::string::npos) << table;
  EXPECT_NE(table.find("2.50"), std::string::npos) << table;
  EXPECT_EQ(sheet_label(s.frames[1]), "frame 1 DROP: nobody in the frame");
  EXPECT_EQ(sheet_label(s.frames[0]), "frame 0 2.5PX IOU0.80");
}

TEST_F(FitVideoRunTest, ReportSaysWhereTheFocalLengthCameFrom) {
  FitVideoSummary s = two_frame_summary();
  s.camera.fx = s.camera.fy = 700;
  s.focal_source = "26.0 mm (35 mm equivalent) from EXIF FocalLengthIn35mmFilm of a.jpg";
  EXPECT_EQ(nlohmann::json::parse(fit_report_json(s))["focal_source"], s.focal_source);
  const std::string table = fit_report_table(s);
  EXPECT_NE(table.find("\nfocal length 700.0 px: " + s.focal_source + "\n"), std::string::npos) << table;
}

TEST_F(FitVideoRunTest, ReportWithTruthAddsTheJointErrorColumnAndMean) {
  FitVideoSummary s = two_frame_summary();
  EXPECT_EQ(fit_report_table(s).find("PA"), std::string::npos);  // no --truth: no column
  s.truth = "synth";
  s.frames[0].joint_error_mm = 31.25;
  s.frames[0].orient_error_deg = 7.5;
  summarize_fit(s);
  EXPECT_DOUBLE_EQ(s.mean_joint_error_mm, 31.25);
  EXPECT_DOUBLE_EQ(s.mean_orient_error_deg, 7.5);
  const auto j = nlohmann::json::parse(fit_report_json(s));
  EXPECT_EQ(j["truth"], "synth");
  EXPECT_DOUBLE_EQ(j["mean_joint_error_mm"].get<double>(), 31.25);
  EXPECT_DOUBLE_EQ(j["frames"][0]["joint_error_mm"].get<double>(), 31.25);
  EXPECT_TRUE(j["frames"][1]["joint_error_mm"].is_null());
  EXPECT_DOUBLE_EQ(j["mean_orient_error_deg"].get<double>(), 7.5);
  EXPECT_DOUBLE_EQ(j["frames"][0]["orient_error_deg"].get<double>(), 7.5);
  EXPECT_TRUE(j["frames"][1]["orient_error_deg"].is_null());
  const std::string table = fit_report_table(s);
  EXPECT_NE(table.find("mean body-joint error after Procrustes 31.2 mm (PA-MPJPE), orientation 7.5 deg, "
                       "against synth\n\n"),
            std::string::npos) << table;
  EXPECT_NE(table.find("\nframe 0       0  train          0    2.50   0.800   31.2      7.5\n"), std::string::npos)
      << table;
  EXPECT_NE(table.find("\nframe 1       1  dropped        -       -       -      -        -  nobody in the frame\n"),
            std::string::npos) << table;
}

TEST_F(FitVideoRunTest, SheetShowsEveryDroppedFrame) {
  std::vector<FitVideoFrameRow> rows(100);
  rows[37].dropped = rows[38].dropped = true;
  const std::vector<int> pick = sheet_frames(rows, 10);
  EXPECT_EQ(pick.size(), 12u);
  EXPECT_NE(std::find(pick.begin(), pick.end(), 37), pick.end());
  EXPECT_NE(std::find(pick.begin(), pick.end(), 38), pick.end());
  EXPECT_TRUE(std::is_sorted(pick.begin(), pick.end()));
  EXPECT_EQ(sheet_frames(std::vector<FitVideoFrameRow>(3), 10), (std::vector<int>{0, 1, 2}));
}

TEST_F(FitVideoRunTest, OverlayOutlinesTheRasterizedBodyAndMarksDrops) {
  ProceduralBodyOptions po;
  po.resolution = BodyResolution::low;
  const BodyModel body = make_procedural_body(po);
  Camera cam;
  cam.width = cam.height = 64;
  cam.fx = cam.fy = 80;
  cam.cx = cam.cy = 32;
  SmplxParams p;
  p.transl[2] = 3.0f;  // in front of the camera
  std::vector<float> verts(size_t(body.num_verts) * 3), joints(size_t(kNumJoints) * 3);
  Lbs<float>(body).forward(p, verts.data(), joints.data(), nullptr);
  MeshRaster raster;
  rasterize_mesh(cam, MeshView{verts.data(), body.num_verts, body.faces.data(), body.num_faces}, raster);
  const Image black(64, 64, 3);
  const Image img = draw_fit_overlay(black, cam, body, verts, KeypointsFrame{}, false);
  // Green exactly on silhouette pixels next to a background pixel (at 64 px the line is 1 px).
  int edge = 0;
  for (int y = 1; y < 63; ++y)
    for (int x = 1; x < 63; ++x) {
      auto m = [&](int u, int v) { return raster.mask[size_t(v) * 64 + u] > 0.5f; };
      const bool is_edge = m(x, y) && (!m(x - 1, y) || !m(x + 1, y) || !m(x, y - 1) || !m(x, y + 1));
      EXPECT_EQ(img.at(x, y, 1) > 0.5f, is_edge) << x << ", " << y;
      edge += is_edge;
    }
  EXPECT_GT(edge, 20);
  // A dropped frame: red border; with no body given, no outline.
  const Image d = draw_fit_overlay(black, cam, body, {}, KeypointsFrame{}, true);
  EXPECT_EQ(d.at(0, 0, 0), 1.0f);
  EXPECT_EQ(d.at(32, 32, 1), 0.0f);
}

// A disc "person" (soft 3 px edge) crossing a bright textured wall; the tool's masks are
// wider and softer than the truth, as a segmentation model's are. The fit keeps the two
// middle frames: the crop follows them, the plate uses every frame.
constexpr int kVw = 96, kVh = 64, kVframes = 6;
constexpr double kDisc = 10;
double disc_x(int i) { return 20 + 11.0 * i; }
float wall(int x, int y, int c) { return float(0.85 + 0.02 * c + 0.08 * std::sin(x / 3.0) * std::cos(y / 4.0)); }
float disc_dist(int x, int y, int i) { return float(std::hypot(x + 0.5 - disc_x(i), y + 0.5 - kVh / 2.0)); }
float disc_alpha(int x, int y, int i) {
  return std::clamp((float(kDisc) + 1.5f - disc_dist(x, y, i)) / 3.0f, 0.0f, 1.0f);
}
float disc_tool_mask(int x, int y, int i) {
  return std::clamp((float(kDisc) + 1.5f - disc_dist(x, y, i)) / 4.0f + 0.5f, 0.0f, 1.0f);
}
const std::vector<int> kKept = {2, 3};

class FitVideoCropMattingTest : public FitVideoRunTest {
 protected:
  void SetUp() override {
    FitVideoRunTest::SetUp();
    if (!program_on_path("node")) GTEST_SKIP() << "node is not installed";
    // The stand-in tool copies the prepared keypoints and masks (HAHA_TEST_KP) to its output.
    test::write_stand_in_keypoint_tool(path("tool"),
                                       "import fs from 'fs';\n"
                                       "fs.cpSync(process.env.HAHA_TEST_KP, process.argv[3], {recursive: true});\n");
    fs::create_directories(path("kp/keypoints"));
    fs::create_directories(path("kp/masks"));
    for (int i = 0; i < kVframes; ++i) {
      char stem[16];
      std::snprintf(stem, sizeof stem, "%06d", i);
      Image m(kVw, kVh, 1);
      for (int y = 0; y < kVh; ++y)
        for (int x = 0; x < kVw; ++x) m.at(x, y, 0) = disc_tool_mask(x, y, i);
      write_image(path("kp/masks/") + stem + ".png", m);
      round_to_8bit(m);
      tool_masks_.push_back(m);
      nlohmann::json body = nlohmann::json::array();
      for (int k = 0; k < kBodyKeypoints; ++k) body.push_back({disc_x(i), kVh / 2.0 - 8 + k * 0.5, 0.9});
      const nlohmann::json j = {{"format", "haha-keypoints"},
                                {"version", 1},
                                {"frame", std::string(stem) + ".png"},
                                {"width", kVw},
                                {"height", kVh},
                                {"people", 1},
                                {"score", 0.9},
                                {"body", body},
                                {"body_world", nullptr},
                                {"left_hand", nullptr},
                                {"right_hand", nullptr},
                                {"mask", std::string("masks/") + stem + ".png"},
                                {"model", "stand-in"}};
      write_text_file(path("kp/keypoints/") + stem + ".json", j.dump());
    }
  }
  // The frames (the wall moving `shift` px a frame: a camera that pans), as PNGs.
  std::string frames(const std::string& name, int shift) {
    const std::string dir = path(name);
    fs::create_directories(dir);
    for (int i = 0; i < kVframes; ++i) {
      Image img(kVw, kVh, 3);
      for (int y = 0; y < kVh; ++y)
        for (int x = 0; x < kVw; ++x) {
          const float a = disc_alpha(x, y, i);
          const float person[3] = {0.5f, 0.2f, 0.15f};
          for (int c = 0; c < 3; ++c) img.at(x, y, c) = a * person[c] + (1 - a) * wall(x + shift * i, y, c);
        }
      char f[32];
      std::snprintf(f, sizeof f, "img_%03d.png", i);
      write_image((fs::path(dir) / f).string(), img);
    }
    return dir;
  }
  // Keeps frames kKept, the (low) body 40 m away on the disc: its outline lies inside the mask.
  static FitVideoResult fitter(const std::vector<FitVideoInputFrame>& in, const FitVideoOptions&) {
    FitVideoResult r;
    r.camera.width = kVw;
    r.camera.height = kVh;
    r.camera.fx = r.camera.fy = 100;
    r.camera.cx = kVw / 2.0f;
    r.camera.cy = kVh / 2.0f;
    for (size_t i = 0; i < in.size(); ++i) {
      FitVideoFrameReport rep;
      rep.reprojection_px = 1;
      rep.silhouette_iou = 0.9;
      rep.dropped = std::find(kKept.begin(), kKept.end(), int(i)) == kKept.end();
      rep.reason = rep.dropped ? "stand-in drops it" : "";
      r.report.push_back(rep);
      if (rep.dropped) continue;
      r.kept.push_back(int(i));
      SmplxParams p;
      p.transl[0] = float((disc_x(int(i)) - kVw / 2.0) * 40 / 100);
      p.transl[2] = 40;
      r.params.push_back(p);
    }
    return r;
  }
  FitVideoSummary run(const std::string& in, bool crop, const std::string& matting) {
    FitVideoRunOptions o = options(in);
    o.crop = crop;
    o.matting = matting;
    ScopedEnv t("HAHA_KEYPOINTS_TOOL", path("tool")), k("HAHA_TEST_KP", path("kp"));
    return run_fit_video(o, test::low_body(), fitter);
  }
  // The expected crop: the union of the tool's masks (> 0.5) with the margin.
  CropBox expected_crop() const {
    CropBox u;
    for (int i : kKept) u = box_union(u, mask_box(tool_masks_[size_t(i)]));
    return dataset_crop(u, kVw, kVh);
  }
  std::vector<Image> tool_masks_;
};

TEST_F(FitVideoCropMattingTest, StaticCameraCropsAndMatsTheDataset) {
  const FitVideoSummary s = run(frames("in", 0), true, "auto");
  const CropBox box = expected_crop();
  ASSERT_LT(box.w, kVw) << "the person's box must leave something to crop";
  ASSERT_LT(box.h, kVh);
  EXPECT_TRUE(s.cropped);
  EXPECT_TRUE(s.matting_used);
  EXPECT_EQ(s.plate_frames, kVframes);
  EXPECT_EQ(s.plate_hole_share, 0.0);  // the disc crosses the frame
  EXPECT_LT(s.background_residual, 1.0 / 255);
  EXPECT_EQ(s.person_height_px, mask_box(tool_masks_[2]).h);
  EXPECT_EQ(s.kept, 2);

  const Dataset ds = read_dataset(path("out"));
  EXPECT_EQ(ds.width, box.w);
  EXPECT_EQ(ds.height, box.h);
  EXPECT_EQ(ds.width % 2 + ds.height % 2, 0);
  EXPECT_EQ(ds.source_crop, (std::array<int, 4>{box.x0, box.y0, box.w, box.h}));
  EXPECT_EQ(ds.premultiplied, 1);
  EXPECT_EQ(ds.fits, Fits::estimated);  // so haha train picks the settings for estimated fits
  EXPECT_FLOAT_EQ(ds.frames[0].camera.cx, kVw / 2.0f - box.x0);
  EXPECT_FLOAT_EQ(ds.frames[0].camera.cy, kVh / 2.0f - box.y0);
  EXPECT_EQ(ds.frames[0].camera.fx, 100);
  double err = 0, tool_err = 0;
  int n = 0;
  ASSERT_EQ(ds.frames.size(), kKept.size());
  for (size_t k = 0; k < kKept.size(); ++k) {
    const int i = kKept[k];
    const DatasetFrame& f = ds.frames[k];
    const Image source = read_image(path("out/work/frames/00000") + std::to_string(i) + ".png");
    for (int y = 0; y < ds.height; ++y)
      for (int x = 0; x < ds.width; ++x) {
        const int u = x + box.x0, v = y + box.y0;  // the same content pixel in the frame
        const float a = f.mask.at(x, y, 0);
        for (int c = 0; c < 3; ++c) ASSERT_LE(f.image.at(x, y, c), a + 0.5f / 255) << "premultiplied: colour <= alpha";
        if (disc_dist(u, v, i) < kDisc - 6) {
          for (int c = 0; c < 3; ++c) EXPECT_EQ(f.image.at(x, y, c), source.at(u, v, c)) << "the core keeps its pixels";
        }
        if (std::abs(disc_dist(u, v, i) - kDisc) < 3) {  // the soft edge and beside it
          err += std::abs(a - disc_alpha(u, v, i));
          tool_err += std::abs(tool_masks_[size_t(i)].at(u, v, 0) - disc_alpha(u, v, i));
          ++n;
        }
      }
  }
  ASSERT_GT(n, 100);
  EXPECT_LT(err / n, 0.5 * tool_err / n) << "alpha against the plate beats the tool's mask";

  const std::string table = read_text_file(path("out/fit_report.txt"));
  EXPECT_NE(table.find("\ncrop " + std::to_string(box.w) + "x" + std::to_string(box.h) + " at (" +
                       std::to_string(box.x0) + ", " + std::to_string(box.y0) + ") of the 96x64 frames"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("background plate from 6 of 6 frames, holes 0.0 % of the frame (0.0 % filled from the plain "
                       "background beside them); camera static"),
            std::string::npos) << table;
  EXPECT_NE(table.find("matting on"), std::string::npos) << table;
  const auto j = nlohmann::json::parse(read_text_file(path("out/fit_report.json")));
  EXPECT_EQ(j["crop"]["width"], box.w);
  EXPECT_EQ(j["matting"]["used"], true);
  EXPECT_EQ(j["matting"]["plate_frames"], kVframes);
  const int side = std::max(box.w, box.h);
  EXPECT_NEAR(j["person_height_train_px"].get<double>(),
              s.person_height_px * double(train_resolution(make_preset("standard"), side)) / side, 1e-9);
  EXPECT_TRUE(leftovers().empty());
}

TEST_F(FitVideoCropMattingTest, NoCropAndMattingOffKeepTodaysDataset) {
  const FitVideoSummary s = run(frames("in", 0), false, "off");
  EXPECT_FALSE(s.cropped);
  EXPECT_FALSE(s.matting_used);
  const Dataset ds = read_dataset(path("out"));
  EXPECT_EQ(ds.width, kVw);
  EXPECT_EQ(ds.height, kVh);
  EXPECT_EQ(ds.source_crop[2], 0);
  EXPECT_EQ(ds.premultiplied, 0);
  EXPECT_EQ(ds.frames[0].camera.cx, kVw / 2.0f);
  ASSERT_EQ(ds.frames.size(), kKept.size());
  for (size_t k = 0; k < kKept.size(); ++k) {
    const int i = kKept[k];
    EXPECT_EQ(ds.frames[k].mask.data, tool_masks_[size_t(i)].data) << "the tool's mask, frame " << i;
    EXPECT_EQ(ds.frames[k].image.data, read_image(path("in/img_00") + std::to_string(i) + ".png").data);
  }
  const std::string table = read_text_file(path("out/fit_report.txt"));
  EXPECT_NE(table.find("\nno crop (--no-crop): the whole 96x64 frames: the person is "), std::string::npos) << table;
  EXPECT_NE(table.find("\nmatting off (--matting off): the keypoint tool's masks\n"), std::string::npos) << table;
  EXPECT_EQ(read_text_file(path("out/dataset.json")).find("source_crop"), std::string::npos);
}

TEST_F(FitVideoCropMattingTest, AMovingCameraKeepsTheToolsMasksAndSaysSo) {
  const FitVideoSummary s = run(frames("in", 4), true, "auto");  // the wall pans 4 px a frame
  EXPECT_FALSE(s.matting_used);
  EXPECT_GT(s.background_residual, s.static_threshold);
  const Dataset ds = read_dataset(path("out"));
  EXPECT_EQ(ds.premultiplied, 0);
  const CropBox box = expected_crop();
  ASSERT_EQ(ds.frames.size(), kKept.size());
  for (size_t k = 0; k < kKept.size(); ++k)
    EXPECT_EQ(ds.frames[k].mask.data, crop(tool_masks_[size_t(kKept[k])], box.x0, box.y0, box.w, box.h).data) << k;
  const std::string table = read_text_file(path("out/fit_report.txt"));
  EXPECT_NE(table.find("camera moving (background residual "), std::string::npos) << table;
  EXPECT_NE(table.find("matting off, the keypoint tool's masks\n"), std::string::npos) << table;
}

TEST_F(FitVideoRunTest, MattingOptionIsChecked) {
  FitVideoRunOptions o = options(image_folder("in", 1, 16, 16));
  o.matting = "always";
  expect_error_at("--matting", [&] { validate_fit_video_options(o); }, {"always", "auto", "off"});
}

}  // namespace
}  // namespace haha
