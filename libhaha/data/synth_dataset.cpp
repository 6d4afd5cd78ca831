// `haha synth`: the synthetic subject's frames (synth/synth_subject.h) written in the native
// dataset format, plus a contact sheet, assembled beside the output directory and moved
// into place at the end.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>

#include "core/error.h"
#include "data/contact_sheet.h"
#include "data/dataset.h"
#include "data/stage_dir.h"
#include "data/synth_dataset.h"
#include "io/body_model_io.h"
#include "io/image.h"

namespace haha {

namespace fs = std::filesystem;

BodyModel synth_body(const std::string& path, BodyResolution resolution, uint64_t seed) {
  if (!path.empty()) return load_body_model(path);
  ProceduralBodyOptions o;
  o.resolution = resolution;
  o.seed = seed;
  return make_procedural_body(o);
}

namespace {

// k indices spread evenly over [0, n).
std::vector<int> spread(int n, int k) {
  std::vector<int> out;
  if (n <= 0 || k <= 0) return out;
  if (k >= n) k = n;
  for (int i = 0; i < k; ++i) out.push_back(int((int64_t(i) * n) / k));
  return out;
}

// The output directory without trailing slashes, checked before any work.
std::string checked_out_dir(const std::string& dir_in) {
  std::string dir = dir_in;
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  if (dir.empty()) fail("--out", "empty output directory");
  if (!dataset_dir_replaceable(dir)) fail(dir, "exists, is not empty and holds no dataset.json: refusing to replace it");
  return dir;
}

struct SceneWrite {
  std::string source;  // dataset.json's "source" (the body is appended)
  std::string title;   // of the contact sheet
  double fps = 30;     // dataset.json's "fps"
  bool save_body = false;
  bool part_masks = false;
};

// Writes `scene` as the dataset `dir` (already checked), assembled beside it and moved into
// place at the end.
SynthSummary write_scene(const std::string& dir, const BodyModel& body, const SynthScene& scene, const SceneWrite& w,
                         const std::function<void(const std::string&)>& say) {
  const SynthOptions& opt = scene.options;
  say("subject: " + std::to_string(scene.subject.meshes.size()) + " garment meshes, texture " +
      std::to_string(scene.texture_size) + " px");
  SynthSummary sum;
  sum.camera = scene.camera;
  sum.train_frames = opt.train_frames;
  sum.test_frames = opt.test_frames;
  sum.unseen_frames = int(scene.unseen_cameras.size());
  sum.texture_size = scene.texture_size;
  sum.min_pose_gap = scene.min_pose_gap;
  say("motion and camera: f = " + std::to_string(sum.camera.fx) + " px");

  // Everything is assembled in `stage` (the writer itself stages in stage.tmp-<pid>, the
  // part masks in stage.parts until the writer has moved its folder to `stage`).
  const fs::path stage = dir + ".synth-" + std::to_string(::getpid());
  const fs::path parts = stage.string() + ".parts";
  {
    std::error_code ec;
    fs::remove_all(stage, ec);
    fs::remove_all(parts, ec);
  }
  DirGuard guard(stage.string()), parts_guard(parts.string());
  if (w.part_masks) fs::create_directories(parts);
  DatasetWriter writer(stage.string(), opt.size, opt.size, w.fps, "neutral",
                       w.source + "; body: " + (body.source.empty() ? std::string("?") : body.source));
  writer.set_premultiplied(1);  // rendered on black, box-filtered coverage as the mask
  // Noisy fits stand in for estimated ones: `haha train` then picks the settings for them.
  writer.set_fits(opt.fit_noise.pose > 0 || opt.fit_noise.transl > 0 ? Fits::estimated : Fits::exact);

  const std::vector<int> sheet_train = spread(opt.train_frames, opt.sheet_train);
  const std::vector<int> sheet_test = spread(opt.test_frames, opt.sheet_test);
  std::vector<ContactSheetTile> tiles;
  const int N = int(scene.truth.size());
  auto add_frame = [&](int i, const Image& rgb, const Image& mask, const Image* garment) {
    const bool train = i < opt.train_frames, unseen = i >= scene.first_unseen();
    const int local = train ? i : unseen ? i - scene.first_unseen() : i - opt.train_frames;
    DatasetFrame f;
    f.split = train ? Split::train : unseen ? Split::unseen : Split::test;
    f.camera = scene.frame_camera(i);
    f.params = scene.fits[i];
    f.source_index = local;
    // Named as the writer names the frame's image and mask (its i-th frame).
    char name[32];
    std::snprintf(name, sizeof name, "%06d.png", writer.num_frames());
    writer.add(f, rgb, mask, &scene.truth[i]);
    if (garment) write_image((parts / name).string(), *garment);
    const auto& pick = train ? sheet_train : sheet_test;
    if (unseen || std::find(pick.begin(), pick.end(), local) != pick.end()) {  // every unseen view
      ContactSheetTile t;
      t.image = opt.size > 128 ? resize_area(rgb, 128, 128) : rgb;
      t.label = unseen ? std::string(synth_unseen_view_name(local))
                       : std::string(train ? "train " : "test ") + std::to_string(local);
      t.new_row = (unseen && local == 0) || (!train && !unseen && local == sheet_test.front());
      tiles.push_back(std::move(t));
    }
    if (N >= 10 && (i + 1) % (N / 10) == 0) say("rendered " + std::to_string(i + 1) + " / " + std::to_string(N));
  };
  render_synth_frames(body, scene, w.part_masks, add_frame);
  writer.finish();
  if (w.part_masks) fs::rename(parts, stage / kSynthPartMaskDir);
  say("dataset written");

  ContactSheetOptions co;
  co.columns = 10;
  co.title = w.title;
  write_contact_sheet((stage / "contact_sheet.png").string(), tiles, co);
  write_image((stage / "synth_texture.png").string(), scene.subject.body_texture);
  if (w.save_body) save_body_model(body, (stage / "body_model.npz").string());

  move_dir_into_place(stage.string(), dir);
  guard.release();
  return sum;
}

std::string subject_source(const SynthOptions& opt, double view_shading) {
  char src[320];
  if (opt.subject == 1)
    std::snprintf(src, sizeof src,
                  "haha synth: procedural clothed subject (hair, ponytail, skirt), seed %llu, fit noise %g rad / %g m",
                  static_cast<unsigned long long>(opt.seed), opt.fit_noise.pose, opt.fit_noise.transl);
  else
    std::snprintf(src, sizeof src,
                  "haha synth: procedural clothed subject 2 (long hair, coat), seed %llu, fit noise %g rad / %g m, "
                  "view shading %g",
                  static_cast<unsigned long long>(opt.seed), opt.fit_noise.pose, opt.fit_noise.transl, view_shading);
  return src;
}

std::function<void(const std::string&)> logger(void (*log)(const std::string&)) {
  return [log](const std::string& s) {
    if (log) log(s);
  };
}

}  // namespace

SynthSummary write_synth_dataset(const std::string& dir_in, const BodyModel& body, const SynthOptions& opt,
                                 bool save_body, void (*log)(const std::string&), bool part_masks) {
  validate_synth_options(opt);
  const std::string dir = checked_out_dir(dir_in);
  const SynthScene scene = make_synth_scene(body, opt);
  SceneWrite w;
  w.source = subject_source(opt, scene.view_shading) + (opt.still_arms ? ", arms still" : "") +
             (opt.unseen ? ", unseen views (below chin, above head, arms raised)" : "");
  w.title = std::string(opt.subject == 1 ? "HAHA SYNTH" : "HAHA SYNTH SUBJECT 2") + ": SEED " + std::to_string(opt.seed) +
            ", " + std::to_string(opt.size) + " PX, " + std::to_string(opt.train_frames) + " TRAIN (TURNING) + " +
            std::to_string(opt.test_frames) + " TEST (NOVEL POSES)" + (opt.unseen ? " + UNSEEN VIEWS" : "");
  w.save_body = save_body;
  w.part_masks = part_masks;
  return write_scene(dir, body, scene, w, logger(log));
}

SynthSummary write_synth_motion_dataset(const std::string& dir_in, const BodyModel& body, const SynthOptions& opt,
                                        const Motion& motion_in, bool save_body, bool part_masks,
                                        void (*log)(const std::string&)) {
  const std::string dir = checked_out_dir(dir_in);
  if (motion_in.frames.empty()) fail(motion_in.source, "no frames");
  SynthScene scene = make_synth_subject_scene(body, opt);
  // A Z-up (AMASS) motion turns upright about the subject's own rest pelvis.
  Motion motion = motion_in;
  const std::vector<float>& J = scene.subject.rest_joints;
  motion_to_y_up(motion, {J[0], J[1], J[2]});
  set_synth_scene_motion(body, scene, motion.frames);
  SceneWrite w;
  w.source = subject_source(scene.options, scene.view_shading) + ", in the poses of " + motion.source + " (" +
             std::to_string(motion.frames.size()) + " frames, all test)";
  w.title = std::string(opt.subject == 1 ? "HAHA SYNTH" : "HAHA SYNTH SUBJECT 2") + ": " +
            std::to_string(opt.size) + " PX, " + std::to_string(motion.frames.size()) + " MOTION FRAMES";
  w.fps = motion.fps;
  w.save_body = save_body;
  w.part_masks = part_masks;
  return write_scene(dir, body, scene, w, logger(log));
}

}  // namespace haha
