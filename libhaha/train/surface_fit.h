// The clothed surface (SMPL+D, Alldieck et al. 2018): a displacement of the body's rest
// vertices along their rest normals, h (V) in metres, fitted to the training frames after the
// pose fits and before stage 1, with the poses frozen. The fitted body is skin-tight; a
// jacket, trousers with volume or a hood stand out of it, and a texture painted on a surface
// inside the clothes puts colour in the wrong place in every view but the one it was seen
// from. The displaced body keeps the body's topology, joints, skinning and correctives
// (BodyModel::rest_offsets), so every stage, the .glb and every reader see it as it is.
//
// Per step one frame (seeded epochs), posed as base + h u (u: the rest normal carried by the
// frame's skinning, so the map from h to the posed vertices is exact and linear), and
//   L = w_photo |I - gt|^2 (the body textured by a texture learned alongside, over a random
//       background behind both the frame and the render; train/photo_fit.h does the same)
//     + w_silhouette mean[m (1 - k) + (1 - m) k] (the antialiased coverage m against the
//       mask k, both ways: the surface should end where the person does)
//     + w_laplacian mean_v (h_v - mean of its neighbours' h)^2 + w_shrink mean_v h_v^2.
// h is held in [-max_in, bound_v] after every step: bound_v = max_out, shrinking to max_held
// by the vertex's skinning weight on the hands, wrists, feet, ankles, jaw and eyes. Hands
// and feet: the fits and the masks are least reliable there (fingers, shoes in shadow) and a
// displacement would turn fingers into mittens; jaw and eyes: the face's shape drives its
// expressions and its texture is the most looked at. The first `warmup` share of the steps
// trains the texture alone. With `part_clearance` bound_v also keeps each part off the
// others in every frame (train/part_clearance.h: an arm at the side is not swallowed by the
// torso grown out to a side view's mask). A garment appended to the body (body/garment.h) moves too, in
// [0, garment_max_out] with its own Adam group (garment_lr) and smoothness over its own faces
// (garment_w_laplacian); `garment_only` holds the body at 0. Measured: docs/results.md, "The
// clothed surface" and "A garment around both legs".
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "body/body_model.h"
#include "core/math.h"
#include "train/config.h"
#include "train/trainer.h"

namespace haha {

struct SurfaceFitReport {
  std::vector<float> offsets;     // (V, 3) h n: what BodyModel::rest_offsets takes; empty when off
  double loss_start = 0, loss_end = 0;  // data loss, mean over the first 5% of the steps that move
                                        // the surface (after the warm-up) / the last 5%
  double mean_mm = 0;             // mean |h| over the vertices
  double p95_mm = 0, max_mm = 0;  // 95th percentile and largest outward h
  int side = 0;                   // longer image side of the last level
  int part_held = 0;              // body vertices whose outward bound another part more than halved
};

// Fits h to the frames (their params as given; betas from video_betas). `progress`
// (optional) is called every few steps with the steps done, their count and the mean data
// loss since the last call. Throws haha::Error "<frame>: ..." for frames without a mask or of
// different sizes.
SurfaceFitReport fit_rest_surface(const BodyModel& body, const std::vector<TrainFrame>& frames, bool premultiplied,
                                  const Stage0Config::Surface& opt, uint64_t seed,
                                  const std::function<void(int done, int total, double loss)>& progress = {});

// ---- the pieces, for tests --------------------------------------------------------------

// Area-weighted unit normals (V, 3) of a mesh (zero for a vertex with no face area).
std::vector<float> vertex_normals(const float* verts, int num_verts, const int32_t* faces, int num_faces);

// Vertex adjacency of a triangle mesh as compressed rows: the neighbours of v are
// idx[off[v] .. off[v + 1]), each once, in increasing order.
struct VertexAdjacency {
  std::vector<int32_t> off, idx;
};
VertexAdjacency vertex_adjacency(const int32_t* faces, int num_faces, int num_verts);

// E = w_laplacian / V sum_v (h_v - mean_{u ~ v} h_u)^2 + w_shrink / V sum_v h_v^2; adds dE/dh
// into grad (may be null). Vertices without neighbours have no Laplacian term.
template <class T>
T surface_regularizer(const T* h, const VertexAdjacency& adj, double w_laplacian, double w_shrink, T* grad);

// Posed vertices of the displaced body: out = base + h u ((V, 3), u the posed normal
// directions); the backward adds dL/dh_v = u_v . dL/dout_v into d_h.
template <class T>
void displace_posed(const T* base, const T* u, const T* h, int num_verts, T* out);
template <class T>
void displace_posed_backward(const T* u, const T* d_out, int num_verts, T* d_h);

// The posed directions u (V, 3) of the rest normals n (V, 3) for a pose whose skinning
// transforms are `skinning` (55 Rigid, LbsCache::skinning): u_v = sum_j w_vj R_j n_v.
void posed_normal_directions(const BodyModel& body, const std::vector<Rigid<float>>& skinning, const float* normals,
                             float* u);

// Per vertex the largest outward h: max_out, down to max_held by the share of the vertex's
// skinning weight on the held joints (wrists, hands, fingers, ankles, feet, jaw, eyes).
std::vector<float> outward_bounds(const BodyModel& body, double max_out, double max_held);

}  // namespace haha
