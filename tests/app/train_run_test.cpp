// File side of training: the run config as JSON, checkpoints as npz, dataset frames turned
// into training frames, and the driver (run directory outputs, kill + --resume reaching
// the uninterrupted result, bad frames reported before any work).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "app/eval_run.h"
#include "app/run_dir.h"
#include "app/train_frames.h"
#include "app/train_run.h"
#include "core/interrupt.h"
#include "data/dataset.h"
#include "format/avatar_npz.h"
#include "io/body_model_io.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"
#include "support/data_test_util.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using testutil::expect_error;

class TrainRunTest : public testutil::TempDirTest {
 protected:
  // A small dataset on disk rendered from the test scene: 6 train + 2 test frames, 48 px,
  // images on black (premultiplied), with the body model beside it.
  std::string make_dataset(Fits fits = Fits::unknown, const std::string& name = "ds") {
    const std::string dir = path(name);
    const Avatar truth = test::scene_truth();
    const std::vector<TrainFrame> f = test::scene_frames(truth, 8, 48);
    DatasetWriter w(dir, 48, 48, 30.0, "neutral", "haha synth: test scene");
    w.set_fits(fits);
    for (size_t i = 0; i < f.size(); ++i) {
      DatasetFrame df;
      df.split = i < 6 ? Split::train : Split::test;
      df.camera = f[i].camera;
      df.params = f[i].params;
      Image rgb(48, 48, 3), mask(48, 48, 1);
      rgb.data = f[i].rgb;
      mask.data = f[i].mask;
      w.add(df, rgb, mask);
    }
    w.finish();
    save_body_model(test::scene_body(), dir + "/body_model.npz");
    return dir;
  }
  TrainRunOptions options(const std::string& data, const std::string& run) {
    TrainRunOptions o;
    o.data_dir = data;
    o.run_dir = run;
    o.preset = "tiny";
    o.overrides = {"resolution=0", "s1.steps=6", "s2.steps=4", "s3.steps=5", "s2.texture_size=16",
                   "s1.densify.from=1", "s1.densify.every=2", "s1.densify.grad=1e-5", "s3.prune_every=2",
                   "checkpoint_every=2", "batch=2"};
    o.log = [this](const std::string& s) { log_ += s + "\n"; };
    return o;
  }
  std::string log_;
};

TEST_F(TrainRunTest, RunInfoRoundTripsThroughJson) {
  RunInfo a;
  a.model_path = "/m/SMPLX_NEUTRAL.npz";
  a.data_path = "/d/ds";
  a.lpips_weights_path = "/w/lpips.npz";
  a.config = make_preset("tiny");
  apply_overrides(a.config, {"s1.lr.offset_init=1.234567890123e-3", "use_dice=false", "seed=7"});
  fs::create_directories(path("run"));
  const RunDir run(path("run"));
  write_run_info(run, a);
  const RunInfo b = read_run_info(run);
  EXPECT_TRUE(b.trained);
  EXPECT_EQ(b.model_path, a.model_path);
  EXPECT_EQ(b.data_path, a.data_path);
  EXPECT_EQ(b.lpips_weights_path, a.lpips_weights_path);
  EXPECT_EQ(config_to_pairs(b.config), config_to_pairs(a.config));
  EXPECT_EQ(b.config.s1.lr_offset_init, a.config.s1.lr_offset_init);
  // Errors name the file and key.
  fs::create_directories(path("bad"));
  std::ofstream(path("bad/config.json")) << R"({"format": "haha-run", "version": 1, "model": "m", "data": "d",
    "config": {"s1.stepz": 3}})";
  expect_error([&] { read_run_info(RunDir(path("bad"))); }, {"bad/config.json: config: s1.stepz: unknown key"});
  fs::create_directories(path("notjson"));
  std::ofstream(path("notjson/config.json")) << "{";
  expect_error([&] { read_run_info(RunDir(path("notjson"))); }, {"notjson/config.json: not valid JSON"});
  expect_error([&] { read_run_info(RunDir(path("nowhere"))); }, {"nowhere/config.json", "missing"});
}

