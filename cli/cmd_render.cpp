// `haha render`: repose a packed avatar with a motion and render the frames (app/render_run.h).
#include <memory>
#include <string>

#include "app/render_run.h"
#include "command.h"
#include "parse_rgb.h"

HAHA_COMMAND(render) {
  struct Opts {
    haha::RenderRunOptions run;
    std::string background = "1,1,1";
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("render", "Repose a .glb avatar with a motion and render the frames (PNG, optional mp4)");
  sub->add_option("avatar", o->run.avatar, "avatar .glb")->required();
  auto* mo = sub->add_option("--motion", o->run.motion, "AMASS-style motion .npz (poses (T,165|156), trans, mocap_frame_rate; Z-up unless it has `up`)");
  auto* po = sub->add_option("--params", o->run.params, "native SMPL-X parameter file (global_orient, body_pose, ...)");
  auto* an = sub->add_option("--animation", o->run.animation, "play the avatar's own glTF animation NAME or INDEX (haha pack --animation)");
  mo->excludes(po);
  an->excludes(mo);
  an->excludes(po);
  sub->add_option("--out", o->run.out, "output directory for frame_%05d.png")->required();
  sub->add_option("--model", o->run.model,
                  "body model .npz the avatar was trained on: supplies its pose correctives when the file has none");
  sub->add_option("--max-gaussians", o->run.max_gaussians,
                  "of an avatar packed with --lod, load only the importance tiers that fit in N Gaussians (the first always)");
  sub->add_option("--camera", o->run.camera, "cam.json (io/camera_json.h); default: a front camera framing the motion");
  sub->add_option("--size", o->run.size, "image size of the default camera (pixels)")->capture_default_str();
  sub->add_option("--every", o->run.every, "render every N-th frame")->capture_default_str();
  sub->add_option("--max-frames", o->run.max_frames, "stop after this many rendered frames (0 = all)");
  sub->add_option("--background", o->background, "background colour r,g,b in [0, 1]")->capture_default_str();
  sub->add_option("--video", o->run.video, "also encode the frames as this .mp4 (needs the ffmpeg command)");
  sub->add_option("--rate", o->run.rate,
                  "resample the motion to this many frames per second (slerp); default: keep the mocap rate");
  sub->add_option("--fps", o->run.fps, "video frame rate (default: the motion's rate / every)");
  sub->callback([o] {
    const haha::Vec3f bg = haha::cli::parse_rgb(o->background);
    for (int c = 0; c < 3; ++c) o->run.background[c] = bg[c];
    haha::run_render(o->run);
  });
}
