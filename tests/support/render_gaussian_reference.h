// Test-only brute-force Gaussian renderer in double: every Gaussian evaluated at every
// pixel, sorted by depth, no tiles, no bounding boxes. Its projection is written out
// independently of render/gaussian_kernels.h (explicit 2x3 Jacobian, matrix products) from
// the model stated there. It also reports how close the scene is to each hard cut, so
// gradient tests can pick inputs away from them.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include "core/camera.h"
#include "render/sh.h"

namespace haha::testref {

struct Scene {
  int n = 0;
  std::vector<double> means, quats, scales, opacities, colors, sh;
  int sh_degree = 0;
  bool use_sh = false;
};

struct RefSplat {
  bool valid = false;
  double mx = 0, my = 0, ia = 0, ib = 0, ic = 0, o = 0, z = 0, col[3] = {0, 0, 0};
  double u_raw = 0, v_raw = 0, ulo = 0, uhi = 0, vlo = 0, vhi = 0, sh_raw[3] = {0, 0, 0};
};

inline RefSplat project(const CameraT<double>& cam, const Scene& s, int i, bool aa) {
  RefSplat r;
  const double* m = &s.means[3 * i];
  double p[3];
  for (int a = 0; a < 3; ++a) p[a] = cam.R.a[a][0] * m[0] + cam.R.a[a][1] * m[1] + cam.R.a[a][2] * m[2] + cam.t[a];
  if (!(p[2] > cam.near_plane)) return r;
  const double* q = &s.quats[4 * i];
  const double qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (qn == 0) return r;
  const Quat<double> qq(q[0] / qn, q[1] / qn, q[2] / qn, q[3] / qn);
  const Mat3<double> rot = quat_to_mat(qq);
  double cov3[3][3] = {};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int k = 0; k < 3; ++k) cov3[a][b] += rot.a[a][k] * rot.a[b][k] * s.scales[3 * i + k] * s.scales[3 * i + k];
  r.u_raw = p[0] / p[2];
  r.v_raw = p[1] / p[2];
  r.ulo = -1.3 * cam.cx / cam.fx;
  r.uhi = 1.3 * (cam.width - cam.cx) / cam.fx;
  r.vlo = -1.3 * cam.cy / cam.fy;
  r.vhi = 1.3 * (cam.height - cam.cy) / cam.fy;
  const double u = std::clamp(r.u_raw, r.ulo, r.uhi), v = std::clamp(r.v_raw, r.vlo, r.vhi);
  const double z = p[2];
  const double J[2][3] = {{cam.fx / z, 0, -cam.fx * u / z}, {0, cam.fy / z, -cam.fy * v / z}};
  double JW[2][3] = {};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 3; ++b)
      for (int k = 0; k < 3; ++k) JW[a][b] += J[a][k] * cam.R.a[k][b];
  double cov2[2][2] = {};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) cov2[a][b] += JW[a][k] * cov3[k][l] * JW[b][l];
  const double det0 = cov2[0][0] * cov2[1][1] - cov2[0][1] * cov2[1][0];
  cov2[0][0] += 0.3;
  cov2[1][1] += 0.3;
  const double det = cov2[0][0] * cov2[1][1] - cov2[0][1] * cov2[1][0];
  if (!(det > 0)) return r;
  r.o = s.opacities[i] * (aa ? std::sqrt(std::max(0.0, det0 / det)) : 1.0);
  r.ia = cov2[1][1] / det;
  r.ib = -cov2[0][1] / det;
  r.ic = cov2[0][0] / det;
  r.mx = cam.fx * r.u_raw + cam.cx;
  r.my = cam.fy * r.v_raw + cam.cy;
  r.z = z;
  if (s.use_sh) {
    const Vec3<double> c = -(transpose(cam.R) * cam.t);
    Vec3<double> d(m[0] - c.x, m[1] - c.y, m[2] - c.z);
    d = d / norm(d);
    const Vec3<double> col = eval_sh(s.sh_degree, &s.sh[size_t(i) * 3 * sh_coeff_count(s.sh_degree)], d);
    for (int k = 0; k < 3; ++k) {
      r.sh_raw[k] = col[k] + 0.5;
      r.col[k] = std::max(0.0, col[k] + 0.5);
    }
  } else {
    for (int k = 0; k < 3; ++k) r.col[k] = s.colors[3 * i + k];
  }
  r.valid = true;
  return r;
}

struct Image {
  int w = 0, h = 0;
  std::vector<double> color, alpha, depth, composite;
};

// Closest approach of the scene to each hard cut (for choosing FD test inputs).
struct Margins {
  double alpha_min = 1e9;   // min |o G - 1/255| over evaluated (pixel, Gaussian) pairs
  double alpha_max = 1e9;   // min |o G - 0.99|
  double trans = 1e9;       // min |T (1 - alpha) - 1e-4| / 1e-4
  double depth = 1e9;       // min |z - D| over pixels where the Gaussian has alpha >= 1/255
  double jac = 1e9;         // min distance of u, v to the clamp bounds
  double sh_clamp = 1e9;    // min |SH colour + 0.5|
  double near = 1e9;        // min z - near
  double zsep = 1e9;        // min depth gap between two visible Gaussians (sort order)
};

