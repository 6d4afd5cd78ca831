#include "render/mesh_antialias.h"

#include <algorithm>
#include <string>

#include "core/error.h"
#include "render/scatter.h"

namespace haha {

std::vector<int32_t> mesh_face_neighbors(const int32_t* faces, int num_faces, int num_verts) {
  // (undirected edge, face corner) sorted by edge: an edge with exactly two entries links
  // its faces; one entry is a boundary, three or more a non-manifold edge (both -1).
  struct EdgeUse {
    uint64_t key;
    int64_t corner;  // 3 f + i
  };
  std::vector<EdgeUse> uses(size_t(num_faces) * 3);
  for (int f = 0; f < num_faces; ++f)
    for (int i = 0; i < 3; ++i) {
      const int32_t a = faces[3 * f + (i + 1) % 3], b = faces[3 * f + (i + 2) % 3];
      if (a < 0 || a >= num_verts || b < 0 || b >= num_verts)
        fail("mesh_face_neighbors", "face " + std::to_string(f) + " has a vertex index outside [0, " +
                                        std::to_string(num_verts) + ")");
      uses[size_t(3 * f + i)] = {(uint64_t(uint32_t(std::min(a, b))) << 32) | uint32_t(std::max(a, b)),
                                 int64_t(3) * f + i};
    }
  std::sort(uses.begin(), uses.end(),
            [](const EdgeUse& x, const EdgeUse& y) { return x.key != y.key ? x.key < y.key : x.corner < y.corner; });
  std::vector<int32_t> out(size_t(num_faces) * 3, -1);
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    while (j < uses.size() && uses[j].key == uses[i].key) ++j;
    if (j - i == 2) {
      out[size_t(uses[i].corner)] = int32_t(uses[i + 1].corner / 3);
      out[size_t(uses[i + 1].corner)] = int32_t(uses[i].corner / 3);
    }
    i = j;
  }
  return out;
}

namespace {

template <class T>
void check_inputs(const AntialiasInputsT<T>& in, const char* fn) {
  if (in.camera.width <= 0 || in.camera.height <= 0) fail(fn, "no camera");
  if (!in.tri || !in.depth || !in.color || !in.mask || !in.neighbors || (in.mesh.num_faces > 0 && !in.mesh.faces) ||
      (in.mesh.num_verts > 0 && !in.mesh.verts))
    fail(fn, "missing input buffers");
  if (in.channels < 1 || in.channels > 8) fail(fn, "channels must be in [1, 8]");
}

}  // namespace

template <class T>
void antialias(const AntialiasInputsT<T>& in, NoDeduce<T>* color_out, NoDeduce<T>* mask_out) {
  check_inputs(in, "antialias");
  const int W = in.camera.width, H = in.camera.height, C = in.channels;
  detail::parallel_items(int64_t(W) * H, [&](int64_t p) {
    antialias_pixel(in, int(p % W), int(p / W), color_out + p * C, mask_out + p);
  });
}

template <class T>
void antialias_backward(const AntialiasInputsT<T>& in, const NoDeduce<T>* grad_color_out,
                        const NoDeduce<T>* grad_mask_out, NoDeduce<T>* grad_color, NoDeduce<T>* grad_mask,
                        NoDeduce<T>* grad_verts) {
  check_inputs(in, "antialias_backward");
  const int W = in.camera.width, H = in.camera.height, C = in.channels;
  const int64_t P = int64_t(W) * H, V = in.mesh.num_verts;
  // One packed buffer (colour | mask | vertices) so a single deterministic scatter serves all.
  const int64_t oc = 0, om = P * C, ov = om + P, size = ov + 3 * V;
  std::vector<T> acc(size_t(size), T(0));
  std::vector<T> zero(size_t(C), T(0));
  detail::scatter_add(P, size, acc.data(), [&](int64_t p, T* buf) {
    const T* gc = grad_color_out ? grad_color_out + p * C : zero.data();
    const T gm = grad_mask_out ? grad_mask_out[p] : T(0);
    antialias_backward_pixel(in, int(p % W), int(p / W), gc, gm, buf + oc, buf + om, buf + ov);
  });
  if (grad_color)
    for (int64_t i = 0; i < P * C; ++i) grad_color[i] += acc[size_t(oc + i)];
  if (grad_mask)
    for (int64_t i = 0; i < P; ++i) grad_mask[i] += acc[size_t(om + i)];
  if (grad_verts)
    for (int64_t i = 0; i < 3 * V; ++i) grad_verts[i] += acc[size_t(ov + i)];
}

#define HAHA_INSTANTIATE_AA(T)                                                                                   \
  template void antialias<T>(const AntialiasInputsT<T>&, T*, T*);                                                \
  template void antialias_backward<T>(const AntialiasInputsT<T>&, const T*, const T*, T*, T*, T*);
HAHA_INSTANTIATE_AA(float)
HAHA_INSTANTIATE_AA(double)
#undef HAHA_INSTANTIATE_AA

}  // namespace haha
