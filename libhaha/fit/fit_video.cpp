// SMPL-X fits from per-frame keypoints and masks (fit/fit_video.h): frame selection
// (fit/fit_video_frames.h), initialisation, the three SMPLify-style stages over the
// objective of fit/fit_video_objective.h with Adam (train/adam.h), and the report.
#include "fit/fit_video.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "fit/fit_video_focal.h"
#include "fit/fit_video_facing.h"
#include "fit/fit_video_frames.h"
#include "fit/fit_video_world_init.h"
#include "body/rotation.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "train/adam.h"
#include "train/silhouette_fit.h"

namespace haha {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kYawCandidates = 8;

void check_input(const std::vector<FitVideoInputFrame>& frames) {
  if (frames.empty()) fail("video fit", "no frames");
  const KeypointsFrame& k0 = frames[0].keypoints;
  for (const FitVideoInputFrame& f : frames) {
    const KeypointsFrame& k = f.keypoints;
    const std::string where = k.frame.empty() ? "video fit" : k.frame;
    if (k.width != k0.width || k.height != k0.height)
      fail(where, "frame is " + std::to_string(k.width) + " x " + std::to_string(k.height) + ", the first frame " +
                      std::to_string(k0.width) + " x " + std::to_string(k0.height));
    if (k.width < 1 || k.height < 1) fail(where, "frame has no pixels");
    if (k.has_person() && k.body.size() != size_t(kBodyKeypoints))
      fail(where, "body has " + std::to_string(k.body.size()) + " points, expected " + std::to_string(kBodyKeypoints));
    if (k.has_person() && !k.body_world.empty() && k.body_world.size() != size_t(kBodyKeypoints))
      fail(where, "body_world has " + std::to_string(k.body_world.size()) + " points, expected " +
                      std::to_string(kBodyKeypoints));
    if (!f.mask.empty() && (f.mask.width != k.width || f.mask.height != k.height || f.mask.channels < 1))
      fail(where, "mask is " + std::to_string(f.mask.width) + " x " + std::to_string(f.mask.height) +
                      ", the frame " + std::to_string(k.width) + " x " + std::to_string(k.height));
  }
}

Camera make_camera(int width, int height, const FitVideoOptions& opt) {
  if (!(opt.focal_px >= 0) || !(opt.fov_deg > 0 && opt.fov_deg < 180) || !std::isfinite(opt.focal_px))
    fail("video fit", "focal must be > 0 or the field of view in (0, 180) degrees");
  const double f = opt.focal_px > 0 ? opt.focal_px : focal_px_from_fov(opt.fov_deg, width);
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = float(f);
  c.cx = 0.5f * float(width);
  c.cy = 0.5f * float(height);
  return c;
}

// The mask and camera of a frame at silhouette resolution (area-averaged mask).
struct SilhouetteFrame {
  Camera camera;
  std::vector<float> mask;
};
SilhouetteFrame shrink(const Image& mask, const Camera& cam, int max_side) {
  SilhouetteFrame s;
  const double scale = std::min(1.0, double(std::max(1, max_side)) / std::max(cam.width, cam.height));
  const int w = std::max(1, int(std::lround(cam.width * scale))), h = std::max(1, int(std::lround(cam.height * scale)));
  const float sx = float(w) / float(cam.width), sy = float(h) / float(cam.height);
  s.camera = cam;
  s.camera.width = w;
  s.camera.height = h;
  s.camera.fx *= sx, s.camera.cx *= sx, s.camera.fy *= sy, s.camera.cy *= sy;
  std::vector<float> sum(size_t(w) * h, 0.0f), count(size_t(w) * h, 0.0f);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      const size_t q = size_t(std::min(h - 1, int(y * sy))) * w + size_t(std::min(w - 1, int(x * sx)));
      sum[q] += std::clamp(mask.at(x, y, 0), 0.0f, 1.0f);
      count[q] += 1;
    }
  s.mask.resize(sum.size());
  for (size_t q = 0; q < sum.size(); ++q) s.mask[q] = count[q] > 0 ? sum[q] / count[q] : 0.0f;
  return s;
}

