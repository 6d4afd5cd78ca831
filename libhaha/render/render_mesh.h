// Convenience for the trainer: posed vertices + faces + UV map + texture + camera ->
// mesh colour M and depth D (forward), and the backward to the texture and the vertices.
// It chains the pieces of mesh_raster.h and texture.h:
//   rasterize_mesh -> (tri, bary, depth) -> interpolate(ft, vt) -> uv -> sample_texture -> M
// The vertex gradient flows through the barycentrics with visibility held fixed (no
// silhouette-edge gradient): moving a vertex changes which surface point (hence UV, hence
// texel) a covered pixel sees, and its depth.
#pragma once

#include <cstdint>
#include <vector>

#include "core/camera.h"
#include "render/mesh_raster.h"
#include "render/texture.h"

namespace haha {

// Borrowed inputs (not owned).
struct MeshRenderInput {
  const float* verts = nullptr;     // (V, 3) posed, world space
  int num_verts = 0;
  const int32_t* faces = nullptr;   // (F, 3) vertex indices
  int num_faces = 0;
  const float* uv = nullptr;        // (T, 2) vt: u right, v up
  int num_uv = 0;
  const int32_t* uv_faces = nullptr;  // (F, 3) ft: UV index per face corner
  TextureView texture;              // (Ht, Wt, C), row 0 = v = 1
  const float* coverage = nullptr;  // (V) the coverage cut (render/mesh_raster.h); null: none
};

// Forward results (pixel p = y * W + x) plus backward scratch; vectors are resized by
// render_mesh and reused between calls.
struct MeshRender {
  MeshRaster raster;          // tri, bary, depth D (+inf outside), mask (silhouette)
  std::vector<float> uv;      // (H*W, 2) interpolated UV, 0 outside
  std::vector<float> color;   // (H*W, C) M, 0 outside
  std::vector<float> grad_uv_, grad_bary_;  // backward scratch
};

// Throws haha::Error ("render_mesh: ...") on bad sizes, an out-of-range face/ft index or an
// empty texture.
void render_mesh(const Camera& cam, const MeshRenderInput& in, MeshRender& out);

// Backward of render_mesh for the same inputs (fwd = its output). grad_color (H*W, C) is
// dL/dM and grad_depth (H*W) is dL/dD; either may be null (only covered pixels count).
// grad_texture (Ht*Wt*C) and grad_verts (V*3, world space) are ACCUMULATED and may be null.
void render_mesh_backward(const Camera& cam, const MeshRenderInput& in, MeshRender& fwd, const float* grad_color,
                          const float* grad_depth, float* grad_texture, float* grad_verts);

}  // namespace haha
