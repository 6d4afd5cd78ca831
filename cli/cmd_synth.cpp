// `haha synth`: the embedded sample. A clothed synthetic subject (textured skin and
// clothes, plus hair, ponytail and skirt that leave the body surface; or, with
// --subject 2, long loose hair and a loose long coat on another body shape) rendered as a
// monocular video with masks, a static camera and per-frame SMPL-X fits, in the native
// dataset format (data/synth_dataset.h, synth/synth_subject.h).
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "body/procedural_body.h"
#include "command.h"
#include "core/error.h"
#include "data/dataset.h"
#include "data/synth_dataset.h"
#include "data/xhumans_take.h"

HAHA_COMMAND(synth) {
  struct Opts {
    std::string out, body, resolution = "full", xhumans;
    haha::SynthOptions o;
    double fit_noise = 0, fit_noise_pose = 0, fit_noise_transl = 0;
  };
  auto a = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("synth", "Render the synthetic clothed subject as a dataset (the embedded sample)");
  sub->add_option("--out", a->out, "output dataset directory")->required();
  sub->add_option("--body", a->body, "body model .npz (default: the procedural body, saved as OUT/body_model.npz)");
  sub->add_option("--body-resolution", a->resolution, "procedural body without --body: low or full")
      ->capture_default_str();
  sub->add_option("--size", a->o.size, "image side in pixels")->capture_default_str();
  sub->add_option("--frames", a->o.train_frames, "training frames (one full turn)")->capture_default_str();
  sub->add_option("--test-frames", a->o.test_frames, "test frames (novel poses)")->capture_default_str();
  sub->add_option("--subject", a->o.subject,
                  "1: the default sample (hair shell, ponytail, skirt); 2: the harder benchmark subject (another "
                  "body shape, long loose hair, a loose long coat, view-dependent sheen)")
      ->capture_default_str();
  sub->add_option("--view-shading", a->o.view_shading,
                  "strength in [0, 2] of the view-dependent sheen and highlight on hair and garments (a texture "
                  "cannot hold it; default: 0 for subject 1, 0.5 for subject 2)");
  sub->add_flag("--still-arms", a->o.still_arms,
                "hold the arms in one A-pose over the turn (as PeopleSnapshot-style captures do) instead of swinging them");
  sub->add_option("--seed", a->o.seed, "subject colours, motion details, fit noise, procedural body")
      ->capture_default_str();
  sub->add_option("--fit-noise", a->fit_noise,
                  "sigma of Gaussian noise on the stored fits, both pose axis-angle (rad) and transl (m)")
      ->capture_default_str();
  CLI::Option* pose_opt =
      sub->add_option("--fit-noise-pose", a->fit_noise_pose, "sigma on every pose axis-angle value (rad; default --fit-noise)");
  CLI::Option* transl_opt = sub->add_option("--fit-noise-transl", a->fit_noise_transl, "sigma on transl (m; default --fit-noise)");
  sub->add_option("--supersample", a->o.supersample, "subsamples per pixel side (anti-aliasing)")->capture_default_str();
  sub->add_option("--texture-size", a->o.texture_size, "body texture side (0: automatic)")->capture_default_str();
  sub->add_option("--xhumans", a->xhumans,
                  "also write the frames as X-Humans takes DIR/train/Take1 and DIR/test/Take2 (800 x 1200 colour PNGs, "
                  "depth TIFFs, cameras.npz, SMPL-X pickles; --size at most 800) for haha convert --from xhumans");
  sub->callback([a, pose_opt, transl_opt] {
    const auto t0 = std::chrono::steady_clock::now();
    if (!(a->fit_noise >= 0 && a->fit_noise <= 1)) haha::fail("--fit-noise", "must be in [0, 1]");
    a->o.fit_noise.pose = pose_opt->count() ? a->fit_noise_pose : a->fit_noise;
    a->o.fit_noise.transl = transl_opt->count() ? a->fit_noise_transl : a->fit_noise;
    haha::validate_synth_options(a->o);  // cheap checks before any work
    if (a->resolution != "low" && a->resolution != "full")
      haha::fail("--body-resolution", "unknown value '" + a->resolution + "' (expected low or full)");
    const haha::BodyResolution res = haha::parse_body_resolution(a->resolution);
    const haha::BodyModel body = haha::synth_body(a->body, res, a->o.seed);
    static std::chrono::steady_clock::time_point start;
    start = t0;
    std::printf("  body: %d vertices (%s), %.2f s\n", body.num_verts, body.source.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    const haha::SynthSummary s = haha::write_synth_dataset(a->out, body, a->o, a->body.empty(), [](const std::string& line) {
      std::printf("  %s, %.2f s\n", line.c_str(), std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    });
    if (!a->xhumans.empty()) {
      haha::Dataset ds = haha::read_dataset(a->out, haha::LoadPixels::headers);
      for (auto [split, take] : {std::pair{haha::Split::train, "train/Take1"}, std::pair{haha::Split::test, "test/Take2"}}) {
        if (ds.indices(split).empty()) continue;
        haha::write_xhumans_take(ds, split, body, a->xhumans + "/" + take);
        std::printf("  X-Humans take %s/%s, %.2f s\n", a->xhumans.c_str(), take,
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("%s: %d train + %d test frames, %dx%d, f = %.1f px, min test-train pose gap %.2f rad, %.2f s\n",
                a->out.c_str(), s.train_frames, s.test_frames, a->o.size, a->o.size, double(s.camera.fx),
                s.min_pose_gap, secs);
  });
}
