// End to end on the synthetic subject at a reduced scale (96 px, 24 training frames, a
// shortened tiny schedule): haha synth -> haha train -> haha eval as library calls,
// through the real files (dataset, run directory, avatar npz). Checks the outputs and the
// method's properties with margins that a shorter schedule still meets (the full tiny
// preset's numbers are in docs/results.md):
//   - filtering removes Gaussians, mostly on the body surface: the head/hair and legs
//     (skirt) keep a larger share than arms, hands and feet;
//   - the filtered avatar beats the textured mesh alone and stays close to the full
//     Gaussian avatar.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "app/eval_report.h"
#include "app/run_dir.h"
#include "app/train_frames.h"
#include "app/train_run.h"
#include "body/procedural_body.h"
#include "data/dataset.h"
#include "data/synth_dataset.h"
#include "format/avatar_npz.h"
#include "train/evaluate.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

TEST(PipelineTrain, SynthTrainEvalOnTheSyntheticSubject) {
  const auto t0 = std::chrono::steady_clock::now();
  const fs::path dir = fs::temp_directory_path() / ("haha_pipeline_train_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string data = (dir / "ds").string(), run = (dir / "run").string();

  SynthOptions so;
  so.size = 96;
  so.train_frames = 24;
  so.test_frames = 4;
  so.supersample = 2;
  const BodyModel body = make_procedural_body({BodyResolution::full, 0});
  write_synth_dataset(data, body, so, true);

  TrainRunOptions o;
  o.data_dir = data;
  o.run_dir = run;
  o.preset = "tiny";
  o.overrides = {"resolution=96", "s1.steps=400", "s1.densify.until=300", "s2.steps=300", "s3.steps=300",
                 "checkpoint_every=0", "log_every=100"};
  const TrainRunResult res = run_training(o);
  ASSERT_TRUE(res.finished);
  EXPECT_GT(res.gaussians_stage1, body.num_faces);  // densified
  EXPECT_LT(res.gaussians, res.gaussians_stage1);   // filtered

  // Evaluation as `haha eval` does it.
  const Avatar filtered = load_run_avatar(RunDir(run));
  const Avatar full = load_stage1_avatar(RunDir(run), filtered.body);
  EXPECT_EQ(full.gaussians.size(), res.gaussians_stage1);
  Dataset ds = read_dataset(data);
  const std::vector<TrainFrame> frames = dataset_frames(ds, Split::test, 96);
  ASSERT_EQ(frames.size(), 4u);
  EvalOptions eo;
  eo.tto_steps = 5;
  eo.premultiplied = dataset_premultiplied(ds, "auto");
  eo.keep_images = 2;
  EvalReport r;
  r.run_dir = run;
  r.data_dir = data;
  for (const TrainFrame& f : frames) r.frame_names.push_back(f.name);
  const EvalVariant variants[] = {{"mesh only", &filtered, true, false},
                                  {"full Gaussians", &full, false, true},
                                  {"naive merge", &full, true, true},
                                  {"HAHA filtered", &filtered, true, true}};
  for (const EvalVariant& v : variants) r.variants.push_back(evaluate_variant(v, frames, eo));
  r.regions_full = gaussians_per_region(full.body, full.gaussians);
  r.regions_filtered = gaussians_per_region(filtered.body, filtered.gaussians);
  write_eval_report(r);
  write_eval_contact_sheet(run + "/eval_sheet.png", r, 96, 96);
  std::printf("%s", eval_report_markdown(r).c_str());

  const double mesh = r.variants[0].psnr, fullp = r.variants[1].psnr, filt = r.variants[3].psnr;
  for (const VariantEval& v : r.variants) {
    EXPECT_TRUE(std::isfinite(v.psnr)) << v.name;
    EXPECT_GT(v.ssim, 0.5) << v.name;
  }
  EXPECT_GT(filt, mesh + 0.5);    // Gaussians add what the mesh cannot show
  EXPECT_GT(filt, fullp - 1.0);   // filtering costs little
  EXPECT_LT(r.variants[3].storage_bytes, r.variants[2].storage_bytes);
  // Survival by region: head/hair + legs (skirt) versus arms + hands + feet.
  auto kept = [&](std::initializer_list<BodyRegion> regs) {
    double a = 0, b = 0;
    for (BodyRegion g : regs) a += r.regions_filtered[size_t(g)], b += r.regions_full[size_t(g)];
    return a / std::max(1.0, b);
  };
  const double off_body = kept({BodyRegion::head, BodyRegion::legs});
  const double on_body = kept({BodyRegion::arms, BodyRegion::hands, BodyRegion::feet});
  EXPECT_GT(off_body, on_body) << "head+legs keep " << off_body << ", arms+hands+feet " << on_body;
  for (const char* f : {"report.json", "report.md", "eval_sheet.png", "avatar.npz", "avatar_stage1.npz"})
    EXPECT_TRUE(fs::exists(run + "/" + f)) << f;
  std::printf("pipeline: %.1f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
