// Test / benchmark glue for the CUDA backend: an avatar-like scene made from the procedural
// body (posed by LBS) with face-bound Gaussians and a smooth texture, plus upload helpers.
// Host-only data; the GPU copies are made by the users.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "body/face_frames.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "core/camera.h"
#include "render/texture.h"
#include "render/avatar_render.h"

namespace haha::testgpu {

struct AvatarScene {
  BodyModel body;
  SmplxParams params;
  std::vector<float> verts;  // (V, 3) posed
  Camera cam;
  float divisor = 1.0f;
  // Face-bound Gaussians (activated scale / colour / opacity, unit local rotations).
  std::vector<int32_t> face;
  std::vector<float> offset, rotation, scale, color, opacity;
  int tex_w = 0, tex_h = 0;
  std::vector<float> texture;  // (tex_h, tex_w, 3)

  int num_gaussians() const { return int(face.size()); }
  GaussianSetView gaussians() const {
    return {num_gaussians(), face.data(), offset.data(), rotation.data(), scale.data(), color.data(), opacity.data()};
  }
  TextureView texture_view() const { return {tex_w, tex_h, 3, texture.data()}; }
};

// Camera looking at the body from the front (+Z), OpenCV axes, the body's height filling
// about 85% of the image height.
inline Camera front_camera(int width, int height) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = 1.55f * float(std::min(width, height));
  cam.cx = 0.5f * float(width);
  cam.cy = 0.5f * float(height);
  cam.R = Mat3f::identity();
  cam.R.a[1][1] = -1.0f;  // world Y up -> camera y down
  cam.R.a[2][2] = -1.0f;  // camera looks along world -Z
  cam.t = Vec3f(0.0f, -0.35f, 3.2f);  // centre at (0, -0.35, 3.2)
  cam.near_plane = 0.1f;
  cam.far_plane = 20.0f;
  return cam;
}

inline AvatarScene make_avatar_scene(BodyResolution res, int num_gaussians, int width, int height,
                                     uint64_t seed = 1, int tex_size = 512) {
  AvatarScene s;
  ProceduralBodyOptions opt;
  opt.resolution = res;
  opt.seed = seed;
  s.body = make_procedural_body(opt);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  // Arms lowered from the T-pose, a little motion elsewhere.
  for (int i = 3; i < kNumPoseValues; ++i) s.params.pose[size_t(i)] = 0.08f * U(rng);
  s.params.pose[3 * 16 + 2] = -1.1f;  // left shoulder
  s.params.pose[3 * 17 + 2] = 1.1f;   // right shoulder
  s.params.betas.assign(10, 0.0f);
  for (float& b : s.params.betas) b = 0.5f * U(rng);
  s.params.expression.assign(10, 0.0f);
  for (float& e : s.params.expression) e = 0.5f * U(rng);
  s.params.transl = {0.02f, 0.01f, -0.03f};
  s.verts.resize(size_t(s.body.num_verts) * 3);
  Lbs<float>(s.body).forward(s.params, s.verts.data(), nullptr, nullptr);
  s.cam = front_camera(width, height);

  std::uniform_int_distribution<int> F(0, s.body.num_faces - 1);
  std::normal_distribution<float> N(0.0f, 1.0f);
  s.face.resize(size_t(num_gaussians));
  s.offset.resize(3 * size_t(num_gaussians));
  s.rotation.resize(4 * size_t(num_gaussians));
  s.scale.resize(3 * size_t(num_gaussians));
  s.color.resize(3 * size_t(num_gaussians));
  s.opacity.resize(size_t(num_gaussians));
  for (int i = 0; i < num_gaussians; ++i) {
    s.face[size_t(i)] = F(rng);
    // Local frame: columns (edge, normal, edge x normal); a small lift along the normal.
    s.offset[3 * i] = 0.3f * N(rng);
    s.offset[3 * i + 1] = 0.1f + 0.1f * std::fabs(N(rng));
    s.offset[3 * i + 2] = 0.3f * N(rng);
    float q[4], n2 = 0.0f;
    for (float& v : q) {
      v = N(rng);
      n2 += v * v;
    }
    for (int k = 0; k < 4; ++k) s.rotation[4 * i + k] = q[k] / std::sqrt(n2);
    for (int k = 0; k < 3; ++k) {
      s.scale[3 * i + k] = 0.4f + 0.55f * (U(rng) + 1.0f);
      s.color[3 * i + k] = 0.5f + 0.5f * U(rng);
    }
    s.opacity[size_t(i)] = 0.6f + 0.35f * U(rng);
  }
  s.tex_w = s.tex_h = tex_size;
  s.texture.resize(size_t(tex_size) * tex_size * 3);
  for (int y = 0; y < tex_size; ++y)
    for (int x = 0; x < tex_size; ++x)
      for (int c = 0; c < 3; ++c)
        s.texture[(size_t(y) * tex_size + x) * 3 + c] =
            0.5f + 0.45f * std::sin(0.05f * float(x) * float(c + 1) + 0.07f * float(y) + float(c));
  return s;
}

}  // namespace haha::testgpu
