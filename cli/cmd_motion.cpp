// `haha motion`: writes a short procedural SMPL-X motion for `haha render --motion`
// (app/motion_run.h), a video's (app/motion_video_run.h) or another rig's
// (app/motion_retarget_run.h), or a motion as BVH.
#include <memory>

#include "app/motion_retarget_run.h"
#include "app/motion_run.h"
#include "app/motion_video_run.h"
#include "command.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "data/synth_dataset.h"
#include "fit/fit_video.h"

HAHA_COMMAND(motion) {
  auto o = std::make_shared<haha::MotionRunOptions>();
  auto* sub = app.add_subcommand("motion",
                                 "Write an SMPL-X motion (AMASS-style .npz) for haha render: procedural, from a video or "
                                 "retargeted from another rig; or a motion as BVH");
  sub->add_option("--out", o->out, "output .npz (poses (T,165), trans (T,3), mocap_frame_rate, up); .bvh with --in")->required();
  sub->add_option("--kind", o->kind, "wave, walk, turn or kick (a high front kick with each leg)")->capture_default_str();
  sub->add_option("--frames", o->frames, "number of frames (one loop of the motion)")->capture_default_str();
  auto* fps = sub->add_option("--fps", o->fps, "frame rate stored in the file (with --retarget: resample to it; default the file's)")
                  ->capture_default_str();
  auto r = std::make_shared<haha::MotionRetargetOptions>();
  auto* retarget = sub->add_option("--retarget", r->in,
                                   "a skeleton animation (BVH, FBX, glTF/GLB, Collada) retargeted onto the SMPL-X body");
  sub->add_option("--take", r->take, "with --retarget: the animation to read (default: the first)");
  sub->add_option("--map", r->map, "with --retarget: JSON bone map {\"bone\": \"smplx_joint\"} (default: the best built-in map)");
  auto bvh_in = std::make_shared<std::string>();
  auto* in = sub->add_option("--in", *bvh_in, "a motion .npz to write as BVH (--out M.bvh): the body's skeleton, cm, Y up");
  auto v = std::make_shared<haha::MotionVideoOptions>();
  auto model = std::make_shared<std::string>();
  auto* from = sub->add_option("--from-video", v->fit.input,
                               "a video (or image folder) of a person: its fitted poses as the motion (haha fit-video's fit)");
  sub->add_option("--video-fps", v->fit.fps, "resample the video to this rate first (0: every frame)");
  sub->add_option("--focal-35mm", v->fit.focal_35mm, "the lens's 35 mm-equivalent focal length in mm (with --from-video)");
  sub->add_option("--keypoint-tool", v->fit.keypoint_tool, "tools/keypoints folder (default: found next to haha)");
  sub->add_option("--model", *model, "SMPL-X model .npz to fit and to scale the motion to (default: the procedural body)");
  sub->add_option("--truth", v->truth, "dataset with the video's true fits: print joint, jitter and foot-sliding errors");
  sub->add_flag("--no-foot-lock", [v, r](int64_t) { v->motion.lock_feet = r->retarget.lock_feet = false; },
                "do not hold feet in place during contacts");
  sub->callback([o, v, r, bvh_in, model, from, retarget, in, fps] {
    if (retarget->count() + in->count() + from->count() > 1) throw haha::Error("--retarget, --in and --from-video: give one");
    if (retarget->count() > 0) {
      r->fps = fps->count() > 0 ? o->fps : 0;
      r->out = o->out;
      return haha::run_motion_retarget(*r, haha::synth_body(*model, haha::BodyResolution::full, 0));
    }
    if (in->count() > 0) {
      if (o->out.size() < 4 || o->out.compare(o->out.size() - 4, 4, ".bvh") != 0) throw haha::Error(o->out + ": --in writes BVH: give --out M.bvh");
      return haha::run_motion_to_bvh(*bvh_in, o->out, haha::synth_body(*model, haha::BodyResolution::full, 0));
    }
    if (from->count() == 0) return haha::run_motion(*o);
    v->out = o->out;
    haha::install_interrupt_handler();
    const haha::BodyModel body = haha::synth_body(*model, haha::BodyResolution::full, 0);
    haha::run_motion_from_video(*v, body, [&body](const std::vector<haha::FitVideoInputFrame>& frames,
                                                  const haha::FitVideoOptions& vo) { return haha::fit_video(body, frames, vo); });
  });
}
