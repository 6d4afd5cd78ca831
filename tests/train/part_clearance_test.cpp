// The clothed surface's part clearance (train/part_clearance.h): the parts follow the skinning;
// with the arms lowered against the sides the torso's flanks and the arms' inner sides are
// held, each displaced vertex stays on its side of the bisector with every vertex of another
// part (checked by brute force), a body with its arms raised away holds far less of the trunk, and the
// bounds stay within [0, cap].
#include <gtest/gtest.h>

#include <cmath>

#include "body/garment.h"
#include "body/lbs.h"
#include "support/train_test_scene.h"
#include "train/part_clearance.h"
#include "train/surface_fit.h"

namespace haha {
namespace {

using test::scene_body;

struct PosedFrame {
  std::vector<float> verts, dirs;
};

// The scene body with its shoulders rotated about the forward axis by `lower` radians
// (positive: the arms come down to the sides).
PosedFrame pose_arms(const BodyModel& b, float lower) {
  SmplxParams p;
  p.betas.assign(4, 0.0f);
  p.pose[3 * 16 + 2] = -lower;  // left shoulder (+X side)
  p.pose[3 * 17 + 2] = lower;
  Lbs<float> lbs(b);
  LbsCache<float> cache;
  PosedFrame f;
  f.verts.resize(3 * size_t(b.num_verts));
  f.dirs.resize(f.verts.size());
  lbs.forward(p, f.verts.data(), nullptr, &cache);
  const std::vector<float> n = vertex_normals(b.v_template.data(), b.num_verts, b.faces.data(), b.num_faces);
  posed_normal_directions(b, cache.skinning, n.data(), f.dirs.data());
  return f;
}

TEST(PartClearance, PartsFollowTheSkinning) {
  const BodyModel& b = scene_body();
  const std::vector<BodyPart> part = body_part_of_vertices(b);
  ASSERT_EQ(int(part.size()), b.num_body_verts());
  int count[6] = {};
  for (int v = 0; v < b.num_verts; ++v) {
    const float* w = &b.weights[size_t(v) * kNumJoints];
    ++count[int(part[size_t(v)])];
    if (w[18] > 0.9f) {   // left elbow
      EXPECT_EQ(part[size_t(v)], BodyPart::LeftArm) << v;
    }
    if (w[kRightHandFirst + 4] > 0.9f) {
      EXPECT_EQ(part[size_t(v)], BodyPart::RightArm) << v;
    }
    if (w[4] > 0.9f) {    // left knee
      EXPECT_EQ(part[size_t(v)], BodyPart::LeftLeg) << v;
    }
    if (w[11] > 0.9f) {  // right foot
      EXPECT_EQ(part[size_t(v)], BodyPart::RightLeg) << v;
    }
    if (w[6] > 0.9f || w[15] > 0.9f) {  // spine, head
      EXPECT_EQ(part[size_t(v)], BodyPart::Trunk) << v;
    }
  }
  for (int k = 0; k < 5; ++k) EXPECT_GT(count[k], 50) << "part " << k;
  EXPECT_EQ(count[int(BodyPart::Garment)], 0) << "no garment on this body";
  EXPECT_EQ(count[1], count[2]) << "the procedural body is symmetric";
}

TEST(PartClearance, ArmsAtTheSidesHoldTheFlanksAndNothingCrossesTheBisector) {
  const BodyModel& b = scene_body();
  const float cap = 0.08f;
  const PosedFrame f = pose_arms(b, 1.25f);
  const std::vector<float> h = part_clearance_bounds(b, {f.verts}, {f.dirs}, cap);
  const std::vector<BodyPart> part = body_part_of_vertices(b);
  ASSERT_EQ(int(h.size()), b.num_verts);
  int trunk_held = 0, arm_held = 0, free = 0;
  for (int v = 0; v < b.num_verts; ++v) {
    EXPECT_GE(h[size_t(v)], 0.0f);
    EXPECT_LE(h[size_t(v)], cap);
    if (h[size_t(v)] < 0.5f * cap) {
      if (part[size_t(v)] == BodyPart::Trunk) ++trunk_held;
      if (part[size_t(v)] == BodyPart::LeftArm || part[size_t(v)] == BodyPart::RightArm) ++arm_held;
    }
    if (h[size_t(v)] == cap) ++free;
  }
  EXPECT_GT(trunk_held, 0) << "the torso's flanks beside the lowered arms";
  EXPECT_GT(arm_held, 0) << "the arms' inner sides";
  // The trunk vertex nearest to a left-elbow vertex faces the arm across the gap: held.
  int elbow = -1, flank = -1;
  double best = 1e9;
  for (int v = 0; v < b.num_verts; ++v)
    if (b.weights[size_t(v) * kNumJoints + 18] > 0.9f) elbow = v;
  ASSERT_GE(elbow, 0);
  for (int v = 0; v < b.num_verts; ++v) {
    if (part[size_t(v)] != BodyPart::Trunk) continue;
    double d = 0;
    for (int k = 0; k < 3; ++k) d += std::pow(f.verts[3 * size_t(v) + k] - f.verts[3 * size_t(elbow) + k], 2);
    if (d < best) best = d, flank = v;
  }
  EXPECT_LT(h[size_t(flank)], cap) << "the flank beside the elbow, " << std::sqrt(best) << " m from it";
  EXPECT_GT(free, b.num_verts / 3) << "the front, back and far sides are not held";
  // Brute force: v moved by h u is no nearer to any vertex w of another part than to v itself.
  double worst = 0;
  for (int v = 0; v < b.num_verts; v += 7) {
    const float* p = &f.verts[3 * size_t(v)];
    const float* u = &f.dirs[3 * size_t(v)];
    const double q[3] = {p[0] + h[size_t(v)] * u[0], p[1] + h[size_t(v)] * u[1], p[2] + h[size_t(v)] * u[2]};
    const double moved = h[size_t(v)] * std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int w = 0; w < b.num_verts; ++w) {
      if (!parts_kept_apart(part[size_t(w)], part[size_t(v)])) continue;
      const float* r = &f.verts[3 * size_t(w)];
      const double to_w = std::sqrt(std::pow(q[0] - r[0], 2) + std::pow(q[1] - r[1], 2) + std::pow(q[2] - r[2], 2));
      worst = std::max(worst, moved - to_w);
    }
  }
  EXPECT_LT(worst, 1e-5) << "m: a displaced vertex crossed the bisector with another part";
}

TEST(PartClearance, ArmsRaisedAwayHoldFewerAndFramesFoldByTheMinimum) {
  const BodyModel& b = scene_body();
  const float cap = 0.08f;
  const PosedFrame up = pose_arms(b, -0.6f), down = pose_arms(b, 1.25f);
  const std::vector<float> h_up = part_clearance_bounds(b, {up.verts}, {up.dirs}, cap);
  const std::vector<float> h_down = part_clearance_bounds(b, {down.verts}, {down.dirs}, cap);
  const std::vector<float> h_both = part_clearance_bounds(b, {up.verts, down.verts}, {up.dirs, down.dirs}, cap);
  const std::vector<BodyPart> part = body_part_of_vertices(b);
  int trunk_held_up = 0, trunk_held_down = 0;
  for (int v = 0; v < b.num_verts; ++v) {
    EXPECT_EQ(h_both[size_t(v)], std::min(h_up[size_t(v)], h_down[size_t(v)])) << v;
    if (part[size_t(v)] != BodyPart::Trunk) continue;
    trunk_held_up += h_up[size_t(v)] < 0.5f * cap;
    trunk_held_down += h_down[size_t(v)] < 0.5f * cap;
  }
  EXPECT_LT(trunk_held_up, trunk_held_down) << "raised arms free the flanks (the armpits' seams stay held)";
}

TEST(PartClearance, AGarmentHoldsNothingAndIsNotHeld) {
  EXPECT_FALSE(parts_kept_apart(BodyPart::Garment, BodyPart::LeftArm));
  EXPECT_FALSE(parts_kept_apart(BodyPart::RightArm, BodyPart::Garment));
  EXPECT_FALSE(parts_kept_apart(BodyPart::Garment, BodyPart::Trunk));
  EXPECT_FALSE(parts_kept_apart(BodyPart::LeftArm, BodyPart::LeftArm));
  EXPECT_TRUE(parts_kept_apart(BodyPart::LeftLeg, BodyPart::RightLeg));
  EXPECT_TRUE(parts_kept_apart(BodyPart::Trunk, BodyPart::RightArm));
  // A skirt on the body, the arms lowered beside it: the bounds cover the body's vertices
  // only, and the body's are what they are without the skirt.
  const BodyModel& bare = scene_body();
  std::vector<float> rest(3 * size_t(bare.num_verts)), joints(3 * size_t(kNumJoints));
  Lbs<float>(bare).forward(SmplxParams{}, rest.data(), joints.data(), nullptr);
  GarmentShape shape;
  shape.y_top = 0.5 * (joints[1] + joints[10]);
  shape.y_hem = joints[3 * 4 + 1];  // to the knees
  shape.rings = 6;
  shape.columns = 24;
  const BodyModel b = append_garment(bare, build_garment(bare, rest, joints, shape));
  const std::vector<BodyPart> part = body_part_of_vertices(b);
  for (int v = b.num_body_verts(); v < b.num_verts; ++v) ASSERT_EQ(part[size_t(v)], BodyPart::Garment);
  const PosedFrame with = pose_arms(b, 1.25f), without = pose_arms(bare, 1.25f);
  const std::vector<float> h = part_clearance_bounds(b, {with.verts}, {with.dirs}, 0.08f);
  const std::vector<float> h_bare = part_clearance_bounds(bare, {without.verts}, {without.dirs}, 0.08f);
  ASSERT_EQ(int(h.size()), b.num_body_verts());
  EXPECT_EQ(h, h_bare);
}

TEST(PartClearance, NoFramesNoBound) {
  const BodyModel& b = scene_body();
  const std::vector<float> h = part_clearance_bounds(b, {}, {}, 0.05f);
  ASSERT_EQ(int(h.size()), b.num_verts);
  for (float x : h) EXPECT_EQ(x, 0.05f);
}

}  // namespace
}  // namespace haha
