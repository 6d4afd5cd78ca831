// Test-only glue: runs the rasterizer (float or double) on a testref::Scene.
#pragma once

#include <cmath>
#include <vector>

#include "render/gaussian_raster.h"
#include "support/render_gaussian_reference.h"

namespace haha::testref {

template <class T>
struct Buffers {
  std::vector<T> means, quats, scales, opacities, colors, sh, depth_map, bg;
  int sh_degree = 0;
  T bg_color[3] = {0, 0, 0};
  GaussianInputs<T> inputs() const {
    GaussianInputs<T> in;
    in.count = int(opacities.size());
    in.means = means.data();
    in.quats = quats.data();
    in.scales = scales.data();
    in.opacities = opacities.data();
    if (!sh.empty()) {
      in.sh = sh.data();
      in.sh_degree = sh_degree;
    } else {
      in.colors = colors.data();
    }
    return in;
  }
};

template <class T>
std::vector<T> cast_vec(const std::vector<double>& v) {
  return std::vector<T>(v.begin(), v.end());
}

template <class T>
Buffers<T> to_buffers(const Scene& s, const std::vector<double>& depth_map = {}, const std::vector<double>& bg = {},
                      const double* bg_color = nullptr) {
  Buffers<T> b;
  b.means = cast_vec<T>(s.means);
  b.quats = cast_vec<T>(s.quats);
  b.scales = cast_vec<T>(s.scales);
  b.opacities = cast_vec<T>(s.opacities);
  if (s.use_sh) {
    b.sh = cast_vec<T>(s.sh);
    b.sh_degree = s.sh_degree;
  } else {
    b.colors = cast_vec<T>(s.colors);
  }
  b.depth_map = cast_vec<T>(depth_map);
  b.bg = cast_vec<T>(bg);
  if (bg_color)
    for (int c = 0; c < 3; ++c) b.bg_color[c] = T(bg_color[c]);
  return b;
}

template <class T>
struct Rendered {
  std::vector<T> color, alpha, depth, composite;
};

template <class T>
GaussianRasterSettings<T> settings_of(const Buffers<T>& b, bool aa) {
  GaussianRasterSettings<T> st;
  st.antialiased = aa;
  st.depth_map = b.depth_map.empty() ? nullptr : b.depth_map.data();
  st.background = b.bg.empty() ? nullptr : b.bg.data();
  st.background_color = Vec3<T>(b.bg_color[0], b.bg_color[1], b.bg_color[2]);
  return st;
}

template <class T>
Rendered<T> run_forward(const Buffers<T>& b, const CameraT<double>& camd, bool aa, GaussianRasterState<T>& state) {
  const CameraT<T> cam = camd.cast<T>();
  const size_t P = size_t(cam.width) * cam.height;
  Rendered<T> r;
  r.color.assign(3 * P, T(-7));
  r.alpha.assign(P, T(-7));
  r.depth.assign(P, T(-7));
  r.composite.assign(3 * P, T(-7));
  GaussianRasterOutputs<T> out{r.color.data(), r.alpha.data(), r.depth.data(), r.composite.data()};
  rasterize_gaussians(b.inputs(), cam, settings_of(b, aa), state, out);
  return r;
}

template <class T>
bool all_finite(const std::vector<T>& v) {
  for (T x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

template <class A, class B>
double max_abs_diff(const std::vector<A>& a, const std::vector<B>& b) {
  double m = a.size() == b.size() ? 0.0 : 1e300;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) m = std::max(m, std::abs(double(a[i]) - double(b[i])));
  return m;
}

}  // namespace haha::testref
