// The one camera type used everywhere: pinhole, OpenCV conventions (x right, y down,
// z forward), intrinsics K, world-to-camera extrinsics, pixel centres at +0.5 (pixel
// (i, j) covers [i, i+1) x [j, j+1) and its centre is (i + 0.5, j + 0.5)).
#pragma once

#include "core/math.h"

namespace haha {

template <class T>
struct CameraT {
  int width = 0, height = 0;
  T fx = 1, fy = 1, cx = 0, cy = 0;  // K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
  Mat3<T> R = Mat3<T>::identity();   // world -> camera rotation
  Vec3<T> t{};                       // world -> camera translation: x_cam = R x + t
  T near_plane = T(0.01), far_plane = T(100);

  HAHA_HD Vec3<T> to_camera(Vec3<T> x) const { return R * x + t; }
  // Pixel coordinates (continuous; centre of pixel i at i + 0.5) of a camera-space point.
  HAHA_HD Vec2<T> project(Vec3<T> xc) const { return {fx * xc.x / xc.z + cx, fy * xc.y / xc.z + cy}; }
  template <class U>
  CameraT<U> cast() const {
    CameraT<U> c;
    c.width = width; c.height = height;
    c.fx = U(fx); c.fy = U(fy); c.cx = U(cx); c.cy = U(cy);
    for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) c.R.a[i][j] = U(R.a[i][j]);
    c.t = Vec3<U>(U(t.x), U(t.y), U(t.z));
    c.near_plane = U(near_plane); c.far_plane = U(far_plane);
    return c;
  }
};
using Camera = CameraT<float>;

}  // namespace haha
