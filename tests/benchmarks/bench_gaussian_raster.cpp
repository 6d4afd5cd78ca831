// Gaussian rasterizer speed at 512 x 512 with 20k Gaussians laid out like an avatar:
// sampled on a body made of ellipsoids (head, torso, pelvis, arms, legs, hands, feet),
// ~1 cm scales, flattened along the surface normal, +-5 mm off the surface; camera 2.5 m
// away; the body's own depth (analytic ray cast of the ellipsoids) is the occlusion map.
//   cmake --build build --target bench_gaussian_raster && OMP_NUM_THREADS=2 build/tests/bench_gaussian_raster
#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/parallel.h"
#include "render/gaussian_raster.h"

using namespace haha;

namespace {

struct Ellipsoid {
  Vec3f c, r;
};

// World: y down, z away from the camera (OpenCV-like), body centred at the origin.
const std::vector<Ellipsoid> kBody = {
    {{0, -0.10f, 0}, {0.17f, 0.28f, 0.11f}},       // torso
    {{0, 0.20f, 0}, {0.16f, 0.12f, 0.10f}},        // pelvis
    {{0, -0.62f, 0}, {0.09f, 0.12f, 0.10f}},       // head
    {{0, -0.45f, 0}, {0.05f, 0.07f, 0.05f}},       // neck
    {{-0.25f, -0.20f, 0}, {0.05f, 0.16f, 0.05f}},  // upper arms
    {{0.25f, -0.20f, 0}, {0.05f, 0.16f, 0.05f}},
    {{-0.28f, 0.10f, 0.02f}, {0.04f, 0.14f, 0.04f}},  // forearms
    {{0.28f, 0.10f, 0.02f}, {0.04f, 0.14f, 0.04f}},
    {{-0.29f, 0.30f, 0.03f}, {0.03f, 0.07f, 0.02f}},  // hands
    {{0.29f, 0.30f, 0.03f}, {0.03f, 0.07f, 0.02f}},
    {{-0.09f, 0.50f, 0}, {0.07f, 0.20f, 0.07f}},  // thighs
    {{0.09f, 0.50f, 0}, {0.07f, 0.20f, 0.07f}},
    {{-0.09f, 0.88f, 0}, {0.05f, 0.20f, 0.05f}},  // shins
    {{0.09f, 0.88f, 0}, {0.05f, 0.20f, 0.05f}},
    {{-0.09f, 1.10f, -0.05f}, {0.04f, 0.03f, 0.10f}},  // feet
    {{0.09f, 1.10f, -0.05f}, {0.04f, 0.03f, 0.10f}},
};

struct AvatarScene {
  Camera cam;
  std::vector<float> means, quats, scales, opacities, colors, depth;
};

AvatarScene make_scene(int n, int size) {
  AvatarScene s;
  s.cam.width = s.cam.height = size;
  s.cam.fx = s.cam.fy = 0.64f * float(size) * 2.5f / 2.0f;  // 2 m tall field of view at 2.5 m
  s.cam.cx = s.cam.cy = 0.5f * float(size);
  s.cam.t = Vec3f(0, -0.15f, 2.5f);
  // Approximate ellipsoid areas to spread the Gaussians evenly.
  std::vector<double> area;
  double total = 0;
  for (const auto& e : kBody) {
    const double p = 1.6;
    const double a = 4 * M_PI *
                     std::pow((std::pow(e.r.x * e.r.y, p) + std::pow(e.r.x * e.r.z, p) + std::pow(e.r.y * e.r.z, p)) / 3,
                              1 / p);
    area.push_back(a);
    total += a;
  }
  std::mt19937 rng(1);
  std::normal_distribution<float> N(0, 1);
  std::uniform_real_distribution<float> U(0, 1);
  for (size_t k = 0; k < kBody.size(); ++k) {
    const auto& e = kBody[k];
    const int m = int(n * area[k] / total + 0.5);
    for (int i = 0; i < m && int(s.opacities.size()) < n; ++i) {
      Vec3f d(N(rng), N(rng), N(rng));
      d = d / norm(d);
      const Vec3f p = e.c + mul(d, e.r);
      Vec3f nrm(d.x / e.r.x, d.y / e.r.y, d.z / e.r.z);
      nrm = nrm / norm(nrm);
      const Vec3f mean = p + (0.005f * (2 * U(rng) - 1)) * nrm;
      // Rotation taking local z to the normal.
      Vec3f tx = std::abs(nrm.x) < 0.9f ? cross(Vec3f(1, 0, 0), nrm) : cross(Vec3f(0, 1, 0), nrm);
      tx = tx / norm(tx);
      const Mat3f R = Mat3f::from_cols(tx, cross(nrm, tx), nrm);
      const Quat<float> q = mat_to_quat(R);
      s.means.insert(s.means.end(), {mean.x, mean.y, mean.z});
      s.quats.insert(s.quats.end(), {q.w, q.x, q.y, q.z});
      s.scales.insert(s.scales.end(), {0.006f + 0.008f * U(rng), 0.006f + 0.008f * U(rng), 0.002f});
      s.opacities.push_back(0.5f + 0.5f * U(rng));
      s.colors.insert(s.colors.end(), {U(rng), U(rng), U(rng)});
    }
  }
  // Occlusion map: camera z of the first ellipsoid hit through each pixel centre.
  s.depth.assign(size_t(size) * size, std::numeric_limits<float>::infinity());
  const Vec3f o = -(transpose(s.cam.R) * s.cam.t);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const Vec3f dir((x + 0.5f - s.cam.cx) / s.cam.fx, (y + 0.5f - s.cam.cy) / s.cam.fy, 1.0f);  // camera z = t
      float best = std::numeric_limits<float>::infinity();
      for (const auto& e : kBody) {
        const Vec3f oc(((o - e.c).x) / e.r.x, ((o - e.c).y) / e.r.y, ((o - e.c).z) / e.r.z);
        const Vec3f dd(dir.x / e.r.x, dir.y / e.r.y, dir.z / e.r.z);
        const float a = dot(dd, dd), b = dot(oc, dd), c = dot(oc, oc) - 1;
        const float disc = b * b - a * c;
        if (disc < 0) continue;
        const float t = (-b - std::sqrt(disc)) / a;
        if (t > 0) best = std::min(best, t);
      }
      s.depth[size_t(y) * size + x] = best;
    }
  return s;
}

