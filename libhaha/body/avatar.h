// A trained HAHA avatar: what the trainer produces, `haha pack` stores and the loader
// reads. Gaussians are bound to faces of the body mesh and live in their face's local
// frame (docs/method.md section 1): world mu' = k R mu + T, r' = R * r, s' = k s.
#pragma once

#include <cstdint>
#include <vector>

#include "body/body_model.h"
#include "body/garment.h"

namespace haha {

// Structure of arrays; N = face.size(). Values are stored activated (not logits):
// scale > 0 in units of the face scale k, opacity in [0, 1], colour linear RGB in [0, 1].
struct BoundGaussians {
  std::vector<int32_t> face;     // (N) parent face index
  std::vector<float> offset;     // (N, 3) local mu
  std::vector<float> rotation;   // (N, 4) local unit quaternion (w, x, y, z)
  std::vector<float> scale;      // (N, 3)
  std::vector<float> color;      // (N, 3)
  std::vector<float> opacity;    // (N)
  int size() const { return int(face.size()); }
  void resize(int n) {
    face.resize(n); offset.resize(3 * n); rotation.resize(4 * n); scale.resize(3 * n);
    color.resize(3 * n); opacity.resize(n);
  }
};

struct Texture {
  int width = 0, height = 0;
  std::vector<float> rgb;  // (H, W, 3), row 0 = top of the image (v = 1)
};

struct Avatar {
  BodyModel body;                 // topology, skinning, UVs (correctives optional)
  std::vector<float> betas;       // subject shape
  std::vector<float> expression;  // subject expression (usually zeros)
  Texture texture;
  BoundGaussians gaussians;
  // Read from avatar.npz before the body model is known (format/avatar_npz.h): attach_body
  // appends it to `body`, and from then on `body` carries it (BodyModel::has_garment). Empty
  // otherwise; the trainer's and the unpacker's avatars keep it in `body` only.
  Garment garment;
  float face_scale_divisor = 1.0f;  // k is divided by this (release: 0.05) so k ~ 1
  // Depth test of the merge: a Gaussian shows in front of the mesh where its centre's
  // camera z <= D + depth_margin (metres; the trainer's s3.depth_margin, 0 = exact).
  float depth_margin = 0.0f;
  // The mesh's learned coverage (train/mesh_coverage.h): one value in [0, 1] per body vertex
  // (garment included); the mesh draws a point only where the barycentric interpolation of
  // its face's three values is >= kCoverageCutoff, so where an estimated surface overshoots
  // the person the mesh is cut away and what is behind it shows (the glTF file writes it as
  // COLOR_0 alpha with alphaMode MASK). Empty: the whole mesh draws.
  std::vector<float> mesh_coverage;
};

// The cut of mesh_coverage: a mesh point draws where its interpolated coverage >= this (the
// glTF material's alphaCutoff).
inline constexpr float kCoverageCutoff = 0.5f;

// The largest |depth_margin| an avatar may carry (metres): the format's range, which the
// trainer's config checks before training rather than after.
inline constexpr float kMaxDepthMargin = 1.0f;

}  // namespace haha