TEST_F(TrainRunTest, AnUnpackedAvatarsConfigNamesItsModelAndNoTraining) {
  fs::create_directories(path("unpacked"));
  const RunDir run(path("unpacked"));
  RunInfo a;
  a.trained = false;
  a.model_path = "body.npz";
  a.unpacked_from = "avatar.glb";
  write_run_info(run, a);
  std::ofstream(path("unpacked/body.npz")) << "x";  // only its existence matters here
  const RunInfo b = read_run_info(run);
  EXPECT_FALSE(b.trained);
  EXPECT_EQ(b.unpacked_from, "avatar.glb");
  EXPECT_EQ(fs::path(b.model_path), fs::path(path("unpacked")) / "body.npz");  // resolved in the run directory
  expect_error([&] { read_trained_run_info(run, "haha eval"); },
               {"unpacked/config.json", "haha eval needs a trained run", "avatar.glb"});
  // A hand-made directory: only the model.
  fs::create_directories(path("hand"));
  std::ofstream(path("hand/config.json")) << R"({"model": "/abs/SMPLX_NEUTRAL.npz"})";
  const RunInfo h = read_run_info(RunDir(path("hand")));
  EXPECT_FALSE(h.trained);
  EXPECT_EQ(h.model_path, "/abs/SMPLX_NEUTRAL.npz");
}

TEST_F(TrainRunTest, CheckpointsRoundTrip) {
  TrainCheckpoint ck;
  ck.f32["g.offset"] = {1.5f, -2.0f, 3.25f};
  ck.f32["empty"] = {};
  ck.i32["meta.version"] = {1};
  ck.i32["g.face"] = {4, 5, 6};
  ck.f64["time.seconds"] = {1.0, 2.5, 3.0};
  write_checkpoint(path("ck.npz"), ck);
  const TrainCheckpoint r = read_checkpoint(path("ck.npz"));
  EXPECT_EQ(r.f32, ck.f32);
  EXPECT_EQ(r.i32, ck.i32);
  EXPECT_EQ(r.f64, ck.f64);
  Npz other;
  other.set("x", NpyArray::from(std::vector<float>{1.0f}, {1}));
  other.write(path("other.npz"));
  expect_error([&] { read_checkpoint(path("other.npz")); }, {"other.npz", "not a haha training checkpoint"});
  EXPECT_TRUE(leftovers().empty());
}

TEST_F(TrainRunTest, PremultipliedComesFromTheDatasetFlagThenTheSource) {
  Dataset ds;
  ds.source = "haha synth: anything";
  EXPECT_TRUE(dataset_premultiplied(ds, "auto"));  // older files: inferred as before
  ds.premultiplied = 0;
  EXPECT_FALSE(dataset_premultiplied(ds, "auto"));  // the flag wins over the source text
  EXPECT_TRUE(dataset_premultiplied(ds, "true"));   // and the config over both
  ds.source = "my own renders on black";
  ds.premultiplied = -1;
  EXPECT_FALSE(dataset_premultiplied(ds, "auto"));
  ds.premultiplied = 1;
  EXPECT_TRUE(dataset_premultiplied(ds, "auto"));
  EXPECT_FALSE(dataset_premultiplied(ds, "false"));
}

TEST_F(TrainRunTest, DatasetFramesAreResizedWithTheirCameras) {
  Dataset ds = read_dataset(make_dataset());
  EXPECT_TRUE(dataset_premultiplied(ds, "auto"));  // made by "haha synth" (no flag: its source)
  EXPECT_FALSE(dataset_premultiplied(ds, "false"));
  const std::vector<TrainFrame> full = dataset_frames(ds, Split::train, 0);
  const std::vector<TrainFrame> half = dataset_frames(ds, Split::train, 24);
  ASSERT_EQ(full.size(), 6u);
  ASSERT_EQ(dataset_frames(ds, Split::test, 0).size(), 2u);
  EXPECT_EQ(half[0].camera.width, 24);
  EXPECT_EQ(half[0].rgb.size(), size_t(24 * 24 * 3));
  EXPECT_EQ(half[0].mask.size(), size_t(24 * 24));
  EXPECT_FLOAT_EQ(half[0].camera.fx, full[0].camera.fx / 2);
  EXPECT_FLOAT_EQ(half[0].camera.cx, full[0].camera.cx / 2);
  // Area resize keeps the mean colour.
  double a = 0, b = 0;
  for (float v : full[0].rgb) a += v / full[0].rgb.size();
  for (float v : half[0].rgb) b += v / half[0].rgb.size();
  EXPECT_NEAR(a, b, 1e-3);
}

