// `haha synth`: the synthetic subject rendered into the native dataset format, plus a
// contact sheet, assembled beside the output directory and moved into place at the end.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "core/parallel.h"
#include "data/contact_sheet.h"
#include "data/dataset.h"
#include "data/stage_dir.h"
#include "data/synth_subject.h"
#include "io/body_model_io.h"

namespace haha {

namespace fs = std::filesystem;

void validate_synth_options(const SynthOptions& o) {
  if (o.size < 16 || o.size > 4096) fail("--size", std::to_string(o.size) + " is outside [16, 4096] pixels");
  if (o.train_frames < 1 || o.train_frames > 100000)
    fail("--frames", std::to_string(o.train_frames) + " is outside [1, 100000]");
  if (o.test_frames < 0 || o.test_frames > 100000)
    fail("--test-frames", std::to_string(o.test_frames) + " is outside [0, 100000]");
  if (!std::isfinite(o.fit_noise.pose) || o.fit_noise.pose < 0 || o.fit_noise.pose > 1)
    fail("--fit-noise-pose", "must be in [0, 1] radians");
  if (!std::isfinite(o.fit_noise.transl) || o.fit_noise.transl < 0 || o.fit_noise.transl > 1)
    fail("--fit-noise-transl", "must be in [0, 1] metres");
  if (o.supersample < 1 || o.supersample > 8) fail("--supersample", "must be in [1, 8]");
  // One supersampled raster holds ~24 bytes per subsample (3.6 GB at 12288 x 12288).
  if (o.size * o.supersample > 12288)
    fail("--supersample", "size x supersample = " + std::to_string(o.size * o.supersample) +
                              " exceeds 12288 (memory of the supersampled raster)");
  if (o.texture_size != 0 && (o.texture_size < 16 || o.texture_size > 8192))
    fail("--texture-size", "must be 0 (automatic) or in [16, 8192]");
  if (!std::isfinite(o.camera_distance) || o.camera_distance < 1 || o.camera_distance > 100)
    fail("--camera-distance", "must be in [1, 100] metres");
  if (o.sheet_train < 0 || o.sheet_test < 0) fail("contact sheet", "frame counts must be >= 0");
  if (o.subject != 1 && o.subject != 2)
    fail("--subject", std::to_string(o.subject) + " is not a subject (expected 1 or 2)");
  if (!(o.view_shading == -1 || (o.view_shading >= 0 && o.view_shading <= 2)))
    fail("--view-shading", "must be in [0, 2] (-1: the subject's default)");
}

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

}  // namespace

