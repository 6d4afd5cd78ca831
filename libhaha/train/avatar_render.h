// One differentiable render of the HAHA avatar for a posed body (docs/method.md section 2), the
// chain every stage and the evaluation share:
//
//   posed vertices --face frames--> world Gaussians --raster (occluded by D)--> C_front, A
//   posed vertices --mesh raster + texture--> M, D, m
//   I = C_front + (1 - A) (m M + (1 - m) B)                           (render/merge.h)
//
// Either layer may be absent: Gaussians only (stage 1, "full Gaussians"), mesh only
// (stage 2, "textured mesh"), or both (stage 3, the HAHA avatar). The mesh layer is either
// rendered here from a texture or borrowed precomputed (frozen poses and texture in
// stage 3). The backward returns gradients for the image I and, optionally, an extra
// gradient on A (silhouette losses), to: posed vertices, local Gaussian parameters
// (offset, raw rotation, activated scale / colour / opacity) and the texture.
#pragma once

#include <cstdint>
#include <vector>

#include "body/body_model.h"
#include "render/camera.h"
#include "render/gaussian_raster.h"
#include "render/render_mesh.h"

namespace haha {

// Face-bound Gaussians, borrowed; scale / colour / opacity activated, rotation raw.
struct GaussianSetView {
  int count = 0;
  const int32_t* face = nullptr;
  const float* offset = nullptr;    // (N, 3)
  const float* rotation = nullptr;  // (N, 4)
  const float* scale = nullptr;     // (N, 3) units of k
  const float* color = nullptr;     // (N, 3)
  const float* opacity = nullptr;   // (N)
};

// A precomputed mesh layer (P = H * W pixels), borrowed.
struct MeshLayerView {
  const float* depth = nullptr;  // (P) camera z, +inf outside
  const float* color = nullptr;  // (P, 3) M
  const float* mask = nullptr;   // (P) m
};

struct AvatarRenderRequest {
  const Camera* camera = nullptr;
  const BodyModel* body = nullptr;  // faces, vt, ft
  const float* verts = nullptr;     // (V, 3) posed body
  float face_scale_divisor = 1.0f;
  const GaussianSetView* gaussians = nullptr;  // null: no Gaussian layer
  // Mesh layer: `mesh_layer` (precomputed, no gradient) or `texture` (rendered here);
  // neither: no mesh.
  const MeshLayerView* mesh_layer = nullptr;
  const TextureView* texture = nullptr;
  float depth_margin = 0.0f;        // Gaussians in front where centre z <= D + margin
  float background[3] = {0, 0, 0};
};

// Outputs and scratch, reused between calls.
struct AvatarRenderBuffers {
  int width = 0, height = 0;
  std::vector<float> image;        // (P, 3) I
  std::vector<float> color_front;  // (P, 3) C_front (premultiplied), 0 without Gaussians
  std::vector<float> alpha;        // (P) A, 0 without Gaussians
  MeshLayerView mesh;              // the mesh layer used (points into mesh_render or the request's)
  MeshRender mesh_render;          // when rendered from a texture
  std::vector<float> means, quats, scales;  // (N, 3/4/3) posed Gaussians
  GaussianRasterState<float> raster;
  // backward scratch
  std::vector<float> d_color_front, d_alpha, d_mesh_color, d_means, d_quats, d_scales, d_opacity, d_color, depth_tmp;
};

// Gradient outputs, all optional, all ACCUMULATED (+=).
struct AvatarRenderGrads {
  float* verts = nullptr;     // (V, 3)
  float* offset = nullptr;    // (N, 3)
  float* rotation = nullptr;  // (N, 4) raw quaternion
  float* scale = nullptr;     // (N, 3) activated
  float* color = nullptr;     // (N, 3) activated
  float* opacity = nullptr;   // (N) activated
  float* texture = nullptr;   // (Ht, Wt, 3), when the mesh is rendered from a texture
  float* means2d_norm_accum = nullptr;  // (N) densification statistic (rasterizer's +=)
};

// Throws haha::Error for inconsistent inputs (sizes, missing buffers).
void render_avatar(const AvatarRenderRequest& req, AvatarRenderBuffers& buf);

// Backward of the last render_avatar with the same request. d_image (P, 3) is dL/dI;
// d_alpha_extra (P, may be null) is added to dL/dA (a silhouette loss on A);
// d_means_extra (N, 3, may be null) to dL/d(world means) (a regulariser on the posed
// centres, e.g. the KNN distance term).
void render_avatar_backward(const AvatarRenderRequest& req, AvatarRenderBuffers& buf, const float* d_image,
                            const float* d_alpha_extra, const float* d_means_extra, const AvatarRenderGrads& grads);

}  // namespace haha
