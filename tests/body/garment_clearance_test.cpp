// How far the body pokes through its garment (body/garment_clearance.h), on the procedural
// body with a skirt to 80% of the thigh: nothing is through at rest; a vertex moved a known
// distance out of a face reads that depth; the more the hem follows the legs, the less a
// stride or a kick gets through (held by the pelvis alone, by the default gradient, by the
// legs alone); a body without a garment has nothing to check.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "body/garment.h"
#include "body/garment_clearance.h"
#include "body/lbs.h"
#include "body/procedural_body.h"
#include "support/skirt_shape.h"

namespace haha {
namespace {

struct Dressed {
  BodyModel body;
  std::vector<float> rest;
};

// The procedural body with a skirt from the waist to 80% of the way to the knees, the legs'
// share of its hem `legs` (or held by the pelvis alone).
Dressed dressed(double legs = GarmentShape{}.legs, bool rigid_to_pelvis = false) {
  const BodyModel b = make_procedural_body();
  std::vector<float> verts(3 * size_t(b.num_verts)), joints(3 * size_t(kNumJoints));
  Lbs<float>(b).forward(SmplxParams{}, verts.data(), joints.data(), nullptr);
  GarmentShape s = test::skirt_shape(joints);
  s.legs = legs;
  Garment g = build_garment(b, verts, joints, s);
  if (rigid_to_pelvis) {
    std::fill(g.weights.begin(), g.weights.end(), 0.0f);
    for (int v = 0; v < g.num_verts(); ++v) g.weights[size_t(v) * kNumJoints] = 1.0f;
  }
  Dressed d{append_garment(b, g), {}};
  d.rest.resize(3 * size_t(d.body.num_verts));
  Lbs<float>(d.body).forward(SmplxParams{}, d.rest.data(), nullptr, nullptr);
  return d;
}

std::vector<float> posed(const Dressed& d, double left_hip_flexion) {
  SmplxParams p;
  p.pose[3 * 1] = float(-left_hip_flexion);  // the left thigh forward
  std::vector<float> v(3 * size_t(d.body.num_verts));
  Lbs<float>(d.body).forward(p, v.data(), nullptr, nullptr);
  return v;
}

TEST(GarmentClearance, NothingIsThroughAtRest) {
  const Dressed d = dressed();
  const std::vector<int> covered = garment_covered_vertices(d.body, d.rest.data());
  ASSERT_GT(covered.size(), 300u) << "the skirt covers the hips and thighs";
  for (int v : covered) ASSERT_LT(v, d.body.num_body_verts()) << "only the body's own vertices are checked";
  const GarmentClearance c = garment_clearance(d.body, covered, d.rest.data());
  EXPECT_EQ(c.covered, int(covered.size()));
  EXPECT_EQ(c.outside, 0);
  EXPECT_EQ(c.max_depth, 0.0);
}

TEST(GarmentClearance, AVertexMovedOutOfAFaceReadsItsDepth) {
  const Dressed d = dressed();
  const std::vector<int> covered = garment_covered_vertices(d.body, d.rest.data());
  ASSERT_FALSE(covered.empty());
  // A face in the middle of the skirt (ring 6, column 12): its centre plus 4 cm along its
  // outward normal. The nearest garment point of that position is the centre itself.
  const int f = d.body.garment_first_face + 2 * (6 * 48 + 12);
  const int32_t* t = &d.body.faces[3 * size_t(f)];
  Vec3<double> P[3];
  for (int k = 0; k < 3; ++k) P[k] = Vec3<double>(d.rest[3 * t[k]], d.rest[3 * t[k] + 1], d.rest[3 * t[k] + 2]);
  const Vec3<double> centre = (P[0] + P[1] + P[2]) * (1.0 / 3), n = cross(P[1] - P[0], P[2] - P[0]);
  const Vec3<double> out = centre + n * (0.04 / norm(n));
  std::vector<float> v = d.rest;
  for (int c = 0; c < 3; ++c) v[3 * size_t(covered[0]) + size_t(c)] = float(out[c]);
  const GarmentClearance c = garment_clearance(d.body, covered, v.data());
  EXPECT_EQ(c.outside, 1);
  EXPECT_NEAR(c.max_depth, 0.04, 1e-5);
  EXPECT_NEAR(c.mean_depth, 0.04, 1e-5);
}

TEST(GarmentClearance, TheMoreTheHemFollowsTheLegsTheLessGetsThrough) {
  const Dressed rigid = dressed(0.0, true), gradient = dressed(), legs = dressed(1.0);
  const std::vector<int> covered = garment_covered_vertices(gradient.body, gradient.rest.data());
  EXPECT_EQ(garment_covered_vertices(rigid.body, rigid.rest.data()), covered) << "the same rest surface covers the same";
  EXPECT_EQ(garment_covered_vertices(legs.body, legs.rest.data()), covered);
  for (double flexion : {0.45, 1.4}) {  // a walk's stride, a high kick
    const GarmentClearance r = garment_clearance(rigid.body, covered, posed(rigid, flexion).data());
    const GarmentClearance g = garment_clearance(gradient.body, covered, posed(gradient, flexion).data());
    const GarmentClearance l = garment_clearance(legs.body, covered, posed(legs, flexion).data());
    EXPECT_GT(r.max_depth, 0.03) << flexion << ": a thigh leaves a skirt that does not move";
    EXPECT_GT(r.outside, 20) << flexion;
    EXPECT_LT(g.max_depth, r.max_depth) << flexion;
    EXPECT_LT(g.outside, r.outside) << flexion;
    EXPECT_LE(l.max_depth, g.max_depth) << flexion;
    std::printf("hip flexion %.2f rad: through %.1f / %.1f / %.1f mm, %.1f%% / %.1f%% / %.1f%% (pelvis / default / legs)\n",
                flexion, 1000 * r.max_depth, 1000 * g.max_depth, 1000 * l.max_depth, 100 * r.share(), 100 * g.share(),
                100 * l.share());
  }
}

TEST(GarmentClearance, ABodyWithoutAGarmentHasNothingToCheck) {
  const BodyModel b = make_procedural_body();
  std::vector<float> v(3 * size_t(b.num_verts));
  Lbs<float>(b).forward(SmplxParams{}, v.data(), nullptr, nullptr);
  EXPECT_TRUE(garment_covered_vertices(b, v.data()).empty());
  const GarmentClearance c = garment_clearance(b, {}, v.data());
  EXPECT_EQ(c.covered, 0);
  EXPECT_EQ(c.share(), 0.0);
}

}  // namespace
}  // namespace haha
