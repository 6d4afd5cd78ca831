// A small in-memory training scene for the trainer tests: the procedural body (low
// resolution), a turntable of frames at 40 x 40 px, ground truth rendered with the
// avatar renderer from a known "true" avatar: a smooth texture plus a cluster of
// Gaussians that stand off the head (like hair), so the filtering stage has something
// to keep. No files.
#pragma once

#include <cmath>
#include <vector>

#include "body/avatar.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "render/avatar_render.h"
#include "train/evaluate.h"
#include "train/trainer.h"

namespace haha::test {

inline const BodyModel& scene_body() {
  static const BodyModel m = make_procedural_body({BodyResolution::low, 0});
  return m;
}

// Camera on +Z looking at the body (OpenCV axes: y down), the whole body in view.
inline Camera scene_camera(int size) {
  Camera c;
  c.width = c.height = size;
  c.fx = c.fy = 0.9f * size / 2 / (0.95f / 2.8f);
  c.cx = c.cy = size / 2.0f;
  c.R = Mat3f::identity();
  c.R(1, 1) = -1;
  c.R(2, 2) = -1;
  c.t = Vec3f(0, -0.3f, 2.8f);
  c.near_plane = 0.1f;
  c.far_plane = 10.0f;
  return c;
}

inline SmplxParams scene_pose(int i, int n) {
  SmplxParams p;
  p.pose[1] = float(2 * M_PI * i / n);               // turn about the vertical axis
  p.pose[3 * 16 + 2] = -0.3f + 0.2f * std::sin(float(i));  // left shoulder
  p.pose[3 * 17 + 2] = 0.3f - 0.2f * std::cos(float(i));   // right shoulder
  p.betas.assign(4, 0.0f);
  return p;
}

// The true avatar: texture = smooth colour field of the UV, Gaussians: one per face of the
// head region, pushed outward by `stand_off` (units of k: ~0.6 m on this body, so 0.08 is
// ~5 cm), opaque, dark brown.
inline Avatar scene_truth(int tex_size = 32, float stand_off = 0.08f) {
  const BodyModel& b = scene_body();
  Avatar a;
  a.body = b;
  a.betas.assign(4, 0.0f);
  a.face_scale_divisor = 0.05f;
  a.texture.width = a.texture.height = tex_size;
  a.texture.rgb.resize(size_t(tex_size) * tex_size * 3);
  for (int y = 0; y < tex_size; ++y)
    for (int x = 0; x < tex_size; ++x) {
      const float u = (x + 0.5f) / tex_size, v = (y + 0.5f) / tex_size;
      float* t = &a.texture.rgb[(size_t(y) * tex_size + x) * 3];
      t[0] = 0.5f + 0.4f * std::sin(6.0f * u);
      t[1] = 0.5f + 0.4f * std::cos(5.0f * v);
      t[2] = 0.3f + 0.3f * u * v;
    }
  const std::vector<BodyRegion> reg = face_regions(b);
  for (int f = 0; f < b.num_faces; ++f) {
    if (reg[size_t(f)] != BodyRegion::head) continue;
    BoundGaussians& g = a.gaussians;
    g.face.push_back(f);
    g.offset.insert(g.offset.end(), {0.0f, stand_off, 0.0f});
    g.rotation.insert(g.rotation.end(), {1.0f, 0.0f, 0.0f, 0.0f});
    g.scale.insert(g.scale.end(), {0.03f, 0.03f, 0.03f});
    g.color.insert(g.color.end(), {0.35f, 0.2f, 0.1f});
    g.opacity.push_back(0.95f);
  }
  return a;
}

// Frames rendered from `truth` (mesh + Gaussians on black, mask = union silhouette).
inline std::vector<TrainFrame> scene_frames(const Avatar& truth, int n, int size = 40) {
  const BodyModel& b = truth.body;
  Lbs<float> lbs(b);
  std::vector<TrainFrame> out;
  std::vector<float> verts(3 * size_t(b.num_verts));
  AvatarRenderBuffers buf;
  const TextureView tex{truth.texture.width, truth.texture.height, 3, truth.texture.rgb.data()};
  const BoundGaussians& g = truth.gaussians;
  const GaussianSetView gv{g.size(), g.face.data(), g.offset.data(), g.rotation.data(),
                           g.scale.data(), g.color.data(), g.opacity.data()};
  for (int i = 0; i < n; ++i) {
    TrainFrame f;
    f.name = "scene frame " + std::to_string(i);
    f.camera = scene_camera(size);
    f.params = scene_pose(i, n);
    lbs.forward(f.params, verts.data(), nullptr, nullptr);
    AvatarRenderRequest req;
    req.camera = &f.camera;
    const BodyTopology topology = topology_of(b);
    req.body = &topology;
    req.verts = verts.data();
    req.face_scale_divisor = truth.face_scale_divisor;
    req.gaussians = g.size() > 0 ? &gv : nullptr;
    req.texture = &tex;
    render_avatar(req, buf);
    f.rgb = buf.image;
    f.mask.resize(size_t(size) * size);
    for (size_t p = 0; p < f.mask.size(); ++p) f.mask[p] = 1.0f - (1.0f - buf.mesh.mask[p]) * (1.0f - buf.alpha[p]);
    out.push_back(std::move(f));
  }
  return out;
}

// A fast config for the tests (steps chosen per test).
inline TrainConfig scene_config(int s1, int s2, int s3) {
  TrainConfig c = make_preset("tiny");
  c.resolution = 0;
  c.s1.steps = s1;
  c.s2.steps = s2;
  c.s3.steps = s3;
  c.s2.texture_size = 32;
  c.s1.densify_from = 2;
  c.s1.densify_every = 4;
  c.s1.densify_until = 1000;
  c.s1.densify_grad = 1e-4;
  c.s1.max_gaussians = 100000;
  c.s1.knn_every = 3;
  c.s3.prune_every = 3;
  c.s3.w.opacity = 1e-4;
  c.batch = 2;
  return c;
}

inline TrainInput scene_input(const std::vector<TrainFrame>& frames) {
  TrainInput in;
  in.body = &scene_body();
  in.frames = frames;
  in.premultiplied = true;
  return in;
}

}  // namespace haha::test