TEST_F(TrainRunTest, RunWritesItsOutputsAndResumeReachesTheSameState) {
  const std::string data = make_dataset();
  const TrainRunResult full = run_training(options(data, path("run")));
  EXPECT_TRUE(full.finished);
  EXPECT_EQ(full.steps_run, 15);
  for (const char* f : {"config.json", "checkpoint.npz", "checkpoint_stage1.npz", "checkpoint_stage2.npz",
                        "checkpoint_stage3.npz", "avatar.npz", "avatar_stage1.npz", "smplx_refined.npz",
                        "train_summary.json"})
    EXPECT_TRUE(fs::exists(path("run/") + f)) << f;
  EXPECT_EQ(load_avatar_npz(path("run/avatar.npz")).gaussians.size(), full.gaussians);
  EXPECT_EQ(load_avatar_npz(path("run/avatar_stage1.npz")).gaussians.size(), full.gaussians_stage1);
  EXPECT_NE(log_.find("[stage 1]"), std::string::npos);
  EXPECT_NE(log_.find("ETA"), std::string::npos);
  const std::array<double, 3> secs = read_train_seconds(RunDir(path("run")));
  EXPECT_GT(secs[0], 0.0);

  // Killed after 8 steps (stage 2), resumed: the final checkpoint equals the full run's.
  TrainRunOptions o = options(data, path("run2"));
  o.stop_after = 8;
  const TrainRunResult part = run_training(o);
  EXPECT_FALSE(part.finished);
  EXPECT_FALSE(fs::exists(path("run2/avatar.npz")));
  TrainRunOptions r = options("", path("run2"));
  r.overrides.clear();
  r.resume = true;
  const TrainRunResult rest = run_training(r);
  EXPECT_TRUE(rest.finished);
  EXPECT_EQ(rest.steps_run, 7);
  const TrainCheckpoint a = read_checkpoint(path("run/checkpoint.npz"));
  const TrainCheckpoint b = read_checkpoint(path("run2/checkpoint.npz"));
  EXPECT_EQ(a.f32, b.f32);
  EXPECT_EQ(a.i32, b.i32);
  EXPECT_EQ(fs::file_size(path("run/smplx_refined.npz")), fs::file_size(path("run2/smplx_refined.npz")));

  // Resume refuses overrides, and a fresh run refuses an existing run directory.
  r.overrides = {"s1.steps=9"};
  expect_error([&] { run_training(r); }, {"--resume", "overrides are not allowed"});
  expect_error([&] { run_training(options(data, path("run"))); }, {"a run already exists here", "--resume"});
}

TEST_F(TrainRunTest, EvalWritesItsReportIntoOutAndLeavesTheRunsOwn) {
  const std::string data = make_dataset();
  ASSERT_TRUE(run_training(options(data, path("run"))).finished);
  EvalRunOptions e;
  e.run_dir = path("run");
  e.tto_steps = 0;
  e.print_table = false;
  e.sheet_frames = 1;
  const EvalReport own = run_eval(e);
  ASSERT_TRUE(fs::exists(path("run/report.md")));
  const std::string before = testutil::read_text(path("run/report.md"));

  // Evaluated on its training frames into another folder (created): the run's report stays.
  e.split = "train";
  e.out_dir = path("elsewhere/eval");
  const EvalReport other = run_eval(e);
  for (const char* f : {"report.json", "report.md", "eval_sheet.png"})
    EXPECT_TRUE(fs::exists(path("elsewhere/eval/") + f)) << f;
  EXPECT_EQ(testutil::read_text(path("run/report.md")), before);
  EXPECT_NE(testutil::read_text(path("elsewhere/eval/report.md")), before);
  EXPECT_EQ(other.split, "train");
  EXPECT_EQ(other.frame_names.size(), 6u);
  EXPECT_EQ(own.frame_names.size(), 2u);

  // An --out that is a file: one error naming it, before any work.
  testutil::write_text(path("a_file"), "x");
  e.out_dir = path("a_file");
  expect_error([&] { run_eval(e); }, {path("a_file"), "not a folder"});
}

