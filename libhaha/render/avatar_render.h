// One differentiable render of the HAHA avatar for a posed body (docs/method.md section 2),
// the chain training, evaluation, the bench and the avatar loader share:
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
//
// The orchestration is written once (render/avatar_render_impl.h) over a backend: this
// header is the CPU one; cuda/avatar_render_cuda.h runs the same chain on the GPU with
// the same request and gradient structs holding device pointers.
#pragma once

#include <cstdint>
#include <vector>

#include "body/avatar.h"
#include "body/body_model.h"
#include "core/camera.h"
#include "render/gaussian_raster.h"
#include "render/render_mesh.h"

namespace haha {

// The body's fixed topology, borrowed: faces, UVs (vt) and UV faces (ft).
struct BodyTopology {
  int num_verts = 0, num_faces = 0, num_uv = 0;
  const int32_t* faces = nullptr;     // (F, 3)
  const float* uv = nullptr;          // (T, 2)
  const int32_t* uv_faces = nullptr;  // (F, 3); null: no UV map (no textured mesh)
  const int32_t* face_neighbors = nullptr;  // (F, 3) mesh_face_neighbors; needed for antialias
};
BodyTopology topology_of(const BodyModel& body);  // host pointers into `body`

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
  const BodyTopology* body = nullptr;
  const float* verts = nullptr;     // (V, 3) posed body
  float face_scale_divisor = 1.0f;
  const GaussianSetView* gaussians = nullptr;  // null: no Gaussian layer
  // Mesh layer: `mesh_layer` (precomputed, no gradient) or `texture` (rendered here);
  // neither: no mesh.
  const MeshLayerView* mesh_layer = nullptr;
  const TextureView* texture = nullptr;
  const float* mesh_coverage = nullptr;  // (V) the mesh's coverage cut (Avatar::mesh_coverage); null: none
  float depth_margin = 0.0f;        // Gaussians in front where centre z <= D + margin
  float background[3] = {0, 0, 0};
  // Antialias the silhouette of the mesh rendered from `texture` (render/mesh_antialias.h):
  // partial coverage at its edges, and a gradient of the image to the vertices there.
  bool antialias = false;
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
  float means2d_norm_scale[2] = {1, 1};  // its per-axis factors (GaussianGrads::means2d_norm_scale_x/y)
  // (N) ACCUMULATED (+=): what deleting each Gaussian alone would change in the merged image,
  // in pixels fully changed (GaussianGrads::removal_cost, the mesh and background behind).
  float* removal_cost = nullptr;
};

// Host views of a trained avatar (body topology, Gaussians, texture) for requests; keep it
// alive while a request made from it is used.
struct AvatarViews {
  std::vector<int32_t> face_neighbors;  // body.face_neighbors points here
  BodyTopology body;
  GaussianSetView gaussians;
  TextureView texture;
  explicit AvatarViews(const Avatar& a);
  AvatarViews(const AvatarViews&) = delete;
  AvatarViews& operator=(const AvatarViews&) = delete;
};
// A request for avatar `a` posed as `verts`, with its face-scale divisor and depth margin;
// `mesh` / `gaussians` choose the layers; background black.
AvatarRenderRequest avatar_request(const Avatar& a, const AvatarViews& views, const Camera& cam, const float* verts,
                                   bool mesh, bool gaussians);

// Outputs and scratch of one backend, reused between calls. `Buffer<T>` is the backend's
// owning array (std::vector on the CPU, a device buffer on the GPU).
template <class Backend>
struct AvatarRenderBuffersT {
  template <class T>
  using Buffer = typename Backend::template Buffer<T>;
  int width = 0, height = 0;
  Buffer<float> image;        // (P, 3) I
  Buffer<float> color_front;  // (P, 3) C_front (premultiplied), 0 without Gaussians
  Buffer<float> alpha;        // (P) A, 0 without Gaussians
  MeshLayerView mesh;         // the mesh layer used (points into mesh_render or the request's)
  typename Backend::MeshRender mesh_render;  // when rendered from a texture
  Buffer<float> means, quats, scales;        // (N, 3/4/3) posed Gaussians
  typename Backend::RasterState raster;
  typename Backend::PoseScratch pose;
  Buffer<float> aa_color, aa_mask;           // (P, 3), (P) the antialiased mesh layer
  // backward scratch
  Buffer<float> depth_tmp, d_color_front, d_alpha, d_mesh_color, d_mesh_mask, d_mesh_color_raw, d_means, d_quats,
      d_scales, d_opacity, d_color, d_verts_scratch, under;
};

// The CPU backend: OpenMP threads over host memory.
struct CpuRenderBackend {
  template <class T>
  using Buffer = std::vector<T>;
  using MeshRender = haha::MeshRender;
  using RasterState = GaussianRasterState<float>;
  struct PoseScratch {};
};
using AvatarRenderBuffers = AvatarRenderBuffersT<CpuRenderBackend>;

// Throws haha::Error for inconsistent inputs (sizes, missing buffers).
void render_avatar(const AvatarRenderRequest& req, AvatarRenderBuffers& buf);

// Backward of the last render_avatar with the same request. d_image (P, 3) is dL/dI;
// d_alpha_extra (P, may be null) is added to dL/dA (a silhouette loss on A);
// d_means_extra (N, 3, may be null) to dL/d(world means) (a regulariser on the posed
// centres, e.g. the KNN distance term).
void render_avatar_backward(const AvatarRenderRequest& req, AvatarRenderBuffers& buf, const float* d_image,
                            const float* d_alpha_extra, const float* d_means_extra, const AvatarRenderGrads& grads);

}  // namespace haha
