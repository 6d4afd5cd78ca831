// A garment as a part of the body mesh (body/garment.h), on the procedural body: the loft
// encloses the torso and both legs at every ring, faces outward, hangs from the hips (at most
// four influences, no knee, both legs blended at the front and back centre, one leg at the
// sides, the legs' share growing from the waist to the hem), its chart stays on the right of the texture; appending it leaves the body's posing
// bit for bit as it was, and garment_of gives it back; bad arrays are named.
#include <gtest/gtest.h>

#include <cmath>

#include "body/garment.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "core/error.h"
#include "support/skirt_shape.h"

namespace haha {
namespace {

const BodyModel& body() {
  static const BodyModel b = make_procedural_body();
  return b;
}

struct Rest {
  std::vector<float> verts, joints;
};
Rest rest_of(const BodyModel& b) {
  Rest r;
  r.verts.resize(3 * size_t(b.num_verts));
  r.joints.resize(3 * size_t(kNumJoints));
  Lbs<float>(b).forward(SmplxParams{}, r.verts.data(), r.joints.data(), nullptr);
  return r;
}

GarmentShape skirt_shape(const Rest& r) { return test::skirt_shape(r.joints); }

double weight(const Garment& g, int v, int j) { return g.weights[size_t(v) * kNumJoints + size_t(j)]; }

TEST(Garment, LoftEnclosesTheLegsAndFacesOutward) {
  const Rest r = rest_of(body());
  const GarmentShape s = skirt_shape(r);
  const Garment g = build_garment(body(), r.verts, r.joints, s);
  ASSERT_EQ(g.num_verts(), s.rings * s.columns);
  ASSERT_EQ(g.num_faces(), 2 * (s.rings - 1) * s.columns);
  const double ax = r.joints[0], az = r.joints[2];
  // Every thigh vertex between two rings lies inside both rings' polygons (radius at its
  // azimuth, linearly between columns, is larger).
  int checked = 0;
  for (int v = 0; v < body().num_verts; ++v) {
    const float* w = &body().weights[size_t(v) * kNumJoints];
    if (w[1] + w[2] < 0.5f) continue;  // the hips' vertices: the thighs
    const double y = r.verts[3 * size_t(v) + 1];
    if (y > s.y_top || y < s.y_hem) continue;
    const int i = int(std::floor((s.y_top - y) / (s.y_top - s.y_hem) * (s.rings - 1)));
    const double x = r.verts[3 * size_t(v)] - ax, z = r.verts[3 * size_t(v) + 2] - az;
    const double rad = std::hypot(x, z);
    for (int ring : {i, std::min(i + 1, s.rings - 1)}) {
      // The ring's polygon contains the point: it is on the inner side of every edge.
      bool inside = true;
      for (int k = 0; k < s.columns; ++k) {
        const float* a = &g.verts[3 * size_t(ring * s.columns + k)];
        const float* b = &g.verts[3 * size_t(ring * s.columns + (k + 1) % s.columns)];
        const double ex = b[0] - a[0], ez = b[2] - a[2];
        const double cx = (a[0] - ax) * ez - (a[2] - az) * ex;  // the axis's side
        const double px = (a[0] - ax - x) * ez - (a[2] - az - z) * ex;  // the point's side
        inside &= (cx * px >= 0);
      }
      EXPECT_TRUE(inside) << "thigh vertex " << v << " at radius " << rad << " outside ring " << ring;
      ++checked;
    }
  }
  EXPECT_GT(checked, 50);
  // Faces point away from the axis.
  for (int f = 0; f < g.num_faces(); ++f) {
    const float* p[3];
    for (int c = 0; c < 3; ++c) p[c] = &g.verts[3 * size_t(g.faces[3 * size_t(f) + c])];
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double nx = e1[1] * e2[2] - e1[2] * e2[1], nz = e1[0] * e2[1] - e1[1] * e2[0];
    const double cx = (p[0][0] + p[1][0] + p[2][0]) / 3 - ax, cz = (p[0][2] + p[1][2] + p[2][2]) / 3 - az;
    EXPECT_GT(nx * cx + nz * cz, 0) << "face " << f;
  }
  // Radii never shrink down the garment.
  for (int i = 1; i < s.rings; ++i)
    for (int k = 0; k < s.columns; ++k) {
      const float* a = &g.verts[3 * size_t((i - 1) * s.columns + k)];
      const float* b = &g.verts[3 * size_t(i * s.columns + k)];
      EXPECT_GE(std::hypot(b[0] - ax, b[2] - az), std::hypot(a[0] - ax, a[2] - az) - 1e-6);
    }
}

TEST(Garment, HangsFromTheHipsWithAtMostFourInfluences) {
  const Rest r = rest_of(body());
  const GarmentShape s = skirt_shape(r);
  const Garment g = build_garment(body(), r.verts, r.joints, s);
  for (int v = 0; v < g.num_verts(); ++v) {
    int nonzero = 0;
    double sum = 0;
    for (int j = 0; j < kNumJoints; ++j) {
      nonzero += weight(g, v, j) > 0;
      sum += weight(g, v, j);
      if (j == 4 || j == 5 || j == 7 || j == 8 || j == 10 || j == 11) {
        EXPECT_EQ(weight(g, v, j), 0.0) << "knee/ankle/foot";
      }
    }
    EXPECT_LE(nonzero, 4);
    EXPECT_NEAR(sum, 1.0, 1e-5);
  }
  // At the hem: the side columns follow one leg, the front and back centres blend both.
  // Columns start at the back (k = 0) and run through the left side (+X, k = C/4)...
  const int hem = (s.rings - 1) * s.columns, C = s.columns;
  auto at = [&](int k, int j) { return weight(g, hem + k, j); };
  const int back = 0, left = C / 2 + C / 4, front = C / 2, right = C / 4;
  const double lx = g.verts[3 * size_t(hem + left)] - r.joints[0];
  const int lhip = lx > 0 ? 1 : 2, rhip = 3 - lhip;  // whichever leg that side is
  EXPECT_GT(at(left, lhip), 0.6);
  EXPECT_GT(at(right, rhip), 0.6);
  for (int k : {front, back}) {
    EXPECT_GT(at(k, 1), 0.2) << "column " << k;
    EXPECT_GT(at(k, 2), 0.2) << "column " << k;
    EXPECT_NEAR(at(k, 1), at(k, 2), 0.15) << "column " << k;
  }
  // The chart: on the right of the texture.
  for (size_t i = 0; i < g.vt.size(); i += 2) {
    EXPECT_GE(g.vt[i], 1.0f - s.chart);
    EXPECT_LE(g.vt[i], 1.0f);
  }
}

TEST(Garment, TheLegsShareGrowsFromTheWaistToTheHem) {
  const Rest r = rest_of(body());
  GarmentShape s = skirt_shape(r);
  const Garment g = build_garment(body(), r.verts, r.joints, s);
  const int C = s.columns;
  auto legs = [&](const Garment& x, int i, int k) { return weight(x, i * C + k, 1) + weight(x, i * C + k, 2); };
  for (int k = 0; k < C; ++k) {
    EXPECT_LT(legs(g, 0, k), 0.05) << "the waist hangs from the torso, column " << k;
    EXPECT_NEAR(legs(g, s.rings - 1, k), s.legs, 0.05) << "the hem, column " << k;
    for (int i = 1; i < s.rings; ++i) EXPECT_GE(legs(g, i, k), legs(g, i - 1, k) - 0.02) << "ring " << i << ", column " << k;
  }
  s.legs = 1.0;  // a hem on the legs alone
  const Garment all = build_garment(body(), r.verts, r.joints, s);
  for (int k = 0; k < C; ++k) EXPECT_NEAR(legs(all, s.rings - 1, k), 1.0, 1e-5) << "column " << k;
}

TEST(Garment, AppendingLeavesTheBodyAsItWas) {
  const BodyModel& b = body();
  const Rest r = rest_of(b);
  const Garment g = build_garment(b, r.verts, r.joints, skirt_shape(r));
  const BodyModel both = append_garment(b, g);
  ASSERT_TRUE(both.has_garment());
  EXPECT_EQ(both.num_body_verts(), b.num_verts);
  EXPECT_EQ(both.num_body_faces(), b.num_faces);
  EXPECT_EQ(both.num_verts, b.num_verts + g.num_verts());
  SmplxParams p;
  for (int i = 3; i < 66; ++i) p.pose[size_t(i)] = 0.3f * std::sin(1.7f * i);
  p.transl = {0.1f, -0.2f, 0.3f};
  std::vector<float> v0(3 * size_t(b.num_verts)), v1(3 * size_t(both.num_verts)), j0(165), j1(165);
  Lbs<float>(b).forward(p, v0.data(), j0.data(), nullptr);
  Lbs<float>(both).forward(p, v1.data(), j1.data(), nullptr);
  EXPECT_EQ(j0, j1);
  for (size_t i = 0; i < v0.size(); ++i) ASSERT_EQ(v0[i], v1[i]) << "body coordinate " << i;
  // At rest the garment sits where it was built.
  Lbs<float>(both).forward(SmplxParams{}, v1.data(), nullptr, nullptr);
  for (int v = 0; v < g.num_verts(); ++v)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(v1[3 * size_t(b.num_verts + v) + c], g.verts[3 * size_t(v) + c], 1e-6);
  // garment_of gives it back; the body's UVs moved into the left of the texture.
  const Garment back = garment_of(both);
  EXPECT_EQ(back.verts, g.verts);
  EXPECT_EQ(back.faces, g.faces);
  EXPECT_EQ(back.weights, g.weights);
  EXPECT_EQ(back.vt, g.vt);
  EXPECT_EQ(back.ft, g.ft);
  for (size_t i = 0; i < b.vt.size(); i += 2) EXPECT_LE(both.vt[i], 1.0f - g.chart);
  EXPECT_THROW(append_garment(both, g), Error);
}

TEST(Garment, BadArraysAreNamed) {
  const Rest r = rest_of(body());
  const Garment good = build_garment(body(), r.verts, r.joints, skirt_shape(r));
  auto message = [](const Garment& g) {
    try {
      validate_garment(g, "avatar.npz");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message(good), "");
  Garment g = good;
  g.faces[5] = g.num_verts();
  EXPECT_NE(message(g).find("avatar.npz: garment faces"), std::string::npos) << message(g);
  g = good;
  g.weights[3] = NAN;
  EXPECT_NE(message(g).find("weights"), std::string::npos);
  g = good;
  g.weights[0] += 0.5f;
  EXPECT_NE(message(g).find("sum to 1"), std::string::npos);
  g = good;
  g.ft.pop_back();
  EXPECT_NE(message(g).find("uv faces"), std::string::npos);
  g = good;
  g.vt[0] = 1.5f;
  EXPECT_NE(message(g).find("uv"), std::string::npos);
  GarmentShape bad = skirt_shape(r);
  std::swap(bad.y_top, bad.y_hem);
  EXPECT_THROW(build_garment(body(), r.verts, r.joints, bad), Error);
  bad = skirt_shape(r);
  bad.y_hem = -5;  // below the feet
  EXPECT_THROW(build_garment(body(), r.verts, r.joints, bad), Error);
}

}  // namespace
}  // namespace haha
