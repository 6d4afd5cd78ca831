// `haha eval`: the paper's stage table for a trained run (train/evaluate.h), written to
// RUN/report.json, RUN/report.md and RUN/eval_sheet.png.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command.h"
#include "core/error.h"
#include "data/dataset.h"
#include "data/eval_report.h"
#include "data/train_run.h"
#include "format/avatar_npz.h"
#include "io/lpips_weights.h"
#include "train/evaluate.h"

HAHA_COMMAND(eval) {
  struct Opts {
    std::string run, data, split = "test", background = "black", lpips;
    int tto_steps = -1, frames = 0, sheet_frames = 4;
    bool json = false;
  };
  auto a = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("eval", "Evaluate a trained run: mesh only / full Gaussians / naive merge / HAHA");
  sub->add_option("--run", a->run, "run directory (haha train --out)")->required();
  sub->add_option("--data", a->data, "dataset directory (default: the run's)");
  sub->add_option("--split", a->split, "train or test")->capture_default_str();
  sub->add_option("--background", a->background, "black or white")->capture_default_str();
  sub->add_option("--tto-steps", a->tto_steps, "test-time pose optimisation steps (default: the run's; 0 = off)");
  sub->add_option("--frames", a->frames, "evaluate only the first N frames of the split (0 = all)");
  sub->add_option("--sheet-frames", a->sheet_frames, "frames on the contact sheet")->capture_default_str();
  sub->add_option("--lpips-weights", a->lpips, "LPIPS weight file (AlexNet part used); default: the run's");
  sub->add_flag("--json", a->json, "print report.json instead of the table");
  sub->callback([a] {
    namespace fs = std::filesystem;
    const auto t0 = std::chrono::steady_clock::now();
    if (a->background != "black" && a->background != "white")
      haha::fail("--background", "expected black or white, got '" + a->background + "'");
    const haha::Split split = haha::parse_split(a->split, "--split");
    const haha::RunInfo info = haha::read_run_info((fs::path(a->run) / "config.json").string());
    const std::string data = a->data.empty() ? info.data_path : a->data;
    // Avatars: the final (filtered) one and the stage-1 (full Gaussian) one, same body.
    haha::Avatar filtered = haha::load_run_avatar(a->run);
    haha::Avatar full = haha::load_avatar_npz((fs::path(a->run) / "avatar_stage1.npz").string());
    full.body = filtered.body;
    haha::Dataset ds = haha::read_dataset(data, haha::LoadPixels::headers);
    std::vector<haha::TrainFrame> frames = haha::dataset_frames(ds, split, info.config.resolution);
    if (frames.empty()) haha::fail(data, "no " + a->split + " frames");
    if (a->frames > 0 && size_t(a->frames) < frames.size()) frames.resize(size_t(a->frames));

    haha::EvalOptions opt;
    opt.tto_steps = a->tto_steps >= 0 ? a->tto_steps : info.config.eval_tto_steps;
    opt.lr_pose = info.config.eval_lr_pose;
    opt.lr_pose_fine = info.config.eval_lr_pose_fine;
    const float bgv = a->background == "white" ? 1.0f : 0.0f;
    for (float& c : opt.background) c = bgv;
    opt.premultiplied = haha::dataset_premultiplied(ds, info.config.premultiplied);
    opt.keep_images = a->sheet_frames;
    std::unique_ptr<haha::LpipsNet<float>> alex;
    haha::LpipsWeights lw;
    const std::string lp = a->lpips.empty() ? info.lpips_weights_path : a->lpips;
    if (!lp.empty()) {
      lw = haha::read_lpips_weights(lp);
      if (lw.has_backbone(haha::LpipsBackbone::Alex)) {
        alex = std::make_unique<haha::LpipsNet<float>>(lw, haha::LpipsBackbone::Alex);
        if (std::min(frames[0].camera.width, frames[0].camera.height) < alex->min_size()) alex.reset();
      }
    }
    opt.lpips = alex.get();

    haha::EvalReport r;
    r.run_dir = a->run;
    r.data_dir = data;
    r.split = a->split;
    r.background = a->background;
    r.preset = info.config.preset;
    r.tto_steps = opt.tto_steps;
    r.lpips_available = alex != nullptr;
    const haha::TrainConfig defaults = haha::make_preset(info.config.preset);
    for (const auto& [k, v] : haha::config_to_pairs(info.config))
      for (const auto& [k0, v0] : haha::config_to_pairs(defaults))
        if (k == k0 && v != v0) r.switches.push_back(k + "=" + v);
    r.stage_seconds = haha::read_train_seconds(a->run);
    for (const haha::TrainFrame& f : frames) r.frame_names.push_back(f.name);
    const haha::EvalVariant variants[] = {{"mesh only", &filtered, true, false},
                                          {"full Gaussians", &full, false, true},
                                          {"naive merge", &full, true, true},
                                          {"HAHA filtered", &filtered, true, true}};
    for (const haha::EvalVariant& v : variants) {
      r.variants.push_back(haha::evaluate_variant(v, frames, opt));
      if (!a->json)
        std::printf("  %-15s PSNR %.2f  SSIM %.4f  (%d Gaussians)\n", v.name.c_str(), r.variants.back().psnr,
                    r.variants.back().ssim, r.variants.back().num_gaussians);
    }
    r.regions_full = haha::gaussians_per_region(full.body, full.gaussians);
    r.regions_filtered = haha::gaussians_per_region(filtered.body, filtered.gaussians);
    r.eval_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    haha::write_eval_report(r);
    haha::write_eval_contact_sheet((fs::path(a->run) / "eval_sheet.png").string(), r, frames[0].camera.width,
                                   frames[0].camera.height);
    if (a->json)
      std::printf("%s", haha::eval_report_json(r).c_str());
    else
      std::printf("%s\nwrote %s/report.md, report.json, eval_sheet.png (%.1f s)\n",
                  haha::eval_report_markdown(r).c_str(), a->run.c_str(), r.eval_seconds);
  });
}