// Global orient and transl of one frame: transl from its 2D torso (depth from the torso size
// and the focal); the orient and the limbs from BlazePose's world points where the frame has
// them (fit/fit_video_world_init.h), else from the 2D torso: roll from the torso's direction
// in the image, heading the best of kYawCandidates (facing the camera, away from it and
// between) under the first stage's point weights.
void initialise_frame(const BodyModel& body, const FitVideoObjective<float>& obj, const FitVideoTargets& tg,
                      const KeypointsFrame& k, const Camera& cam, const std::vector<float>& rest_joints,
                      double min_visibility, float* q) {
  namespace bp = blazepose;
  auto J = [&](int j) { return Vec3d(rest_joints[size_t(3 * j)], rest_joints[size_t(3 * j + 1)], rest_joints[size_t(3 * j + 2)]); };
  const Vec3d S = 0.5 * (J(16) + J(17)), Hm = 0.5 * (J(1) + J(2));
  const double size3 = std::max({norm(S - Hm), norm(J(16) - J(17)), norm(J(1) - J(2))});
  const Torso2D t = torso_2d(k);
  const double Z = double(cam.fx) * size3 / t.size;
  auto P = [&](int i) { return k.body[size_t(i)]; };
  const double hx = 0.5 * (P(bp::left_hip).x + P(bp::right_hip).x), hy = 0.5 * (P(bp::left_hip).y + P(bp::right_hip).y);
  const double sx = 0.5 * (P(bp::left_shoulder).x + P(bp::right_shoulder).x),
               sy = 0.5 * (P(bp::left_shoulder).y + P(bp::right_shoulder).y);
  const Vec3d pelvis((hx - cam.cx) * Z / cam.fx, (hy - cam.cy) * Z / cam.fy, Z);
  const double roll = (std::abs(sx - hx) + std::abs(sy - hy) > 0) ? std::atan2(sx - hx, -(sy - hy)) : 0.0;
  std::fill(q, q + kFitVideoFrameParams, 0.0f);
  for (int c = 0; c < 3; ++c) q[kFitVideoPoseValues + c] = float(pelvis[c] - J(0)[c]);
  if (init_pose_from_world(body, obj.points(), tg, rest_joints, cam.cast<double>().R, min_visibility, q)) return;
  FitVideoTargets one = tg;
  one.linked = false;
  std::vector<float> cand(kFitVideoFrameParams);
  double best = INFINITY;
  for (int y = 0; y < kYawCandidates; ++y) {
    const Mat3<double> R = rodrigues(Vec3d(0, 0, roll)) * rodrigues(Vec3d(kPi, 0, 0)) *
                           rodrigues(Vec3d(0, 2 * kPi * y / kYawCandidates, 0));
    const Vec3d w = matrix_to_axis_angle(R);
    std::copy(q, q + kFitVideoFrameParams, cand.begin());
    for (int c = 0; c < 3; ++c) cand[size_t(c)] = float(w[c]);
    const double e = obj.evaluate({one}, cand.data(), nullptr);
    if (e < best) best = e, std::copy(cand.begin(), cand.end(), q);
  }
}

// The same rotation with the angle 2 pi less (turns = -1) or more (+1): Rodrigues is 2 pi
// periodic in the angle.
Vec3d other_turn(Vec3d a, int turns = -1) {
  const double n = norm(a);
  return n > 0 ? a * (1 + turns * 2 * kPi / n) : a;
}

// Axis-angle is discontinuous at pi (facing the camera is a half turn from the body's rest
// heading): each linked frame's global orient is rewritten as the representation of the
// same rotation nearest the previous frame's, so the temporal term measures the true change.
void unwrap_orients(const std::vector<FitVideoTargets>& targets, float* params) {
  for (size_t f = 1; f < targets.size(); ++f) {
    if (!targets[f].linked) continue;
    float* q = params + f * kFitVideoFrameParams;
    const float* p = q - kFitVideoFrameParams;
    const Vec3d prev(p[0], p[1], p[2]);
    Vec3d a(q[0], q[1], q[2]);
    for (int it = 0; it < 3; ++it) {  // angles may be anything: step one turn at a time
      const Vec3d b = other_turn(a, -1), c = other_turn(a, 1);
      Vec3d best = a;
      if (norm(b - prev) < norm(best - prev)) best = b;
      if (norm(c - prev) < norm(best - prev)) best = c;
      a = best;
    }
    for (int k = 0; k < 3; ++k) q[k] = float(a[k]);
  }
}

// Adam over parameter subsets of the flat vector (orient, body pose, transl, betas).
struct StageGroup {
  std::vector<size_t> idx;
  double lr = 0;
  std::vector<float> p, d;
};

std::string seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, s < 100 ? "%.1f s" : "%.0f s", s);
  return b;
}