TEST_F(TrainRunTest, EstimatedFitsTrainWithTheirSettingsAndExactOnesWithThePreset) {
  TrainConfig preset = make_preset("tiny");
  apply_overrides(preset, options("", "").overrides);
  for (Fits fits : {Fits::estimated, Fits::exact, Fits::unknown}) {
    const std::string name = fits == Fits::unknown ? "unknown" : fits_name(fits);
    SCOPED_TRACE(name);
    const std::string data = make_dataset(fits, "ds_" + name);
    TrainRunOptions o = options(data, path("run_" + name));
    o.stop_after = 0;  // the config is saved before the first step
    log_.clear();
    run_training(o);
    const TrainConfig saved = read_run_info(RunDir(path("run_" + name))).config;
    if (fits == Fits::estimated) {
      EXPECT_EQ(saved.fits, "estimated");
      EXPECT_EQ(saved.s0.steps, 0);
      EXPECT_EQ(saved.s0.photo.steps, 6000);
      EXPECT_EQ(saved.s0.surface.steps, 2000);
      EXPECT_DOUBLE_EQ(saved.s1.lr_pose, 0.005);
      EXPECT_EQ(saved.eval_tto_steps, 100);
      EXPECT_TRUE(saved.eval_antialias);
      EXPECT_EQ(saved.s1.steps, 6);  // the user's keys stay
      EXPECT_NE(log_.find("fits: estimated (dataset.json): s0.photo.steps=6000 s0.surface.steps=2000 s0.surface.max_in=0.015 "
                          "s0.surface.w.outside=4 s1.lr.pose=0.005 s3.w.opacity=0 s3.prune_cost=0.05 "
                          "s3.depth_margin=0.01 eval.tto_steps=100 eval.antialias=true (override any with key=value"),
                std::string::npos)
          << log_;
      EXPECT_NE(log_.find("photometric pose fit against a textured mesh: 6000 steps over 6 frames at 48x48"),
                std::string::npos)
          << log_;
    } else {
      // Exact, or a dataset.json without the flag (older files): the preset as before.
      EXPECT_EQ(saved.fits, "exact");
      TrainConfig c = saved;
      c.fits = preset.fits;
      EXPECT_EQ(config_to_pairs(c), config_to_pairs(preset));
      EXPECT_NE(log_.find(fits == Fits::exact ? "fits: exact (dataset.json): the preset's settings"
                                              : "fits: exact (dataset.json does not say): the preset's settings"),
                std::string::npos)
          << log_;
    }
  }
  // The user wins over the settings; fits=exact keeps the preset on estimated data.
  const std::string data = path("ds_estimated");
  TrainRunOptions o = options(data, path("run_mine"));
  o.stop_after = 0;
  o.overrides.push_back("s0.photo.steps=0");
  run_training(o);
  const TrainConfig mine = read_run_info(RunDir(path("run_mine"))).config;
  EXPECT_EQ(mine.s0.photo.steps, 0);
  EXPECT_DOUBLE_EQ(mine.s1.lr_pose, 0.005);
  o = options(data, path("run_told_exact"));
  o.stop_after = 0;
  o.overrides.push_back("fits=exact");
  run_training(o);
  TrainConfig exact = read_run_info(RunDir(path("run_told_exact"))).config;
  EXPECT_EQ(exact.fits, "exact");
  exact.fits = preset.fits;
  EXPECT_EQ(config_to_pairs(exact), config_to_pairs(preset));
  // A bad value: one line, before anything is read or written.
  o = options(data, path("run_bad"));
  o.overrides.push_back("fits=guessed");
  expect_error([&] { run_training(o); }, {"fits: must be auto, exact or estimated, got 'guessed'"});
  EXPECT_FALSE(fs::exists(path("run_bad")));
}

TEST_F(TrainRunTest, CtrlCInThePhotometricPoseFitLeavesNoRun) {
  TrainRunOptions o = options(make_dataset(Fits::estimated), path("run"));
  request_interrupt();  // what the handler does on Ctrl-C
  expect_error([&] { run_training(o); }, {"interrupted"});
  clear_interrupt();
  EXPECT_NE(log_.find("fits: estimated"), std::string::npos) << log_;  // it got as far as the fit
  EXPECT_EQ(log_.find("photometric pose fit against"), std::string::npos) << log_;
  EXPECT_FALSE(fs::exists(path("run")));
}

