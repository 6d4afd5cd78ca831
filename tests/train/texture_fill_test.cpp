// The texture where the video barely looked: per-texel evidence, the evidence-weighted
// smoothness prior (finite differences in double), the fill across seams and into the
// gutter, and the trainer's use of them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "render/mesh_raster.h"
#include "render/texture_charts.h"
#include "support/expect_error.h"
#include "support/low_body.h"
#include "support/train_test_scene.h"
#include "train/texture_evidence.h"
#include "train/texture_fill.h"
#include "train/texture_smooth.h"
#include "train/trainer.h"

using namespace haha;

namespace {

Vec3<double> face_centroid(const BodyModel& b, int f) {
  Vec3<double> c{0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    const int32_t v = b.faces[size_t(f) * 3 + k];
    c += Vec3<double>(b.v_template[3 * size_t(v)], b.v_template[3 * size_t(v) + 1], b.v_template[3 * size_t(v) + 2]);
  }
  return c * (1.0 / 3.0);
}

// A colour field smooth over the body's surface (a function of the 3D position): what a
// texture looks like where charts meet across a seam.
void surface_colour(const BodyModel& b, int f, float* rgb) {
  const Vec3<double> p = face_centroid(b, f);
  rgb[0] = float(0.5 + 0.3 * std::sin(3 * p.y));
  rgb[1] = float(0.5 + 0.3 * std::cos(4 * p.x));
  rgb[2] = float(0.5 + 0.2 * std::sin(5 * p.z + p.y));
}

}  // namespace

TEST(TextureEvidence, SumsCosineWeightedCoverageOfAFrontalQuad) {
  Camera cam;
  cam.width = cam.height = 32;
  cam.fx = cam.fy = 40;
  cam.cx = cam.cy = 16;
  const std::vector<float> verts = {-0.5f, -0.5f, 2, 0.5f, -0.5f, 2, 0.5f, 0.5f, 2, -0.5f, 0.5f, 2};
  const std::vector<int32_t> faces = {0, 1, 2, 0, 2, 3};
  const std::vector<float> vt = {0, 0, 1, 0, 1, 1, 0, 1};  // the quad fills the texture
  MeshRaster r;
  rasterize_mesh(cam, MeshView{verts.data(), 4, faces.data(), 2}, r);
  const int P = 32 * 32;
  std::vector<float> uv(2 * P), mask(P, 1.0f);
  interpolate(P, r.tri.data(), r.bary.data(), faces.data(), vt.data(), 2, uv.data());
  double expect = 0;
  int covered = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      if (r.tri[size_t(y) * 32 + x] >= 0) {
        const double rx = (x + 0.5 - 16) / 40.0, ry = (y + 0.5 - 16) / 40.0;
        expect += 1.0 / std::sqrt(rx * rx + ry * ry + 1);  // |cos| of a +z normal and the ray
        ++covered;
      }
  ASSERT_GT(covered, 300);
  std::vector<float> e(16 * 16, 0.0f);
  accumulate_texture_evidence(cam, verts.data(), faces.data(), r.tri.data(), uv.data(), mask.data(), 16, 16, e.data());
  double sum = 0;
  for (float v : e) {
    EXPECT_GE(v, 0.0f);
    sum += v;
  }
  EXPECT_NEAR(sum, expect, 1e-3 * expect);
  // Accumulates, and the mask weights: a half mask adds half again.
  for (float& m : mask) m = 0.5f;
  accumulate_texture_evidence(cam, verts.data(), faces.data(), r.tri.data(), uv.data(), mask.data(), 16, 16, e.data());
  double sum2 = 0;
  for (float v : e) sum2 += v;
  EXPECT_NEAR(sum2, 1.5 * expect, 1e-3 * expect);
  // 16 x 16 texels under ~27 x 27 pixels: every texel was seen.
  for (float v : e) EXPECT_GT(v, 0.5f);
}

