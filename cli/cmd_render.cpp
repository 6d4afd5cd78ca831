// `haha render`: repose a packed avatar with a motion (AMASS-style or native SMPL-X
// parameters) and render every frame with the merged mesh + Gaussian renderer
// (format/avatar_loader.h) to DIR/frame_%05d.png, optionally encoding an mp4 with the
// ffmpeg command-line tool.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>

#include "command.h"
#include "parse_rgb.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "format/avatar_loader.h"
#include "io/motion.h"
#include "io/body_model_io.h"
#include "io/camera_json.h"
#include "io/image.h"

namespace {


// A front camera (looking along -Z, OpenCV axes) framing the box [lo, hi] with a margin.
haha::Camera framing_camera(haha::Vec3f lo, haha::Vec3f hi, int size) {
  haha::Camera c;
  c.width = c.height = size;
  c.fx = c.fy = 1.5f * float(size);  // ~37 degrees field of view
  c.cx = c.cy = 0.5f * float(size);
  const haha::Vec3f centre = 0.5f * (lo + hi);
  const float half = 0.5f * std::max(hi.x - lo.x, hi.y - lo.y) * 1.15f;
  const float dist = half * c.fx / (0.5f * float(size)) + 0.5f * (hi.z - lo.z);
  c.R = haha::Mat3f::identity();
  c.R.a[1][1] = -1;  // world +Y up -> image up; camera looks along world -Z
  c.R.a[2][2] = -1;
  const haha::Vec3f eye(centre.x, centre.y, centre.z + dist);
  c.t = -(c.R * eye);
  c.far_plane = dist * 4 + 10;
  return c;
}

}  // namespace

HAHA_COMMAND(render) {
  struct Opts {
    std::string avatar, motion, params, out, camera, video, model, background = "1,1,1";
    int size = 512, every = 1, max_frames = 0;
    double fps = 0;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("render", "Repose a .glb avatar with a motion and render the frames (PNG, optional mp4)");
  sub->add_option("avatar", o->avatar, "avatar .glb")->required();
  auto* mo = sub->add_option("--motion", o->motion, "AMASS-style motion .npz (poses (T,165|156), trans, mocap_frame_rate)");
  auto* po = sub->add_option("--params", o->params, "native SMPL-X parameter file (global_orient, body_pose, ...)");
  mo->excludes(po);
  sub->add_option("--out", o->out, "output directory for frame_%05d.png")->required();
  sub->add_option("--model", o->model,
                  "body model .npz the avatar was trained on: supplies its pose correctives when the file has none");
  sub->add_option("--camera", o->camera, "cam.json (io/camera_json.h); default: a front camera framing the motion");
  sub->add_option("--size", o->size, "image size of the default camera (pixels)")->capture_default_str();
  sub->add_option("--every", o->every, "render every N-th frame")->capture_default_str();
  sub->add_option("--max-frames", o->max_frames, "stop after this many rendered frames (0 = all)");
  sub->add_option("--background", o->background, "background colour r,g,b in [0, 1]")->capture_default_str();
  sub->add_option("--video", o->video, "also encode the frames as this .mp4 (needs the ffmpeg command)");
  sub->add_option("--fps", o->fps, "video frame rate (default: the motion's rate / every)");
  sub->callback([o] {
    if (o->motion.empty() && o->params.empty()) haha::fail("render", "give --motion or --params");
    if (o->size <= 0 || o->size > 16384) haha::fail("--size", "must be in 1..16384");
    if (o->every <= 0) haha::fail("--every", "must be positive");
    if (!o->video.empty() && std::system("ffmpeg -version > /dev/null 2>&1") != 0) {
      haha::fail("--video", "the ffmpeg command is not installed; render without --video or install ffmpeg");
    }
    const haha::Vec3f bg = haha::cli::parse_rgb(o->background);
    std::unique_ptr<haha::BodyModel> model;
    if (!o->model.empty()) model = std::make_unique<haha::BodyModel>(haha::load_body_model(o->model));
    const haha::AvatarRuntime avatar = haha::AvatarRuntime::load(o->avatar, model.get());
    if (avatar.missing_pose_correctives()) {
      std::fprintf(stderr,
                   "haha: warning: %s was trained with pose correctives, which it does not embed; without --model "
                   "the reposed body differs from the trainer's under strong poses\n",
                   o->avatar.c_str());
    }
    const haha::Motion motion = haha::read_motion(o->motion.empty() ? o->params : o->motion);
    std::vector<size_t> frames;
    for (size_t t = 0; t < motion.frames.size(); t += size_t(o->every)) {
      if (o->max_frames > 0 && int(frames.size()) >= o->max_frames) break;
      frames.push_back(t);
    }
    if (frames.empty()) haha::fail(o->motion.empty() ? o->params : o->motion, "no frames");

    haha::PosedAvatar posed;
    haha::Camera cam;
    if (!o->camera.empty()) {
      cam = haha::read_camera_json(o->camera);
    } else {  // frame the whole motion
      haha::Vec3f lo(INFINITY), hi(-INFINITY);
      for (size_t t : frames) {
        avatar.repose(motion.frames[t], posed);
        for (int v = 0; v < posed.num_verts; ++v)
          for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], posed.verts[size_t(v) * 3 + k]);
            hi[k] = std::max(hi[k], posed.verts[size_t(v) * 3 + k]);
          }
      }
      cam = framing_camera(lo, hi, o->size);
    }
    haha::ensure_directory(o->out);
    haha::AvatarRenderOptions ro;
    for (int c = 0; c < 3; ++c) ro.background[c] = bg[c];
    haha::AvatarRenderScratch scratch;
    haha::Image img(cam.width, cam.height, 3);
    for (size_t i = 0; i < frames.size(); ++i) {
      avatar.repose(motion.frames[frames[i]], posed);
      avatar.render(cam, posed, img.data, ro, scratch);
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05zu.png", i);
      haha::write_image((std::filesystem::path(o->out) / name).string(), img);
    }
    std::printf("%s: %zu frames (%dx%d) -> %s\n", o->avatar.c_str(), frames.size(), cam.width, cam.height, o->out.c_str());
    if (!o->video.empty()) {
      const double fps = o->fps > 0 ? o->fps : motion.fps / o->every;
      haha::write_atomically(o->video, [&](const std::string& tmp) {
        char rate[32];
        std::snprintf(rate, sizeof rate, "%.6g", fps);
        const std::string cmd = std::string("ffmpeg -y -loglevel error -framerate ") + rate + " -i '" +
                                (std::filesystem::path(o->out) / "frame_%05d.png").string() +
                                "' -c:v libx264 -pix_fmt yuv420p -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' -f mp4 '" + tmp + "'";
        if (std::system(cmd.c_str()) != 0) haha::fail(o->video, "ffmpeg failed to encode the frames");
      });
      std::printf("%s: %zu frames at %.3g fps\n", o->video.c_str(), frames.size(), fps);
    }
  });
}