// Frame selection, with each input frame's line of the report (dropped or not); throws when
// no frame is left.
FitVideoSelection select_frames(const std::vector<FitVideoInputFrame>& frames, const std::vector<FitVideoPoint>& points,
                                const FitVideoOptions& opt, FitVideoResult& out) {
  if (!(opt.frame_interval_s > 0) || !std::isfinite(opt.frame_interval_s))
    fail("video fit", "the time between frames must be > 0 seconds");
  FitVideoSelection sel = select_video_frames(frames, points, opt);
  if (!opt.use_world)
    for (FitVideoTargets& t : sel.targets) t.world.clear();
  out.report.resize(frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    out.report[i].frame = frames[i].keypoints.frame;
    out.report[i].dropped = !sel.reason[i].empty();
    out.report[i].reason = sel.reason[i];
  }
  if (sel.kept.empty()) {
    std::string why = sel.reason[0];
    fail("video fit", "no frame with a person to fit (" + std::to_string(frames.size()) + " frames; the first: " + why + ")");
  }
  out.kept = sel.kept;
  if (opt.progress)
    std::printf("video fit: %d of %zu frames kept, focal %.1f px, %zu keypoints per frame\n", int(sel.kept.size()),
                frames.size(), double(out.camera.fx), points.size());
  return sel;
}

// Initialisation (rest body, betas 0) under the first stage's weights.
void initialise_frames(const BodyModel& body, const std::vector<FitVideoPoint>& points,
                       const std::vector<FitVideoInputFrame>& frames, const FitVideoSelection& sel, const Camera& camera,
                       const std::vector<double>& torso_w, const FitVideoOptions& opt, std::vector<float>& params) {
  FitVideoObjective<float> init_obj(body, points, camera, 0, opt.weights);  // betas 0
  init_obj.set_point_weights(torso_w);
  std::vector<float> rest_v(size_t(body.num_verts) * 3), rest_j(size_t(kNumJoints) * 3);
  Lbs<float>(body).forward(SmplxParams{}, rest_v.data(), rest_j.data(), nullptr);
  for (int f = 0; f < int(sel.kept.size()); ++f)
    initialise_frame(body, init_obj, sel.targets[size_t(f)], frames[size_t(sel.kept[size_t(f)])].keypoints, camera,
                     rest_j, opt.min_visibility, params.data() + size_t(f) * kFitVideoFrameParams);
}

// Silhouette frames (kept frames with a mask; the others stay empty).
std::vector<SilhouetteFrame> silhouette_frames(const std::vector<FitVideoInputFrame>& frames, const std::vector<int>& kept,
                                               const Camera& camera, const FitVideoOptions& opt, bool& any_mask) {
  std::vector<SilhouetteFrame> sil(kept.size());
  any_mask = false;
  for (size_t f = 0; f < kept.size(); ++f) {
    const Image& m = frames[size_t(kept[f])].mask;
    if (m.empty()) continue;
    sil[f] = shrink(m, camera, opt.silhouette_size);
    any_mask = true;
  }
  return sil;
}

struct StageGroups {
  StageGroup orient, pose, transl, betas;
};

StageGroups stage_groups(int N, int nb, const FitVideoOptions& opt) {
  StageGroups g;
  for (int f = 0; f < N; ++f) {
    const size_t b = size_t(f) * kFitVideoFrameParams;
    for (int k = 0; k < 3; ++k) g.orient.idx.push_back(b + size_t(k));
    for (int k = 3; k < kFitVideoPoseValues; ++k) g.pose.idx.push_back(b + size_t(k));
    for (int k = 0; k < 3; ++k) g.transl.idx.push_back(b + size_t(kFitVideoPoseValues + k));
  }
  for (int k = 0; k < nb; ++k) g.betas.idx.push_back(size_t(N) * kFitVideoFrameParams + size_t(k));
  g.orient.lr = opt.lr_orient, g.pose.lr = opt.lr_body, g.transl.lr = opt.lr_transl, g.betas.lr = opt.lr_betas;
  return g;
}

// What the stages of one fit share.
struct StageRun {
  const FitVideoObjective<float>& obj;
  const std::vector<FitVideoTargets>& targets;
  std::vector<float>& params;
  std::vector<float>& grad;
  const FitVideoOptions& opt;
  int stages;
};

