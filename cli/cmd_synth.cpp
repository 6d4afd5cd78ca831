// `haha synth`: the embedded sample (app/synth_run.h). A clothed synthetic subject (textured
// skin and clothes, plus hair, ponytail and skirt that leave the body surface; or, with
// --subject 2, long loose hair and a loose long coat on another body shape); with --motion,
// that subject in a motion file's poses.
#include <memory>

#include "app/synth_run.h"
#include "command.h"

HAHA_COMMAND(synth) {
  auto a = std::make_shared<haha::SynthRunOptions>();
  auto* sub = app.add_subcommand("synth", "Render the synthetic clothed subject as a dataset (the embedded sample)");
  sub->add_option("--out", a->out, "output dataset directory")->required();
  sub->add_option("--body", a->body, "body model .npz (default: the procedural body, saved as OUT/body_model.npz)");
  sub->add_option("--body-resolution", a->resolution, "procedural body without --body: low or full")
      ->capture_default_str();
  sub->add_option("--size", a->synth.size, "image side in pixels")->capture_default_str();
  auto* fr = sub->add_option("--frames", a->synth.train_frames, "training frames (one full turn)")->capture_default_str();
  auto* tf = sub->add_option("--test-frames", a->synth.test_frames, "test frames (novel poses)")->capture_default_str();
  auto* mo = sub->add_option("--motion", a->motion,
                             "instead of the turn and the novel poses, render the subject in the poses of this motion "
                             "file (haha motion's, AMASS-style or SMPL-X parameters, as haha render reads them), "
                             "every frame a test frame with exact fits; the person is held in place (docs/data.md)");
  mo->excludes(fr)->excludes(tf);
  sub->add_option("--every", a->every, "with --motion: keep every N-th frame")->capture_default_str()->needs(mo);
  sub->add_option("--max-frames", a->max_frames, "with --motion: keep at most this many frames (0 = all)")->needs(mo);
  sub->add_option("--rate", a->rate,
                  "with --motion: first resample the motion to this many frames per second (slerp); default: its own rate")
      ->needs(mo);
  sub->add_flag("--part-masks", a->part_masks,
                "also write part_masks/%06d.png beside masks/: per pixel the fraction covered by the garment around "
                "both legs (skirt, coat tails), 0 on the body");
  sub->add_option("--subject", a->synth.subject,
                  "1: the default sample (hair shell, ponytail, skirt); 2: the harder benchmark subject (another "
                  "body shape, long loose hair, a loose long coat, view-dependent sheen)")
      ->capture_default_str();
  sub->add_option("--view-shading", a->synth.view_shading,
                  "strength in [0, 2] of the view-dependent sheen and highlight on hair and garments (a texture "
                  "cannot hold it; default: 0 for subject 1, 0.5 for subject 2)");
  sub->add_flag("--still-arms", a->synth.still_arms,
                "hold the arms in one A-pose over the turn (as PeopleSnapshot-style captures do) instead of swinging them")
      ->excludes(mo);
  sub->add_flag("--unseen", a->synth.unseen,
                "also render 3 views the turn never shows, split \"unseen\" with exact fits and their own cameras: "
                "from below the chin looking up, from above the head looking down, the arms raised seen from the "
                "front (scored by haha eval --split unseen, never trained on)")
      ->excludes(mo);
  sub->add_option("--seed", a->synth.seed, "subject colours, motion details, fit noise, procedural body")
      ->capture_default_str();
  sub->add_option("--fit-noise", a->fit_noise,
                  "sigma of Gaussian noise on the stored fits, both pose axis-angle (rad) and transl (m)")
      ->capture_default_str()
      ->excludes(mo);
  sub->add_option("--fit-noise-pose", a->fit_noise_pose, "sigma on every pose axis-angle value (rad; default --fit-noise)")
      ->excludes(mo);
  sub->add_option("--fit-noise-transl", a->fit_noise_transl, "sigma on transl (m; default --fit-noise)")->excludes(mo);
  sub->add_option("--supersample", a->synth.supersample, "subsamples per pixel side (anti-aliasing)")->capture_default_str();
  sub->add_option("--texture-size", a->synth.texture_size, "body texture side (0: automatic)")->capture_default_str();
  sub->add_option("--xhumans", a->xhumans,
                  "also write the frames as X-Humans takes DIR/train/Take1 and DIR/test/Take2 (800 x 1200 colour PNGs, "
                  "depth TIFFs, cameras.npz, SMPL-X pickles; --size at most 800) for haha convert --from xhumans");
  sub->callback([a] { haha::run_synth(*a); });
}
