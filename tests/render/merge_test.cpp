// Merge I = C_front + (1 - A) (m M + (1 - m) B): values in the mesh-only, Gaussians-only
// and mixed cases, finite-difference gradients in double w.r.t. every input, and the
// defects of the public release that must not be copied.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "core/parallel.h"
#include "render/merge.h"

using namespace haha;

namespace {

struct MergeData {
  int P;
  std::vector<double> C, A, M, m, B;
  double bg[3] = {0.2, 0.4, 0.6};
  MergeInputsT<double> inputs(bool per_pixel_bg) const {
    MergeInputsT<double> in;
    in.num_pixels = P;
    in.color_front = C.data();
    in.alpha = A.data();
    in.mesh_color = M.data();
    in.mesh_mask = m.data();
    in.background = per_pixel_bg ? B.data() : nullptr;
    for (int c = 0; c < 3; ++c) in.background_color[c] = bg[c];
    return in;
  }
};

MergeData make_merge_data(int P, unsigned seed, bool soft_mask) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  MergeData d{P, {}, {}, {}, {}, {}};
  for (int i = 0; i < 3 * P; ++i) {
    d.M.push_back(U(rng));
    d.B.push_back(U(rng));
  }
  for (int p = 0; p < P; ++p) {
    const double a = U(rng);
    d.A.push_back(a);
    for (int c = 0; c < 3; ++c) d.C.push_back(a * U(rng));  // premultiplied: C <= A
    d.m.push_back(soft_mask ? U(rng) : double(U(rng) < 0.5));
  }
  return d;
}

}  // namespace

TEST(Merge, MeshOnlyGaussiansOnlyAndMixed) {
  const int P = 4;
  const float M[12] = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1.0f, 0.0f, 0.5f};
  const float mask[4] = {1, 0, 1, 0};
  float out[12];
  // Mesh only (no Gaussians: A = 0): I = M inside the silhouette, background outside.
  MergeInputs in;
  in.num_pixels = P;
  in.mesh_color = M;
  in.mesh_mask = mask;
  in.background_color[0] = 0.25f;
  in.background_color[1] = 0.5f;
  in.background_color[2] = 0.75f;
  merge(in, out);
  for (int p = 0; p < P; ++p)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(out[3 * p + c], mask[p] ? M[3 * p + c] : in.background_color[c]);
  // Gaussians only (no mesh): I = C + (1 - A) bg.
  const float C[12] = {0.1f, 0.1f, 0.1f, 0.5f, 0.0f, 0.2f, 0, 0, 0, 0.9f, 0.9f, 0.9f};
  const float A[4] = {0.2f, 0.5f, 0.0f, 1.0f};
  MergeInputs g;
  g.num_pixels = P;
  g.color_front = C;
  g.alpha = A;
  g.background_color[1] = 1.0f;
  merge(g, out);
  for (int p = 0; p < P; ++p)
    for (int c = 0; c < 3; ++c)
      EXPECT_FLOAT_EQ(out[3 * p + c], C[3 * p + c] + (1 - A[p]) * g.background_color[c]);
  // Both: opaque Gaussians (A = 1) hide the mesh completely; the mesh colour enters once.
  in.color_front = C;
  in.alpha = A;
  merge(in, out);
  for (int p = 0; p < P; ++p)
    for (int c = 0; c < 3; ++c) {
      const float under = mask[p] ? M[3 * p + c] : in.background_color[c];
      EXPECT_FLOAT_EQ(out[3 * p + c], C[3 * p + c] + (1 - A[p]) * under);
    }
  EXPECT_EQ(out[9], C[9]);  // pixel 3 has A = 1
  // Nothing at all: the background.
  MergeInputs none;
  none.num_pixels = P;
  none.background_color[2] = 0.5f;
  merge(none, out);
  for (int p = 0; p < P; ++p) EXPECT_EQ(out[3 * p + 2], 0.5f);
}

TEST(Merge, MeshColourOutsideTheMaskIsIgnoredEvenIfNotFinite) {
  const float M[6] = {NAN, INFINITY, NAN, 0.5f, 0.5f, 0.5f};
  const float mask[2] = {0, 1};
  MergeInputs in;
  in.num_pixels = 2;
  in.mesh_color = M;
  in.mesh_mask = mask;
  float out[6];
  merge(in, out);
  for (float v : out) EXPECT_TRUE(std::isfinite(v));
  EXPECT_EQ(out[0], 0.0f);
  EXPECT_EQ(out[3], 0.5f);
}