const AvatarScene& scene() {
  static const AvatarScene s = make_scene(20000, 512);
  return s;
}

GaussianInputs<float> inputs(const AvatarScene& s) {
  GaussianInputs<float> in;
  in.count = int(s.opacities.size());
  in.means = s.means.data();
  in.quats = s.quats.data();
  in.scales = s.scales.data();
  in.opacities = s.opacities.data();
  in.colors = s.colors.data();
  return in;
}

void BM_GaussianForward(benchmark::State& state) {
  const auto& s = scene();
  set_num_threads(int(state.range(0)));
  const bool occlusion = state.range(1) != 0;
  const size_t P = size_t(s.cam.width) * s.cam.height;
  std::vector<float> color(3 * P), alpha(P), depth(P);
  GaussianRasterSettings<float> settings;
  settings.depth_map = occlusion ? s.depth.data() : nullptr;
  GaussianRasterState<float> st;
  for (auto _ : state) {
    rasterize_gaussians(inputs(s), s.cam, settings, st, {color.data(), alpha.data(), depth.data(), nullptr});
    benchmark::DoNotOptimize(color.data());
  }
  int visible = 0;
  for (int r : st.radii) visible += r > 0;
  state.counters["visible"] = visible;
  state.counters["pairs"] = double(st.pairs());
}

void BM_GaussianForwardBackward(benchmark::State& state) {
  const auto& s = scene();
  set_num_threads(int(state.range(0)));
  const bool occlusion = state.range(1) != 0;
  const int n = int(s.opacities.size());
  const size_t P = size_t(s.cam.width) * s.cam.height;
  std::vector<float> color(3 * P), alpha(P), depth(P), d_color(3 * P, 0.01f), d_alpha(P, -0.02f);
  std::vector<float> dm(3 * n), dq(4 * n), ds(3 * n), dop(n), dc(3 * n), dm2(2 * n);
  GaussianRasterSettings<float> settings;
  settings.depth_map = occlusion ? s.depth.data() : nullptr;
  GaussianRasterState<float> st;
  GaussianGrads<float> g;
  g.means = dm.data();
  g.quats = dq.data();
  g.scales = ds.data();
  g.opacities = dop.data();
  g.colors = dc.data();
  g.means2d = dm2.data();
  for (auto _ : state) {
    rasterize_gaussians(inputs(s), s.cam, settings, st, {color.data(), alpha.data(), depth.data(), nullptr});
    rasterize_gaussians_backward(inputs(s), s.cam, settings, st, {d_color.data(), d_alpha.data(), nullptr, nullptr},
                                 g);
    benchmark::DoNotOptimize(dm.data());
  }
  state.counters["pairs"] = double(st.pairs());
}

}  // namespace

// Args: threads, occlusion map on/off.
BENCHMARK(BM_GaussianForward)->Args({2, 1})->Args({1, 1})->Args({2, 0})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_GaussianForwardBackward)
    ->Args({2, 1})
    ->Args({1, 1})
    ->Args({2, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
