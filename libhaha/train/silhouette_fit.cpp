#include "train/silhouette_fit.h"

#include <algorithm>
#include <cmath>

#include "body/lbs.h"
#include "body/rotation.h"
#include "core/parallel.h"
#include "render/avatar_render.h"
#include "render/mesh_antialias.h"
#include "train/adam.h"
#include "train/pose_groups.h"

namespace haha {

std::vector<std::vector<float>> temporal_pose_anchors(const std::vector<TrainFrame>& frames, int half_window) {
  const int n = int(frames.size());
  std::vector<std::vector<float>> groups(static_cast<size_t>(n), std::vector<float>(kPoseBodyGroup));
  std::vector<float> fine(kPoseFineGroup);
  for (int i = 0; i < n; ++i) pose_to_groups(frames[size_t(i)].params, groups[size_t(i)].data(), fine.data());
  std::vector<std::vector<float>> out = groups;
  constexpr int kRotations = kPoseBodyValues / 3;  // global orient + 21 body joints
  for (int i = 0; i < n; ++i) {
    const int lo = std::max(0, i - half_window), hi = std::min(n - 1, i + half_window);
    const double count = hi - lo + 1;
    for (int r = 0; r < kRotations; ++r) {
      const float* wi = &groups[size_t(i)][size_t(3 * r)];
      const Mat3<double> Ri = rodrigues(Vec3d(wi[0], wi[1], wi[2]));
      Vec3d mean(0, 0, 0);
      for (int k = lo; k <= hi; ++k) {
        const float* wk = &groups[size_t(k)][size_t(3 * r)];
        mean = mean + matrix_to_axis_angle(transpose(Ri) * rodrigues(Vec3d(wk[0], wk[1], wk[2])));
      }
      const Vec3d a = matrix_to_axis_angle(Ri * rodrigues(mean / count));
      for (int c = 0; c < 3; ++c) out[size_t(i)][size_t(3 * r + c)] = float(a[c]);
    }
    for (int c = kPoseBodyValues; c < kPoseBodyGroup; ++c) {
      double t = 0;
      for (int k = lo; k <= hi; ++k) t += groups[size_t(k)][size_t(c)];
      out[size_t(i)][size_t(c)] = float(t / count);
    }
  }
  return out;
}

BodySilhouette::BodySilhouette(const BodyModel& body)
    : neighbors_(mesh_face_neighbors(body.faces.data(), body.num_faces, body.num_verts)),
      topology_(topology_of(body)),
      texture_{1, 1, 3, white_} {
  topology_.face_neighbors = neighbors_.data();
  req_.body = &topology_;
  req_.texture = &texture_;
  req_.antialias = true;
}

const std::vector<float>& BodySilhouette::render(const Camera& camera, const float* verts) {
  camera_ = camera;
  req_.camera = &camera_;
  req_.verts = verts;
  render_avatar(req_, buf_);
  return buf_.image;
}

void BodySilhouette::backward(const float* d_image, float* d_verts) {
  AvatarRenderGrads gr;
  gr.verts = d_verts;
  render_avatar_backward(req_, buf_, d_image, nullptr, nullptr, gr);
}

double silhouette_mismatch(const float* image, const float* mask, int num_pixels, double w_outside, double w_inside,
                           float* d_image) {
  double loss = 0;
  const int P = num_pixels;
  for (int q = 0; q < P; ++q) {
    const double m = image[3 * size_t(q)], k = mask[size_t(q)];
    loss += w_outside * m * (1 - k) + w_inside * (1 - m) * k;
    d_image[3 * size_t(q)] = float((w_outside * (1 - k) - w_inside * k) / P);
    d_image[3 * size_t(q) + 1] = d_image[3 * size_t(q) + 2] = 0.0f;
  }
  return loss / std::max(1, P);
}

SilhouetteFitReport fit_poses_to_masks(const BodyModel& body, std::vector<TrainFrame>& frames,
                                       const Stage0Config& opt, const std::function<void(int, int)>& progress) {
  SilhouetteFitReport rep;
  if (opt.steps <= 0) return rep;
  BodySilhouette silhouette(body);
  Lbs<float> lbs(body);
  LbsCache<float> cache;
  std::vector<float> verts(3 * size_t(body.num_verts)), d_verts, d_image;
  const std::vector<std::vector<float>> anchors =
      opt.window > 0 ? temporal_pose_anchors(frames, opt.window) : std::vector<std::vector<float>>();
  for (size_t fi = 0; fi < frames.size(); ++fi) {
    TrainFrame& f = frames[fi];
    const int P = f.camera.width * f.camera.height;
    SmplxParams& p = f.params;
    Adam adam;
    const int gb = adam.add_group("body", kPoseBodyGroup, opt.lr);
    std::vector<float> pb(kPoseBodyGroup), pf(kPoseFineGroup), db(kPoseBodyGroup), dfn(kPoseFineGroup);
    std::vector<float> p0(kPoseBodyGroup);
    pose_to_groups(p, p0.data(), pf.data());
    if (!anchors.empty()) p0 = anchors[fi];
    d_image.resize(3 * size_t(P));
    for (int s = 0; s <= opt.steps; ++s) {
      lbs.forward(p, verts.data(), nullptr, &cache);
      const std::vector<float>& image = silhouette.render(f.camera, verts.data());
      double loss = silhouette_mismatch(image.data(), f.mask.data(), P, opt.w_outside, opt.w_inside, d_image.data());
      pose_to_groups(p, pb.data(), pf.data());
      for (int k = 0; k < kPoseBodyGroup; ++k) loss += opt.w_prior * double(pb[k] - p0[k]) * (pb[k] - p0[k]);
      if (s == 0) rep.loss_start.push_back(loss);
      if (s == opt.steps) {
        rep.loss_end.push_back(loss);
        break;
      }
      d_verts.assign(verts.size(), 0.0f);
      silhouette.backward(d_image.data(), d_verts.data());
      SmplxGrad<float> sg = lbs.make_grad(p);
      lbs.backward(p, cache, d_verts.data(), nullptr, sg);
      pose_to_groups(sg, db.data(), dfn.data());
      for (int k = 0; k < kPoseBodyGroup; ++k) db[k] += float(2 * opt.w_prior * (pb[k] - p0[k]));
      bool finite = true;
      for (float v : db) finite = finite && std::isfinite(v);
      if (!finite) break;
      adam.step(gb, pb.data(), db.data());
      groups_to_pose(pb.data(), pf.data(), p);
    }
    if (progress) progress(int(fi) + 1, int(frames.size()));
  }
  return rep;
}

}  // namespace haha