void run_stage(const StageRun& r, int stage, const char* name, int iters, std::vector<StageGroup*> groups,
               const FitVideoObjective<float>::Extra& extra) {
  if (iters <= 0) return;
  const FitVideoOptions& opt = r.opt;
  std::vector<float>& params = r.params;
  std::vector<float>& grad = r.grad;
  Adam adam;
  std::vector<int> ids;
  std::vector<LogLinearLr> sched;
  for (StageGroup* g : groups) {
    if (g->idx.empty()) continue;
    ids.push_back(adam.add_group(name + std::to_string(ids.size()), int64_t(g->idx.size()), g->lr));
    LogLinearLr s;
    s.lr_init = g->lr;
    s.lr_final = g->lr * opt.lr_final_factor;
    s.max_steps = iters;
    sched.push_back(s);
  }
  const auto t0 = std::chrono::steady_clock::now();
  const int every = std::max(1, iters / 6);
  for (int it = 0; it <= iters; ++it) {
    check_interrupted();
    FitVideoTerms terms;
    r.obj.evaluate(r.targets, params.data(), it < iters ? grad.data() : nullptr, extra, &terms);
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (opt.progress && (it % every == 0 || it == iters))
      std::printf("video fit: stage %d/%d (%s), iteration %d/%d, loss %.4e (keypoints %.3e, world %.2e, prior %.2e, smooth %.2e%s), "
                  "%s, ETA %s\n",
                  stage, r.stages, name, it, iters, terms.total(), terms.keypoints, terms.world, terms.prior, terms.smooth,
                  extra ? (", silhouette " + std::to_string(terms.extra).substr(0, 8)).c_str() : "", seconds(el).c_str(),
                  seconds(it > 0 ? el / it * (iters - it) : 0).c_str());
    if (it == iters) break;
    size_t gi = 0;
    for (StageGroup* g : groups) {
      if (g->idx.empty()) continue;
      g->p.resize(g->idx.size());
      g->d.resize(g->idx.size());
      for (size_t i = 0; i < g->idx.size(); ++i) {
        g->p[i] = params[g->idx[i]];
        g->d[i] = std::isfinite(grad[g->idx[i]]) ? grad[g->idx[i]] : 0.0f;  // never step into NaN
      }
      adam.set_lr(ids[gi], sched[gi](it));
      adam.step(ids[gi], g->p.data(), g->d.data());
      for (size_t i = 0; i < g->idx.size(); ++i) params[g->idx[i]] = g->p[i];
      ++gi;
    }
  }
  std::fflush(stdout);
}

// Face points seen from behind (fit/fit_video_facing.h): their visibility (vis0: as
// selected) scaled by the current fit's facing before each stage.
void fade_hidden_face(const FitVideoObjective<float>& obj, const std::vector<FitVideoPoint>& points,
                      const std::vector<std::vector<double>>& vis0, const std::vector<float>& params, int N,
                      const FitVideoOptions& opt, std::vector<FitVideoTargets>& targets) {
  if (!opt.fade_hidden_face) return;
  const float* shared = params.data() + size_t(N) * kFitVideoFrameParams;
  for (int f = 0; f < N; ++f) {
    std::vector<Vec3d> cp;
    for (const Vec3<float>& p : obj.camera_points(params.data() + size_t(f) * kFitVideoFrameParams, shared))
      cp.emplace_back(p.x, p.y, p.z);
    const std::vector<double> w = face_point_factors(points, cp);
    for (size_t k = 0; k < w.size(); ++k) targets[size_t(f)].vis[k] = vis0[size_t(f)][k] * w[k];
  }
}

// Results and the report: each kept frame's parameters (orient angle back in [0, pi]), its
// keypoint reprojection error and, with a mask, its silhouette IoU.
void collect_results(const BodyModel& body, const std::vector<FitVideoInputFrame>& frames, const FitVideoSelection& sel,
                     const FitVideoObjective<float>& obj, int nb, BodySilhouette& silhouette,
                     std::vector<float>& params, FitVideoResult& out) {
  const int N = int(sel.kept.size());
  const int W = frames[0].keypoints.width, H = frames[0].keypoints.height;
  const std::vector<FitVideoPoint>& points = obj.points();
  const float* shared = params.data() + size_t(N) * kFitVideoFrameParams;
  Lbs<float> lbs(body);
  std::vector<float> verts(size_t(body.num_verts) * 3), u, v;
  for (int f = 0; f < N; ++f) {
    float* q = params.data() + size_t(f) * kFitVideoFrameParams;
    Vec3d a(q[0], q[1], q[2]);  // the angle back in [0, pi]
    while (norm(a) > kPi) a = other_turn(a);
    for (int k = 0; k < 3; ++k) q[k] = float(a[k]);
    out.params.push_back(FitVideoObjective<float>::to_params(q, shared, nb));
    FitVideoFrameReport& r = out.report[size_t(sel.kept[size_t(f)])];
    const FitVideoTargets& tg = sel.targets[size_t(f)];
    obj.project(q, shared, u, v);
    double num = 0, den = 0;
    for (size_t k = 0; k < points.size(); ++k) {
      num += tg.vis[k] * std::hypot(double(u[k]) - tg.x[k], double(v[k]) - tg.y[k]);
      den += tg.vis[k];
    }
    r.reprojection_px = den > 0 ? num / den : NAN;
    const Image& m = frames[size_t(sel.kept[size_t(f)])].mask;
    if (!m.empty()) {
      lbs.forward(out.params.back(), verts.data(), nullptr, nullptr);
      const std::vector<float>& img = silhouette.render(out.camera, verts.data());
      double inter = 0, uni = 0;
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const bool a = img[3 * (size_t(y) * W + size_t(x))] >= 0.5f, b = m.at(x, y, 0) >= 0.5f;
          inter += a && b;
          uni += a || b;
        }
      r.silhouette_iou = uni > 0 ? inter / uni : NAN;
    }
  }
}