TEST(TextureSmooth, GradientMatchesFiniteDifferences) {
  const int H = 7, W = 9, C = 3;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.05, 0.95);
  std::vector<double> t(size_t(H) * W * C);
  for (double& x : t) x = u(rng);
  std::vector<float> a(size_t(H) * W);
  for (size_t i = 0; i < a.size(); ++i) a[i] = (i % 5 == 0) ? 0.0f : float(u(rng));  // gutter texels: 0
  std::vector<double> g(t.size(), 0.0);
  const double grad_scale = 0.7;
  const double e0 = texture_smooth_loss<double>(t.data(), a.data(), H, W, C, g.data(), grad_scale);
  EXPECT_GT(e0, 0.0);
  double scale = 0;
  for (double v : g) scale = std::max(scale, std::abs(v));
  ASSERT_GT(scale, 0.0);
  const double h = 1e-6;
  for (size_t i = 0; i < t.size(); ++i) {
    const double keep = t[i];
    t[i] = keep + h;
    const double fp = texture_smooth_loss<double>(t.data(), a.data(), H, W, C);
    t[i] = keep - h;
    const double fm = texture_smooth_loss<double>(t.data(), a.data(), H, W, C);
    t[i] = keep;
    EXPECT_NEAR(g[i], grad_scale * (fp - fm) / (2 * h), 1e-5 * scale) << "coordinate " << i;
  }
  // A texel of weight 0 (gutter) with weight-0 pairs only has no gradient; a constant
  // texture has no energy.
  for (int c = 0; c < C; ++c) EXPECT_EQ(g[size_t(0) * C + c], 0.0);
  std::vector<double> flat(t.size(), 0.3);
  EXPECT_EQ(texture_smooth_loss<double>(flat.data(), a.data(), H, W, C), 0.0);
}

TEST(TextureSmooth, WeightsFallWithEvidenceAndVanishInTheGutter) {
  const BodyModel& b = test::low_body();
  const TextureCharts c = texture_charts(b, 32, 32);
  std::vector<float> e(32 * 32);
  for (size_t i = 0; i < e.size(); ++i) e[i] = float(i % 7);
  const std::vector<float> a = smooth_weights(e, c, 2.0);
  for (size_t i = 0; i < e.size(); ++i) {
    if (c.face[i] < 0) {
      EXPECT_EQ(a[i], 0.0f);
      continue;
    }
    EXPECT_NEAR(a[i], 1.0 / (1.0 + e[i] / 2.0), 1e-6);
  }
  test::expect_error([&] { smooth_weights(e, c, 0.0); }, {"smooth_weights"});
}

TEST(TextureFill, SeamLinksJoinTexelsThatAreNeighboursOnTheSurface) {
  const BodyModel& b = test::low_body();
  const int S = 96;
  const TextureCharts c = texture_charts(b, S, S);
  const TexelGraph g = texel_graph(b, c);
  EXPECT_GT(g.seam_links, 0);
  // Links between texels that are not grid neighbours are only made at seams: their faces
  // are close on the body, however far apart the charts lie in the atlas.
  int64_t across = 0;
  double worst = 0;
  for (size_t i = 0; i < c.face.size(); ++i)
    for (int64_t k = g.offset[i]; k < g.offset[i + 1]; ++k) {
      const int64_t j = g.neighbor[size_t(k)];
      const int32_t fi = c.face[i], fj = c.face[size_t(j)];
      ASSERT_GE(fi, 0);
      ASSERT_GE(fj, 0);
      const int64_t dx = std::abs(int64_t(i) % S - j % S), dy = std::abs(int64_t(i) / S - j / S);
      if (dx + dy == 1) continue;  // a grid link
      ++across;
      worst = std::max(worst, norm(face_centroid(b, fi) - face_centroid(b, fj)));
    }
  EXPECT_GT(across, 0);
  std::printf("seam links %lld, worst 3D distance %.4f m\n", (long long)across, worst);
  EXPECT_LT(worst, 0.12);  // metres: a few faces of the low body, not across the atlas
}

