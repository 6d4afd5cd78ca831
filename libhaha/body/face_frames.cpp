// CPU launchers of the face-frame and Gaussian-transform kernels (face_frames.h).
#include "body/face_frames.h"

#include <string>
#include <vector>

#include "core/error.h"
#include "core/parallel.h"

namespace haha {
namespace {

template <class T>
Vec3<T> corner(const T* verts, const int32_t* faces, int f, int i) {
  return Vec3<T>::load(verts + 3 * int64_t(faces[3 * f + i]));
}

template <class T>
void check_faces(const GaussianLocalView<T>& g, int num_faces, const char* who) {
  for (int i = 0; i < g.n; ++i)
    if (g.face[i] < 0 || g.face[i] >= num_faces)
      fail(who, "Gaussian " + std::to_string(i) + " has face " + std::to_string(g.face[i]) + ", mesh has " +
                    std::to_string(num_faces) + " faces");
}

}  // namespace

template <class T>
void compute_face_frames(const T* verts, const int32_t* faces, int num_faces, T divisor, FaceFrame<T>* frames) {
  parallel_for(num_faces, [&](int64_t f) {
    frames[f] = face_frame(corner(verts, faces, int(f), 0), corner(verts, faces, int(f), 1),
                           corner(verts, faces, int(f), 2), divisor);
  });
}

template <class T>
void face_frames_backward(const T* verts, const int32_t* faces, int num_faces, T divisor,
                          const FaceFrameGrad<T>* d_frames, T* d_verts) {
  // Per-face corner gradients in parallel, then a serial scatter (faces share vertices).
  std::vector<Vec3<T>> dc(size_t(num_faces) * 3);
  parallel_for(num_faces, [&](int64_t f) {
    face_frame_backward(corner(verts, faces, int(f), 0), corner(verts, faces, int(f), 1),
                        corner(verts, faces, int(f), 2), divisor, d_frames[f], dc[3 * f], dc[3 * f + 1],
                        dc[3 * f + 2]);
  });
  for (int f = 0; f < num_faces; ++f)
    for (int i = 0; i < 3; ++i) {
      T* d = d_verts + 3 * int64_t(faces[3 * f + i]);
      d[0] += dc[3 * f + i].x;
      d[1] += dc[3 * f + i].y;
      d[2] += dc[3 * f + i].z;
    }
}

template <class T>
void pose_gaussians(const T* verts, const int32_t* faces, int num_faces, T divisor, const GaussianLocalView<T>& g,
                    T* means, T* quats, T* scales) {
  check_faces(g, num_faces, "pose_gaussians");
  std::vector<FaceFrame<T>> frames(num_faces);
  compute_face_frames(verts, faces, num_faces, divisor, frames.data());
  parallel_for(g.n, [&](int64_t i) {
    Vec3<T> mu_w, s_w;
    Quat<T> r_w;
    pose_gaussian(frames[g.face[i]], Vec3<T>::load(g.offset + 3 * i), Quat<T>::load(g.rotation + 4 * i),
                  Vec3<T>::load(g.scale + 3 * i), mu_w, r_w, s_w);
    mu_w.store(means + 3 * i);
    r_w.store(quats + 4 * i);
    s_w.store(scales + 3 * i);
  });
}

template <class T>
void pose_gaussians_backward(const T* verts, const int32_t* faces, int num_faces, T divisor,
                             const GaussianLocalView<T>& g, const std::type_identity_t<T>* d_means,
                             const std::type_identity_t<T>* d_quats, const std::type_identity_t<T>* d_scales,
                             std::type_identity_t<T>* d_verts, std::type_identity_t<T>* d_offset,
                             std::type_identity_t<T>* d_rotation,
                             std::type_identity_t<T>* d_scale) {
  check_faces(g, num_faces, "pose_gaussians_backward");
  std::vector<FaceFrame<T>> frames(num_faces);
  compute_face_frames(verts, faces, num_faces, divisor, frames.data());
  // Gaussians grouped by face (counting sort, stable), so each face sums its own.
  std::vector<int32_t> start(size_t(num_faces) + 1, 0), order(g.n);
  for (int i = 0; i < g.n; ++i) ++start[g.face[i] + 1];
  for (int f = 0; f < num_faces; ++f) start[f + 1] += start[f];
  {
    std::vector<int32_t> fill(start.begin(), start.end() - 1);
    for (int i = 0; i < g.n; ++i) order[fill[g.face[i]]++] = i;
  }
  std::vector<FaceFrameGrad<T>> dframes(d_verts ? num_faces : 0);
  const Vec3<T> zero3{};
  const Quat<T> zero4{0, 0, 0, 0};
  parallel_for(num_faces, [&](int64_t f) {
    FaceFrameGrad<T> df;
    for (int o = start[f]; o < start[f + 1]; ++o) {
      const int i = order[o];
      Vec3<T> dmu{}, ds{};
      Quat<T> dr{0, 0, 0, 0};
      pose_gaussian_backward(frames[f], Vec3<T>::load(g.offset + 3 * i), Quat<T>::load(g.rotation + 4 * i),
                             Vec3<T>::load(g.scale + 3 * i), d_means ? Vec3<T>::load(d_means + 3 * i) : zero3,
                             d_quats ? Quat<T>::load(d_quats + 4 * i) : zero4,
                             d_scales ? Vec3<T>::load(d_scales + 3 * i) : zero3, dmu, dr, ds, df);
      if (d_offset)
        for (int c = 0; c < 3; ++c) d_offset[3 * i + c] += dmu[c];
      if (d_scale)
        for (int c = 0; c < 3; ++c) d_scale[3 * i + c] += ds[c];
      if (d_rotation) {
        d_rotation[4 * i] += dr.w;
        d_rotation[4 * i + 1] += dr.x;
        d_rotation[4 * i + 2] += dr.y;
        d_rotation[4 * i + 3] += dr.z;
      }
    }
    if (d_verts) dframes[f] = df;
  });
  if (d_verts) face_frames_backward(verts, faces, num_faces, divisor, dframes.data(), d_verts);
}

GaussianLocalView<float> view_of(const BoundGaussians& g) {
  return {g.size(), g.face.data(), g.offset.data(), g.rotation.data(), g.scale.data()};
}

void pose_gaussians(const float* verts, const BodyModel& body, float divisor, const BoundGaussians& g, float* means,
                    float* quats, float* scales) {
  pose_gaussians(verts, body.faces.data(), body.num_faces, divisor, view_of(g), means, quats, scales);
}

#define HAHA_FACE_FRAMES_INSTANTIATE(T)                                                                            \
  template void compute_face_frames<T>(const T*, const int32_t*, int, T, FaceFrame<T>*);                         \
  template void face_frames_backward<T>(const T*, const int32_t*, int, T, const FaceFrameGrad<T>*, T*);          \
  template void pose_gaussians<T>(const T*, const int32_t*, int, T, const GaussianLocalView<T>&, T*, T*, T*);    \
  template void pose_gaussians_backward<T>(const T*, const int32_t*, int, T, const GaussianLocalView<T>&,        \
                                           const T*, const T*, const T*, T*, T*, T*, T*);
HAHA_FACE_FRAMES_INSTANTIATE(float)
HAHA_FACE_FRAMES_INSTANTIATE(double)
#undef HAHA_FACE_FRAMES_INSTANTIATE

}  // namespace haha
