#include "app/render_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <vector>

#include "body/garment_clearance.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "format/animation.h"
#include "format/avatar_loader.h"
#include "io/body_model_io.h"
#include "io/camera_json.h"
#include "io/image.h"
#include "io/motion.h"

namespace haha {

namespace {

// A front camera (looking along -Z, OpenCV axes) framing the box [lo, hi] with a margin.
Camera framing_camera(Vec3f lo, Vec3f hi, int size) {
  Camera c;
  c.width = c.height = size;
  c.fx = c.fy = 1.5f * float(size);  // ~37 degrees field of view
  c.cx = c.cy = 0.5f * float(size);
  const Vec3f centre = 0.5f * (lo + hi);
  const float half = 0.5f * std::max(hi.x - lo.x, hi.y - lo.y) * 1.15f;
  const float dist = half * c.fx / (0.5f * float(size)) + 0.5f * (hi.z - lo.z);
  c.R = Mat3f::identity();
  c.R.a[1][1] = -1;  // world +Y up -> image up; camera looks along world -Z
  c.R.a[2][2] = -1;
  const Vec3f eye(centre.x, centre.y, centre.z + dist);
  c.t = -(c.R * eye);
  c.far_plane = dist * 4 + 10;
  return c;
}

// How far the legs poke through the avatar's garment over the rendered frames (nothing for
// an avatar without a garment): fed each posed frame, printed as one line.
class GarmentClearanceReport {
 public:
  explicit GarmentClearanceReport(const AvatarLoader& avatar) : body_(avatar.avatar().body) {
    if (!body_.has_garment()) return;
    PosedAvatar rest;
    avatar.repose(SmplxParams{}, rest);
    covered_ = garment_covered_vertices(body_, rest.verts.data());
  }
  void add(const PosedAvatar& posed) {
    if (!body_.has_garment()) return;
    const GarmentClearance c = garment_clearance(body_, covered_, posed.verts.data());
    frames_through_ += c.outside > 0;
    share_ = std::max(share_, c.share());
    if (c.max_depth > worst_) worst_ = c.max_depth, worst_frame_ = frames_;
    ++frames_;
  }
  void print() const {
    if (!body_.has_garment()) return;
    std::printf("garment: %zu body vertices inside it at rest; a leg through it in %d of %d frames, at most %.1f%% of "
                "them, deepest %.1f mm (frame %d)\n",
                covered_.size(), frames_through_, frames_, 100 * share_, 1000 * worst_, worst_frame_);
  }

 private:
  const BodyModel& body_;
  std::vector<int> covered_;
  int frames_ = 0, frames_through_ = 0, worst_frame_ = 0;
  double share_ = 0, worst_ = 0;
};

}  // namespace

void run_render(const RenderRunOptions& o) {
  if (o.motion.empty() && o.params.empty() && o.animation.empty()) fail("render", "give --motion, --params or --animation");
  if (o.size <= 0 || o.size > 16384) fail("--size", "must be in 1..16384");
  if (o.every <= 0) fail("--every", "must be positive");
  if (o.rate < 0 || !std::isfinite(o.rate) || o.rate > 10000) fail("--rate", "must be in (0, 10000] frames per second");
  if (!o.video.empty() && std::system("ffmpeg -version > /dev/null 2>&1") != 0) {
    fail("--video", "the ffmpeg command is not installed; render without --video or install ffmpeg");
  }
  std::unique_ptr<BodyModel> model;
  if (!o.model.empty()) model = std::make_unique<BodyModel>(load_body_model(o.model));
  const AvatarLoader avatar = AvatarLoader::load(o.avatar, model.get(), o.max_gaussians);
  const std::string source = !o.animation.empty() ? o.avatar : o.motion.empty() ? o.params : o.motion;
  // A file's animation becomes a motion like any other: one render path for both.
  Motion motion = !o.animation.empty()
                      ? animation_motion(avatar.animations()[find_animation(avatar.animations(), o.animation, o.avatar)])
                      : read_motion(source, model.get());
  PosedAvatar posed;
  {
    // AMASS motions are Z-up: turn them about the avatar's own rest pelvis (the posed
    // pelvis at zero pose and zero transl), which depends on its baked-in shape.
    avatar.repose(SmplxParams{}, posed);
    motion_to_y_up(motion, {posed.joints[0], posed.joints[1], posed.joints[2]});
  }
  if (o.rate > 0) motion = resample_motion(motion, o.rate);
  std::vector<size_t> frames;
  for (size_t t = 0; t < motion.frames.size(); t += size_t(o.every)) {
    if (o.max_frames > 0 && int(frames.size()) >= o.max_frames) break;
    frames.push_back(t);
  }
  if (frames.empty()) fail(source, "no frames");

  Camera cam;
  if (!o.camera.empty()) {
    cam = read_camera_json(o.camera);
  } else {  // frame the whole motion
    Vec3f lo(INFINITY), hi(-INFINITY);
    for (size_t t : frames) {
      avatar.repose(motion.frames[t], posed);
      for (int v = 0; v < posed.num_verts; ++v)
        for (int k = 0; k < 3; ++k) {
          lo[k] = std::min(lo[k], posed.verts[size_t(v) * 3 + k]);
          hi[k] = std::max(hi[k], posed.verts[size_t(v) * 3 + k]);
        }
    }
    cam = framing_camera(lo, hi, o.size);
  }
  // Warned once every input has been read, so a bad input's error stays the only line.
  if (avatar.missing_pose_correctives()) {
    std::fprintf(stderr,
                 "haha: warning: %s was trained with pose correctives, which it does not embed; without --model "
                 "the reposed body differs from the trainer's under strong poses\n",
                 o.avatar.c_str());
  }
  ensure_directory(o.out);
  AvatarRenderOptions ro;
  for (int c = 0; c < 3; ++c) ro.background[c] = o.background[c];
  AvatarRenderScratch scratch;
  Image img(cam.width, cam.height, 3);
  GarmentClearanceReport clearance(avatar);
  for (size_t i = 0; i < frames.size(); ++i) {
    avatar.repose(motion.frames[frames[i]], posed);
    clearance.add(posed);
    avatar.render(cam, posed, img.data, ro, scratch);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05zu.png", i);
    write_image((std::filesystem::path(o.out) / name).string(), img);
  }
  std::printf("%s: %zu frames (%dx%d) -> %s\n", o.avatar.c_str(), frames.size(), cam.width, cam.height, o.out.c_str());
  clearance.print();
  if (!o.video.empty()) {
    const double fps = o.fps > 0 ? o.fps : motion.fps / o.every;
    write_atomically(o.video, [&](const std::string& tmp) {
      char rate[32];
      std::snprintf(rate, sizeof rate, "%.6g", fps);
      const std::string cmd = std::string("ffmpeg -y -loglevel error -framerate ") + rate + " -i '" +
                              (std::filesystem::path(o.out) / "frame_%05d.png").string() +
                              "' -c:v libx264 -pix_fmt yuv420p -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' -f mp4 '" + tmp + "'";
      if (std::system(cmd.c_str()) != 0) fail(o.video, "ffmpeg failed to encode the frames");
    });
    std::printf("%s: %zu frames at %.3g fps\n", o.video.c_str(), frames.size(), fps);
  }
}

}  // namespace haha