void print_summary(const FitVideoResult& out) {
  double rp = 0;
  int n = 0;
  for (int i : out.kept) {
    const double e = out.report[size_t(i)].reprojection_px;
    if (std::isfinite(e)) rp += e, ++n;
  }
  std::printf("video fit: done, mean keypoint reprojection %.2f px over %d frames\n", n ? rp / n : NAN, n);
}

}  // namespace

FitVideoResult fit_video(const BodyModel& body, const std::vector<FitVideoInputFrame>& frames,
                         const FitVideoOptions& opt) {
  check_input(frames);
  const int W = frames[0].keypoints.width, H = frames[0].keypoints.height;
  FitVideoResult out;
  out.camera = make_camera(W, H, opt);
  const std::vector<FitVideoPoint> points = fit_video_points(body);
  FitVideoSelection sel = select_frames(frames, points, opt, out);
  const int N = int(sel.kept.size());

  FitVideoObjective<float> obj(body, points, out.camera, opt.num_betas, opt.weights);
  const int nb = obj.num_betas();
  std::vector<float> params(size_t(obj.num_params(N)), 0.0f), grad(params.size());

  std::vector<double> torso_w, all_w;
  for (const FitVideoPoint& p : points) {
    all_w.push_back(p.weight);
    torso_w.push_back(p.torso ? p.weight : 0.0);
  }
  initialise_frames(body, points, frames, sel, out.camera, torso_w, opt, params);

  bool any_mask = false;
  const std::vector<SilhouetteFrame> sil = silhouette_frames(frames, sel.kept, out.camera, opt, any_mask);
  BodySilhouette silhouette(body);
  std::vector<float> d_image;
  const FitVideoObjective<float>::Extra silhouette_term = [&](int f, const float* verts, float* d_verts) -> float {
    const SilhouetteFrame& s = sil[size_t(f)];
    if (s.mask.empty()) return 0.0f;
    const int P = s.camera.width * s.camera.height;
    d_image.resize(3 * size_t(P));
    const std::vector<float>& img = silhouette.render(s.camera, verts);
    const double w = opt.w_silhouette / N;
    const double l = silhouette_mismatch(img.data(), s.mask.data(), P, opt.silhouette_outside, opt.silhouette_inside,
                                         d_image.data());
    if (d_verts) {
      for (float& g : d_image) g *= float(w);
      silhouette.backward(d_image.data(), d_verts);
    }
    return float(w * l);
  };

  StageGroups g = stage_groups(N, nb, opt);
  const StageRun run{obj, sel.targets, params, grad, opt, any_mask ? 3 : 2};
  std::vector<std::vector<double>> vis0;
  for (const FitVideoTargets& t : sel.targets) vis0.push_back(t.vis);
  auto fade = [&] { fade_hidden_face(obj, points, vis0, params, N, opt, sel.targets); };

  obj.set_point_weights(torso_w);
  unwrap_orients(sel.targets, params.data());
  fade();
  run_stage(run, 1, "global", opt.iters_global, {&g.orient, &g.transl}, {});
  obj.set_point_weights(all_w);
  unwrap_orients(sel.targets, params.data());
  fade();
  run_stage(run, 2, "body", opt.iters_body, {&g.orient, &g.pose, &g.transl, &g.betas}, {});
  fade();
  if (any_mask) run_stage(run, 3, "silhouette", opt.iters_silhouette, {&g.orient, &g.pose, &g.transl, &g.betas}, silhouette_term);

  collect_results(body, frames, sel, obj, nb, silhouette, params, out);
  if (opt.progress) print_summary(out);
  return out;
}

}  // namespace haha