inline Image render(const CameraT<double>& cam, const Scene& s, bool aa, const double* depth_map, const double* bg,
                    const double* bg_color, bool early_stop = true, Margins* mg = nullptr) {
  Image im;
  im.w = cam.width;
  im.h = cam.height;
  const size_t P = size_t(im.w) * im.h;
  im.color.assign(3 * P, 0);
  im.alpha.assign(P, 0);
  im.depth.assign(P, 0);
  im.composite.assign(3 * P, 0);
  std::vector<RefSplat> sp(size_t(s.n));
  for (int i = 0; i < s.n; ++i) sp[size_t(i)] = project(cam, s, i, aa);
  std::vector<int> order(size_t(s.n));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return sp[size_t(a)].z < sp[size_t(b)].z; });
  if (mg)
    for (const auto& r : sp) {
      if (!r.valid) continue;
      mg->jac = std::min({mg->jac, std::abs(r.u_raw - r.ulo), std::abs(r.u_raw - r.uhi), std::abs(r.v_raw - r.vlo),
                          std::abs(r.v_raw - r.vhi)});
      if (s.use_sh)
        for (double c : r.sh_raw) mg->sh_clamp = std::min(mg->sh_clamp, std::abs(c));
      mg->near = std::min(mg->near, r.z - cam.near_plane);
    }
  if (mg)
    for (size_t k = 1; k < order.size(); ++k) {
      const RefSplat &a = sp[size_t(order[k - 1])], &b = sp[size_t(order[k])];
      if (a.valid && b.valid) mg->zsep = std::min(mg->zsep, b.z - a.z);
    }
  for (int y = 0; y < im.h; ++y)
    for (int x = 0; x < im.w; ++x) {
      const size_t pix = size_t(y) * im.w + x;
      const double D = depth_map ? depth_map[pix] : std::numeric_limits<double>::infinity();
      double T = 1, C[3] = {0, 0, 0}, Z = 0;
      for (int i : order) {
        const RefSplat& r = sp[size_t(i)];
        if (!r.valid) continue;
        const double dx = x + 0.5 - r.mx, dy = y + 0.5 - r.my;
        const double a = r.o * std::exp(-0.5 * (r.ia * dx * dx + r.ic * dy * dy) - r.ib * dx * dy);
        if (mg) {
          mg->alpha_min = std::min(mg->alpha_min, std::abs(a - 1.0 / 255.0));
          mg->alpha_max = std::min(mg->alpha_max, std::abs(a - 0.99));
          if (a >= 1.0 / 255.0 && std::isfinite(D)) mg->depth = std::min(mg->depth, std::abs(r.z - D));
        }
        if (r.z > D) break;
        const double alpha = std::min(0.99, a);
        if (alpha < 1.0 / 255.0) continue;
        if (mg) mg->trans = std::min(mg->trans, std::abs(T * (1 - alpha) - 1e-4) / 1e-4);
        if (early_stop && T * (1 - alpha) < 1e-4) break;
        for (int c = 0; c < 3; ++c) C[c] += r.col[c] * alpha * T;
        Z += r.z * alpha * T;
        T *= 1 - alpha;
      }
      for (int c = 0; c < 3; ++c) {
        im.color[3 * pix + c] = C[c];
        im.composite[3 * pix + c] = C[c] + T * (bg ? bg[3 * pix + c] : bg_color[c]);
      }
      im.alpha[pix] = 1 - T;
      im.depth[pix] = Z;
    }
  return im;
}

// A camera looking down +z from the origin (OpenCV), optionally rotated/translated.
inline CameraT<double> make_camera(int w, int h, double f) {
  CameraT<double> c;
  c.width = w;
  c.height = h;
  c.fx = f;
  c.fy = f * 1.1;
  c.cx = w * 0.5 + 1.25;
  c.cy = h * 0.5 - 0.75;
  return c;
}

// Random Gaussians in front of the camera, inside the view.
inline Scene random_scene(int n, unsigned seed, const CameraT<double>& cam, double scale_lo, double scale_hi,
                          double opa_lo = 0.3, double opa_hi = 0.9, int sh_degree = -1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  Scene s;
  s.n = n;
  s.use_sh = sh_degree >= 0;
  s.sh_degree = std::max(0, sh_degree);
  const Mat3<double> Rt = transpose(cam.R);
  for (int i = 0; i < n; ++i) {
    const double z = 1.5 + U(rng);
    const double px = (0.15 + 0.7 * U(rng)) * cam.width, py = (0.15 + 0.7 * U(rng)) * cam.height;
    const Vec3<double> pc((px - cam.cx) / cam.fx * z, (py - cam.cy) / cam.fy * z, z);
    const Vec3<double> w = Rt * (pc - cam.t);
    s.means.insert(s.means.end(), {w.x, w.y, w.z});
    s.quats.insert(s.quats.end(), {U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5});
    for (int k = 0; k < 3; ++k) s.scales.push_back(scale_lo + (scale_hi - scale_lo) * U(rng));
    s.opacities.push_back(opa_lo + (opa_hi - opa_lo) * U(rng));
    if (s.use_sh) {
      const int K = sh_coeff_count(s.sh_degree);
      for (int k = 0; k < K; ++k)
        for (int c = 0; c < 3; ++c) s.sh.push_back(k == 0 ? 1.0 * (U(rng) - 0.2) : 0.3 * (U(rng) - 0.5));
    } else {
      for (int c = 0; c < 3; ++c) s.colors.push_back(U(rng));
    }
  }
  return s;
}

}  // namespace haha::testref