TEST(TextureFill, KeepsSeenTexelsReplacesNoiseAndFillsTheGutter) {
  const BodyModel& b = test::low_body();
  const int S = 96;
  const TextureCharts c = texture_charts(b, S, S);
  const size_t N = size_t(S) * S;
  std::vector<float> truth(3 * N, 0.0f), tex(3 * N, 0.0f), evidence(N, 0.0f);
  std::mt19937 rng(11);
  for (size_t t = 0; t < N; ++t) {
    const int32_t f = c.face[t];
    if (f < 0) continue;
    surface_colour(b, f, &truth[3 * t]);
    // A third of the faces barely seen (as under a chin, between fingers): noise there.
    const bool seen = (uint32_t(f) * 2654435761u) % 3 != 0;
    evidence[t] = seen ? 2.0f : 0.05f * float(rng() % 3);
    for (int ch = 0; ch < 3; ++ch) tex[3 * t + ch] = seen ? truth[3 * t + ch] : float(rng() % 2);
  }
  FillOptions opt;
  opt.evidence_full = 1.0;
  const FillReport r = fill_low_evidence(b, c, evidence, opt, tex);
  EXPECT_EQ(r.chart_texels, c.count());
  EXPECT_GT(r.low_texels, 0);
  EXPECT_GT(r.unseen_texels, 0);
  double err_low = 0;
  int64_t n_low = 0;
  for (size_t t = 0; t < N; ++t) {
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_GE(tex[3 * t + ch], 0.0f);  // the gutter filled from the charts' values
      EXPECT_LE(tex[3 * t + ch], 1.0f);
    }
    if (c.face[t] < 0) continue;
    if (evidence[t] >= 1.0f) {
      for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(tex[3 * t + ch], truth[3 * t + ch]);  // kept exactly
    } else {
      for (int ch = 0; ch < 3; ++ch) err_low += std::abs(tex[3 * t + ch] - truth[3 * t + ch]);
      n_low += 3;
    }
  }
  // The noise was about 0.5 off on average; the fill brings back the surface's colour.
  std::printf("mean error of the filled texels %.4f\n", err_low / double(n_low));
  EXPECT_LT(err_low / double(n_low), 0.08);  // measured 0.064 (a constant fill: ~0.19)
  test::expect_error([&] { fill_low_evidence(b, c, std::vector<float>(N - 1), opt, tex); }, {"texture_fill"});
}

TEST(TextureFill, AConstantChartColourFillsTheWholeGutter) {
  const BodyModel& b = test::low_body();
  const int S = 40;
  const TextureCharts c = texture_charts(b, S, S);
  std::vector<float> tex(3 * size_t(S) * S, 0.9f);
  for (size_t t = 0; t < c.face.size(); ++t)
    if (c.face[t] >= 0)
      for (int ch = 0; ch < 3; ++ch) tex[3 * t + ch] = 0.25f;
  dilate_into_gutter(c, {}, tex);
  for (float v : tex) EXPECT_FLOAT_EQ(v, 0.25f);
}

TEST(TrainerTexture, FillChangesOnlyTexelsBelowFullEvidence) {
  const Avatar truth = test::scene_truth();
  const std::vector<TrainFrame> frames = test::scene_frames(truth, 4);
  auto run = [&](bool fill) {
    TrainConfig c = test::scene_config(0, 6, 0);
    c.s2.smooth = 0;  // the same stage-2 training either way
    c.s2.fill = fill;
    Trainer t(c, test::scene_input(frames));
    while (!t.done()) t.step();
    return std::make_pair(t.avatar().texture.rgb, t.texture_evidence());
  };
  const auto [kept, evidence] = run(false);
  const auto [filled, evidence2] = run(true);
  ASSERT_EQ(evidence.size(), kept.size() / 3);
  EXPECT_EQ(evidence, evidence2);
  int64_t full = 0, changed = 0;
  for (size_t t = 0; t < evidence.size(); ++t) {
    const bool same = filled[3 * t] == kept[3 * t] && filled[3 * t + 1] == kept[3 * t + 1] &&
                      filled[3 * t + 2] == kept[3 * t + 2];
    if (evidence[t] >= 1.0f) {
      ++full;
      EXPECT_TRUE(same) << "texel " << t;
    } else {
      changed += !same;
    }
  }
  EXPECT_GT(full, 0);
  EXPECT_GT(changed, 0);
}
