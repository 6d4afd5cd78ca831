// The frames of `haha synth` in memory: options, the scene (subject, motions, fits,
// camera) and the rendering loop. data/synth_dataset.cpp writes them as a dataset.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/parallel.h"
#include "synth/synth_subject.h"

namespace haha {

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

namespace {

// The subject of the options (texture size automatic when 0) and its view shading.
SynthScene scene_subject(const BodyModel& body, const SynthOptions& opt) {
  SynthScene sc;
  sc.options = opt;
  SynthSubjectOptions so;
  so.seed = opt.seed;
  so.subject = opt.subject;
  so.texture_size = opt.texture_size > 0 ? opt.texture_size : (opt.size <= 256 ? 512 : (opt.size <= 512 ? 1024 : 2048));
  sc.subject = make_synth_subject(body, so);
  sc.texture_size = so.texture_size;
  sc.view_shading = opt.view_shading < 0 ? default_view_shading(opt.subject) : opt.view_shading;
  return sc;
}

Camera scene_camera(const BodyModel& body, const SynthScene& sc) {
  std::vector<const SmplxParams*> all;
  for (const SmplxParams& p : sc.truth) all.push_back(&p);
  return synth_camera(SynthRenderer(body, sc.subject), all, sc.options.size, sc.options.camera_distance);
}

// The unseen views (synth_subject.h SynthUnseenView): their poses appended to the truth,
// each with its own camera at the scene camera's distance.
void add_unseen_views(const BodyModel& body, SynthScene& sc) {
  const std::vector<SmplxParams> poses = make_synth_unseen_poses(body, sc.subject);
  SynthRenderer renderer(body, sc.subject);
  const double d = sc.options.camera_distance;
  for (int v = 0; v < kSynthUnseenViews; ++v) {
    const double elevation = v == kUnseenBelow ? kUnseenBelowElevation : v == kUnseenAbove ? kUnseenAboveElevation : 0.0;
    sc.unseen_cameras.push_back(synth_view_camera(renderer, poses[size_t(v)], sc.options.size, d, elevation));
  }
  sc.truth.insert(sc.truth.end(), poses.begin(), poses.end());
}

}  // namespace

SynthScene make_synth_scene(const BodyModel& body, const SynthOptions& opt) {
  validate_synth_options(opt);
  SynthScene sc = scene_subject(body, opt);
  const SynthMotion motion = make_synth_motion(body, sc.subject, opt.train_frames, opt.test_frames, opt.seed, opt.still_arms);
  sc.truth = motion.train;
  sc.truth.insert(sc.truth.end(), motion.test.begin(), motion.test.end());
  sc.camera = scene_camera(body, sc);  // framed on the turn and the test poses only
  if (opt.unseen) add_unseen_views(body, sc);
  // The unseen frames come last, so the turn's and the test frames' noise is as without them.
  sc.fits = perturb_fits(sc.truth, opt.fit_noise, opt.seed);
  sc.min_pose_gap = motion.test.empty() ? 0 : 1e30;
  for (const SmplxParams& a : motion.test)
    for (const SmplxParams& b : motion.train) sc.min_pose_gap = std::min(sc.min_pose_gap, pose_distance(a, b));
  return sc;
}

SynthScene make_synth_subject_scene(const BodyModel& body, const SynthOptions& opt_in) {
  SynthOptions opt = opt_in;
  opt.train_frames = 1;  // the counts come from the motion; the other options are checked as usual
  opt.test_frames = 0;
  validate_synth_options(opt);
  opt.train_frames = 0;
  opt.unseen = false;          // the motion's frames only
  opt.fit_noise = FitNoise{};  // the motion's poses are the truth
  return scene_subject(body, opt);
}

void set_synth_scene_motion(const BodyModel& body, SynthScene& sc, const std::vector<SmplxParams>& motion) {
  if (motion.empty()) fail("motion", "no frames");
  sc.options.train_frames = 0;
  sc.options.test_frames = int(motion.size());
  sc.truth = place_synth_motion(body, sc.subject, motion);
  sc.fits = sc.truth;
  sc.camera = scene_camera(body, sc);
  sc.min_pose_gap = 0;
}

void render_synth_frames(const BodyModel& body, const SynthScene& scene,
                         const std::function<void(int frame, const Image& rgb, const Image& mask)>& sink) {
  render_synth_frames(body, scene, false,
                      [&](int i, const Image& rgb, const Image& mask, const Image*) { sink(i, rgb, mask); });
}

void render_synth_frames(const BodyModel& body, const SynthScene& scene, bool garment_masks,
                         const SynthFrameSink& sink) {
  const SynthOptions& opt = scene.options;
  SynthRenderer renderer(body, scene.subject);
  renderer.set_view_shading(scene.view_shading);  // before the per-thread copies are made
  // Small frames: one frame per thread (few, large parallel regions; the renderer's own
  // loops then run single-threaded inside). Large frames: one at a time, parallel
  // inside, which bounds memory to one supersampled raster.
  const int N = int(scene.truth.size());
  const int threads = std::max(1, num_threads());
  const bool by_frame = threads > 1 && opt.size <= 256;
  const int batch = by_frame ? 2 * threads : 1;
  std::vector<SynthRenderer> pool(by_frame ? size_t(threads) : 0, renderer);
  std::vector<Image> rgbs(static_cast<size_t>(batch)), masks(static_cast<size_t>(batch)),
      garments(static_cast<size_t>(batch));
  auto garment = [&](int64_t k) { return garment_masks ? &garments[size_t(k)] : nullptr; };
  for (int b0 = 0; b0 < N; b0 += batch) {
    const int n = std::min(batch, N - b0);
    if (by_frame) {
      parallel_for_dynamic(n, [&](int64_t k) {
        pool[size_t(thread_index())].render(scene.frame_camera(b0 + int(k)), scene.truth[b0 + k], opt.supersample,
                                            kSynthAll, rgbs[k], masks[k], garment(k));
      });
    } else {
      renderer.render(scene.frame_camera(b0), scene.truth[b0], opt.supersample, kSynthAll, rgbs[0], masks[0], garment(0));
    }
    for (int k = 0; k < n; ++k) sink(b0 + k, rgbs[size_t(k)], masks[size_t(k)], garment(k));
  }
}

}  // namespace haha
