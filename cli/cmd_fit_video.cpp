// `haha fit-video`: a plain monocular video (or a folder of images) to a native dataset with
// SMPL-X fits (app/fit_video_run.h: frames, keypoint tool, the fit of fit/fit_video.h).
#include <cstdio>
#include <memory>
#include <string>

#include "app/fit_video_run.h"
#include "fit/fit_video.h"
#include "command.h"
#include "core/interrupt.h"
#include "data/synth_dataset.h"

HAHA_COMMAND(fit_video) {
  struct Opts {
    haha::FitVideoRunOptions o;
    std::string body;
    bool no_crop = false;
  };
  auto a = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("fit-video", "Keypoints, masks and SMPL-X fits from a plain video: a dataset for haha train");
  sub->add_option("input", a->o.input, "video file (decoded with ffmpeg) or folder of .png / .jpg images")->required();
  sub->add_option("--out", a->o.out, "output dataset directory")->required();
  sub->add_option("--fps", a->o.fps, "resample the video to this rate (0: every frame; a folder's rate, default 30)")
      ->capture_default_str();
  auto* focal = sub->add_option("--focal", a->o.focal_px, "focal length in pixels (static camera)");
  auto* focal_35mm = sub->add_option("--focal-35mm", a->o.focal_35mm,
                                     "the lens's 35 mm-equivalent focal length in mm (a phone's spec sheet: e.g. 26)")
                         ->excludes(focal);
  auto* fov = sub->add_option("--fov", a->o.fov_deg,
                              "horizontal field of view in degrees (default: the focal length the video or the "
                              "images record, else this guess)")
                  ->capture_default_str()
                  ->excludes(focal)
                  ->excludes(focal_35mm);
  sub->add_option("--frames", a->o.frames, "A:B:S: frames A (first) to B (exclusive; empty = end) every S, after decoding");
  sub->add_option("--test-every", a->o.test_every, "every Nth kept frame goes to the test split (0: none)")
      ->capture_default_str();
  sub->add_option("--robust-smoothness", a->o.robust_smoothness,
                  "sigma (rad) of a robust smoothness of the body joints, for stills or fast moves (0: quadratic)")
      ->capture_default_str();
  sub->add_option("--test-from", a->o.test_from,
                  "kept frames decoded at or after frame K (before --frames) go to the test split (0: none)")
      ->capture_default_str();
  sub->add_option("--mask", a->o.mask, "person mask of the keypoint tool: pose | selfie")->capture_default_str();
  sub->add_option("--keypoints", a->o.keypoints,
                  "keypoint models: accurate (BlazePose flip-averaged, limbs averaged with MoveNet) | fast "
                  "(BlazePose once per frame, ~1.5x faster, less accurate)")
      ->capture_default_str();
  sub->add_option("--truth", a->o.truth,
                  "dataset with the video's true fits (frames in order, e.g. make-test-video.sh's synth/): "
                  "report the body-joint error after Procrustes (PA-MPJPE)");
  sub->add_flag("--no-crop", a->no_crop,
                "keep the whole frames (default: crop the dataset to the person over the kept frames, "
                "dataset.json source_crop)");
  sub->add_option("--matting", a->o.matting,
                  "auto: with a static camera, alpha and colour at the person's edge against the background "
                  "plate the video shows (a premultiplied dataset) | off: the keypoint tool's masks")
      ->capture_default_str();
  sub->add_option("--keypoint-tool", a->o.keypoint_tool, "tools/keypoints folder (default: found next to haha)");
  sub->add_option("--model", a->body,
                  "SMPL-X model .npz to fit (default: the procedural body, also written to OUT/body_model.npz)");
  sub->callback([a, fov] {
    a->o.fov_given = fov->count() > 0;
    a->o.crop = !a->no_crop;
    haha::install_interrupt_handler();  // Ctrl-C: `haha: error: interrupted`, nothing left beside OUT
    haha::validate_fit_video_options(a->o);
    const haha::BodyModel body = haha::synth_body(a->body, haha::BodyResolution::full, 0);
    a->o.save_body = a->body.empty();
    const haha::FitVideoSummary s =
        haha::run_fit_video(a->o, body, [&body](const std::vector<haha::FitVideoInputFrame>& frames,
                                                const haha::FitVideoOptions& vo) { return haha::fit_video(body, frames, vo); });
    std::printf("%s: %d frames kept (%d train, %d test), %d dropped; keypoint error %.2f px, silhouette IoU %.3f",
                s.out.c_str(), s.kept, s.train, s.test, s.dropped, s.mean_reprojection_px, s.mean_silhouette_iou);
    if (!s.truth.empty())
      std::printf("; body-joint error after Procrustes %.1f mm (PA-MPJPE), orientation %.1f deg", s.mean_joint_error_mm,
                  s.mean_orient_error_deg);
    std::printf("\n");
  });
}