SynthSummary write_synth_dataset(const std::string& dir_in, const BodyModel& body, const SynthOptions& opt,
                                 bool save_body, void (*log)(const std::string&)) {
  validate_synth_options(opt);
  std::string dir = dir_in;
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  if (dir.empty()) fail("--out", "empty output directory");
  if (!dataset_dir_replaceable(dir)) fail(dir, "exists, is not empty and holds no dataset.json: refusing to replace it");
  auto say = [&](const std::string& s) {
    if (log) log(s);
  };

  SynthSubjectOptions so;
  so.seed = opt.seed;
  so.subject = opt.subject;
  so.texture_size = opt.texture_size > 0 ? opt.texture_size : (opt.size <= 256 ? 512 : (opt.size <= 512 ? 1024 : 2048));
  const SynthSubject subject = make_synth_subject(body, so);
  say("subject: " + std::to_string(subject.meshes.size()) + " garment meshes, texture " + std::to_string(so.texture_size) +
      " px");
  const SynthMotion motion = make_synth_motion(body, subject, opt.train_frames, opt.test_frames, opt.seed);
  SynthRenderer renderer(body, subject);
  const double shading = opt.view_shading < 0 ? default_view_shading(opt.subject) : opt.view_shading;
  renderer.set_view_shading(shading);  // before the per-thread copies are made

  std::vector<SmplxParams> truth = motion.train;
  truth.insert(truth.end(), motion.test.begin(), motion.test.end());
  const std::vector<SmplxParams> fits = perturb_fits(truth, opt.fit_noise, opt.seed);
  std::vector<const SmplxParams*> all;
  for (const SmplxParams& p : truth) all.push_back(&p);
  SynthSummary sum;
  sum.camera = synth_camera(renderer, all, opt.size, opt.camera_distance);
  sum.train_frames = opt.train_frames;
  sum.test_frames = opt.test_frames;
  sum.texture_size = so.texture_size;
  sum.min_pose_gap = 1e30;
  for (const SmplxParams& a : motion.test)
    for (const SmplxParams& b : motion.train) sum.min_pose_gap = std::min(sum.min_pose_gap, pose_distance(a, b));
  if (motion.test.empty()) sum.min_pose_gap = 0;
  say("motion and camera: f = " + std::to_string(sum.camera.fx) + " px");

  // Everything is assembled in `stage` (the writer itself stages in stage.tmp-<pid>).
  const fs::path stage = dir + ".synth-" + std::to_string(::getpid());
  {
    std::error_code ec;
    fs::remove_all(stage, ec);
  }
  DirGuard guard(stage.string());
  char src[320];
  if (opt.subject == 1)
    std::snprintf(src, sizeof src,
                  "haha synth: procedural clothed subject (hair, ponytail, skirt), seed %llu, fit noise %g rad / %g m",
                  static_cast<unsigned long long>(opt.seed), opt.fit_noise.pose, opt.fit_noise.transl);
  else
    std::snprintf(src, sizeof src,
                  "haha synth: procedural clothed subject 2 (long hair, coat), seed %llu, fit noise %g rad / %g m, "
                  "view shading %g",
                  static_cast<unsigned long long>(opt.seed), opt.fit_noise.pose, opt.fit_noise.transl, shading);
  DatasetWriter writer(stage.string(), opt.size, opt.size, 30.0, "neutral",
                       std::string(src) + "; body: " + (body.source.empty() ? std::string("?") : body.source));
  writer.set_premultiplied(1);  // rendered on black, box-filtered coverage as the mask

  const std::vector<int> sheet_train = spread(opt.train_frames, opt.sheet_train);
  const std::vector<int> sheet_test = spread(opt.test_frames, opt.sheet_test);
  std::vector<ContactSheetTile> tiles;
  const int N = int(truth.size());
  auto add_frame = [&](int i, const Image& rgb, const Image& mask) {
    const bool train = i < opt.train_frames;
    const int local = train ? i : i - opt.train_frames;
    DatasetFrame f;
    f.split = train ? Split::train : Split::test;
    f.camera = sum.camera;
    f.params = fits[i];
    f.source_index = local;
    writer.add(f, rgb, mask, &truth[i]);
    const auto& pick = train ? sheet_train : sheet_test;
    if (std::find(pick.begin(), pick.end(), local) != pick.end()) {
      ContactSheetTile t;
      t.image = opt.size > 128 ? resize_area(rgb, 128, 128) : rgb;
      t.label = std::string(train ? "train " : "test ") + std::to_string(local);
      t.new_row = !train && local == sheet_test.front();
      tiles.push_back(std::move(t));
    }
    if (N >= 10 && (i + 1) % (N / 10) == 0) say("rendered " + std::to_string(i + 1) + " / " + std::to_string(N));
  };
  // Small frames: one frame per thread (few, large parallel regions; the renderer's own
  // loops then run single-threaded inside). Large frames: one at a time, parallel
  // inside, which bounds memory to one supersampled raster.
  const int threads = std::max(1, num_threads());
  const bool by_frame = threads > 1 && opt.size <= 256;
  const int batch = by_frame ? 2 * threads : 1;
  std::vector<SynthRenderer> pool(by_frame ? size_t(threads) : 0, renderer);
  std::vector<Image> rgbs(static_cast<size_t>(batch)), masks(static_cast<size_t>(batch));
  for (int b0 = 0; b0 < N; b0 += batch) {
    const int n = std::min(batch, N - b0);
    if (by_frame) {
      parallel_for_dynamic(n, [&](int64_t k) {
        pool[size_t(thread_index())].render(sum.camera, truth[b0 + k], opt.supersample, kSynthAll, rgbs[k], masks[k]);
      });
    } else {
      renderer.render(sum.camera, truth[b0], opt.supersample, kSynthAll, rgbs[0], masks[0]);
    }
    for (int k = 0; k < n; ++k) add_frame(b0 + k, rgbs[size_t(k)], masks[size_t(k)]);
  }
  writer.finish();
  say("dataset written");

  ContactSheetOptions co;
  co.columns = 10;
  co.title = std::string(opt.subject == 1 ? "HAHA SYNTH" : "HAHA SYNTH SUBJECT 2") + ": SEED " + std::to_string(opt.seed) + ", " + std::to_string(opt.size) + " PX, " +
             std::to_string(opt.train_frames) + " TRAIN (TURNING) + " + std::to_string(opt.test_frames) +
             " TEST (NOVEL POSES)";
  write_contact_sheet((stage / "contact_sheet.png").string(), tiles, co);
  write_image((stage / "synth_texture.png").string(), subject.body_texture);
  if (save_body) save_body_model(body, (stage / "body_model.npz").string());

  move_dir_into_place(stage.string(), dir);
  guard.release();
  return sum;
}

}  // namespace haha