// The clothed surface: fitted before stage 1, kept in the run (rest_offsets.npy and
// avatar.npz), read back by --resume so the resumed run ends where the uninterrupted one
// does; Ctrl-C during the fit leaves no run.
TEST_F(TrainRunTest, ClothedSurfaceIsKeptByTheRunAndItsResume) {
  const std::string data = make_dataset();
  auto with_surface = [&](const std::string& run) {
    TrainRunOptions o = options(data, path(run));
    o.overrides.insert(o.overrides.end(), {"s0.surface.steps=30", "s0.surface.resolution=48", "s0.surface.texture_size=16"});
    return o;
  };
  const TrainRunResult full = run_training(with_surface("run"));
  ASSERT_TRUE(full.finished);
  EXPECT_NE(log_.find("[clothed surface] step 30/30"), std::string::npos) << log_;
  EXPECT_NE(log_.find("clothed surface: 30 steps at 48 px"), std::string::npos) << log_;
  const NpyArray offsets = read_npy(path("run/rest_offsets.npy"));
  EXPECT_EQ(offsets.shape, (std::vector<int64_t>{test::scene_body().num_verts, 3}));
  const Avatar a = load_run_avatar(RunDir(path("run")), "");
  EXPECT_EQ(a.body.rest_offsets, offsets.as_float());
  EXPECT_EQ(load_stage1_avatar(RunDir(path("run")), a.body).body.rest_offsets, offsets.as_float());
  std::ifstream summary(path("run/train_summary.json"));
  const std::string text((std::istreambuf_iterator<char>(summary)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"clothed_surface\""), std::string::npos);

  TrainRunOptions o = with_surface("run2");
  o.stop_after = 8;
  EXPECT_FALSE(run_training(o).finished);
  TrainRunOptions r = options("", path("run2"));
  r.overrides.clear();
  r.resume = true;
  ASSERT_TRUE(run_training(r).finished);
  const TrainCheckpoint ca = read_checkpoint(path("run/checkpoint.npz"));
  const TrainCheckpoint cb = read_checkpoint(path("run2/checkpoint.npz"));
  EXPECT_EQ(ca.f32, cb.f32);
  EXPECT_EQ(load_run_avatar(RunDir(path("run2")), "").body.rest_offsets, offsets.as_float());
  fs::remove(path("run2/rest_offsets.npy"));  // a resumed run without its displacement says so
  expect_error([&] { run_training(r); }, {"rest_offsets.npy", "displacement is missing"});

  request_interrupt();
  expect_error([&] { run_training(with_surface("run3")); }, {"interrupted"});
  clear_interrupt();
  EXPECT_FALSE(fs::exists(path("run3")));
}

// A garment (forced on the scene's bare body): made and fitted before stage 1, kept in the
// run (garment.npz, avatar.npz), appended again by --resume so the resumed run ends where the
// uninterrupted one does; `none` makes none.
TEST_F(TrainRunTest, GarmentIsKeptByTheRunAndItsResume) {
  const std::string data = make_dataset();
  auto with_garment = [&](const std::string& run, const char* mode) {
    TrainRunOptions o = options(data, path(run));
    o.overrides.insert(o.overrides.end(), {std::string("s0.garment.mode=") + mode, "s0.garment.steps=20",
                                           "s0.garment.rings=4", "s0.garment.columns=12", "s0.surface.resolution=48",
                                           "s0.surface.texture_size=16"});
    return o;
  };
  ASSERT_TRUE(run_training(with_garment("run", "skirt")).finished);
  EXPECT_NE(log_.find("garment forced by s0.garment.mode=skirt"), std::string::npos) << log_;
  EXPECT_NE(log_.find("[garment] step 20/20"), std::string::npos) << log_;
  ASSERT_TRUE(fs::exists(path("run/garment.npz")));
  const Avatar a = load_run_avatar(RunDir(path("run")), "");
  ASSERT_TRUE(a.body.has_garment());
  EXPECT_EQ(a.body.num_verts, test::scene_body().num_verts + 4 * 12);
  EXPECT_EQ(a.body.rest_offsets.size(), size_t(a.body.num_verts) * 3);
  EXPECT_TRUE(load_stage1_avatar(RunDir(path("run")), a.body).body.has_garment());
  std::ifstream summary(path("run/train_summary.json"));
  const std::string text((std::istreambuf_iterator<char>(summary)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"garment\""), std::string::npos);
  EXPECT_NE(text.find("\"garment_only\": true"), std::string::npos) << text;

  TrainRunOptions o = with_garment("run2", "skirt");
  o.stop_after = 8;
  EXPECT_FALSE(run_training(o).finished);
  TrainRunOptions r = options("", path("run2"));
  r.overrides.clear();
  r.resume = true;
  ASSERT_TRUE(run_training(r).finished);
  EXPECT_EQ(read_checkpoint(path("run/checkpoint.npz")).f32, read_checkpoint(path("run2/checkpoint.npz")).f32);
  EXPECT_EQ(load_run_avatar(RunDir(path("run2")), "").body.num_verts, a.body.num_verts);

  ASSERT_TRUE(run_training(with_garment("run3", "none")).finished);
  EXPECT_FALSE(fs::exists(path("run3/garment.npz")));
  EXPECT_FALSE(load_run_avatar(RunDir(path("run3")), "").body.has_garment());
}