TEST(Merge, GradientsMatchFiniteDifferences) {
  for (bool per_pixel_bg : {false, true}) {
    MergeData d = make_merge_data(40, per_pixel_bg ? 1 : 2, /*soft_mask=*/true);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(-1, 1);
    std::vector<double> g(3 * size_t(d.P));
    for (double& v : g) v = U(rng);
    auto loss = [&](const MergeData& dd) {
      std::vector<double> out(3 * size_t(dd.P));
      merge(dd.inputs(per_pixel_bg), out.data());
      double L = 0;
      for (size_t i = 0; i < out.size(); ++i) L += g[i] * out[i];
      return L;
    };
    std::vector<double> gC(d.C.size()), gA(d.A.size()), gM(d.M.size()), gm(d.m.size()), gB(d.B.size(), 5.0);
    double gbg[3] = {0, 0, 0};
    MergeGradsT<double> grads{gC.data(), gA.data(), gM.data(), gm.data(), gB.data(), gbg};
    merge_backward(d.inputs(per_pixel_bg), g.data(), grads);
    const double h = 1e-6, tol = 1e-8;  // |fd - analytic| <= tol (|analytic| + 1)
    auto check = [&](std::vector<double> MergeData::*field, const std::vector<double>& an, const char* name) {
      for (size_t i = 0; i < an.size(); ++i) {
        MergeData p = d, m = d;
        (p.*field)[i] += h;
        (m.*field)[i] -= h;
        const double fd = (loss(p) - loss(m)) / (2 * h);
        ASSERT_NEAR(fd, an[i], tol * (std::fabs(an[i]) + 1)) << name << " " << i;
      }
    };
    check(&MergeData::C, gC, "C_front");
    check(&MergeData::A, gA, "A");
    check(&MergeData::M, gM, "M");
    check(&MergeData::m, gm, "mask");
    check(&MergeData::B, gB, "background image");  // all zero when the colour is used
    for (int c = 0; c < 3; ++c) {
      MergeData p = d, m = d;
      p.bg[c] += h;
      m.bg[c] -= h;
      EXPECT_NEAR((loss(p) - loss(m)) / (2 * h), gbg[c], tol * (std::fabs(gbg[c]) + 1)) << "bg colour " << c;
    }
    if (per_pixel_bg) {
      EXPECT_EQ(gbg[0], 0.0);
      // The release's defect read the first pixel's background for every pixel: here each
      // pixel's background gradient is its own (1 - A)(1 - m) g.
      for (int p = 1; p < d.P; ++p)
        EXPECT_NEAR(gB[3 * p], (1 - d.A[p]) * (1 - d.m[p]) * g[3 * p], 1e-15);
    }
  }
}

TEST(Merge, BackgroundColourGradientAccumulatesAndIsThreadIndependent) {
  const MergeData d = make_merge_data(20000, 4, false);
  std::vector<double> g(3 * size_t(d.P), 1.0);
  double g1[3] = {1, 1, 1}, g2[3] = {1, 1, 1};
  MergeGradsT<double> a, b;
  a.background_color = g1;
  b.background_color = g2;
  const int saved = num_threads();
  set_num_threads(1);
  merge_backward(d.inputs(false), g.data(), a);
  set_num_threads(2);
  merge_backward(d.inputs(false), g.data(), b);
  set_num_threads(saved);
  double expect = 1;
  for (int p = 0; p < d.P; ++p) expect += (1 - d.A[p]) * (1 - d.m[p]);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(g1[c], expect, 1e-9 * expect);
    EXPECT_NEAR(g2[c], expect, 1e-9 * expect);
  }
}

TEST(Merge, MaskWithoutMeshColourThrows) {
  const float mask[1] = {1};
  MergeInputs in;
  in.num_pixels = 1;
  in.mesh_mask = mask;
  float out[3];
  EXPECT_THROW(merge(in, out), Error);
  EXPECT_THROW(merge_backward(in, out, MergeGrads{}), Error);
}