TEST_F(TrainRunTest, ValidatedFilteringHoldsFramesOutAndSaysWhereItStopped) {
  const std::string data = make_dataset();
  TrainRunOptions o = options(data, path("run"));
  o.overrides.insert(o.overrides.end(), {"s3.validation_every=3", "s3.max_kept=1"});
  const TrainRunResult res = run_training(o);
  ASSERT_TRUE(res.finished);
  EXPECT_NE(log_.find("validation: 2 of 6 training frames held out"), std::string::npos) << log_;
  EXPECT_NE(log_.find("filtering stopped at step"), std::string::npos) << log_;
  std::ifstream in(path("run/train_summary.json"));
  const nlohmann::json s = nlohmann::json::parse(in);
  EXPECT_EQ(s["frames"], 4);
  const nlohmann::json& f = s["filter_stop"];
  EXPECT_EQ(f["validation_frames"], 2);
  ASSERT_EQ(f["points"].size(), 4u);  // the start, prunes at 2 and 4, the end at 5
  const int c = f["chosen"];
  EXPECT_EQ(f["points"][size_t(c)]["gaussians"], res.gaussians);
  // The refined fits still cover every training frame, the held-out ones in their places.
  EXPECT_EQ(read_smplx_params(path("run/smplx_refined.npz")).size(), 6u);
}

TEST_F(TrainRunTest, EvalAntialiasesAsTheRunSaysUnlessTold) {
  TrainRunOptions o = options(make_dataset(Fits::estimated), path("run"));
  o.overrides.push_back("s0.photo.steps=2");  // the pose and surface fits' lengths do not matter here
  o.overrides.push_back("s0.surface.steps=2");
  ASSERT_TRUE(run_training(o).finished);
  EvalRunOptions e;
  e.run_dir = path("run");
  e.tto_steps = 0;
  e.frames = 1;
  e.print_table = false;
  e.sheet_frames = 1;
  EXPECT_TRUE(run_eval(e).antialias);  // the run's eval.antialias=true (estimated fits)
  e.antialias = 0;                     // --no-antialias
  EXPECT_FALSE(run_eval(e).antialias);
  e.tto_steps = -1;  // the run's: 100 steps; one frame, and the answer is in the report
  e.antialias = -1;
  e.out_dir = path("eval_default");
  const EvalReport r = run_eval(e);
  EXPECT_EQ(r.tto_steps, 100);
  EXPECT_TRUE(r.antialias);
  // The report's switches say why: the fits, and what they brought.
  for (const char* sw : {"fits=estimated", "s0.photo.steps=2", "s1.lr.pose=0.005", "eval.tto_steps=100", "eval.antialias=true"})
    EXPECT_NE(std::find(r.switches.begin(), r.switches.end(), sw), r.switches.end()) << sw;

  // An exact run: off unless --antialias, and "fits=exact" is no switch.
  ASSERT_TRUE(run_training(options(make_dataset(Fits::exact, "ds_exact"), path("run_exact"))).finished);
  e.run_dir = path("run_exact");
  e.out_dir.clear();
  e.tto_steps = 0;
  const EvalReport x = run_eval(e);
  EXPECT_FALSE(x.antialias);
  for (const std::string& sw : x.switches) EXPECT_EQ(sw.rfind("fits=", 0), std::string::npos) << sw;
  e.antialias = 1;  // --antialias
  EXPECT_TRUE(run_eval(e).antialias);
}

TEST_F(TrainRunTest, BadFramesAreReportedBeforeTraining) {
  const std::string data = make_dataset();
  // An unreadable image: the error names the file, nothing is trained or checkpointed.
  std::ofstream(data + "/images/000003.png", std::ios::trunc) << "not a png";
  expect_error([&] { run_training(options(data, path("run"))); }, {"000003.png"});
  EXPECT_FALSE(fs::exists(path("run/checkpoint.npz")));
  // A missing body model.
  const std::string data2 = path("ds2");
  fs::create_directories(data2);
  expect_error([&] { run_training(options(data2, path("run3"))); }, {"--model", "body_model.npz"});
}

}  // namespace
}  // namespace haha
