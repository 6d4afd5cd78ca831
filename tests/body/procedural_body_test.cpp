// Procedural SMPL-X-layout body: the real file's array shapes and kinematic tree, a valid
// closed outward surface per part, skinning weights / regressor / landmarks / hand PCA
// properties, a non-overlapping UV atlas (every triangle pair checked), meaningful shape
// and expression directions, local pose correctives, smooth skinning under LBS, mirror
// symmetry, determinism per seed.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "core/error.h"

namespace haha {
namespace {

constexpr int kJ = kNumJoints;
constexpr int kSmplxParents[kJ] = {-1, 0,  0,  0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  9,  9,  12, 13, 14, 16,
                                   17, 18, 19, 15, 15, 15, 20, 25, 26, 20, 28, 29, 20, 31, 32, 20, 34, 35, 20,
                                   37, 38, 21, 40, 41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53};

using V3 = Vec3<double>;

struct Fixture {
  BodyModel m;
  ProceduralBodyInfo info;
};
const Fixture& body(BodyResolution r, uint64_t seed = 0) {
  static std::map<std::pair<int, uint64_t>, Fixture> cache;
  auto key = std::make_pair(int(r), seed);
  auto it = cache.find(key);
  if (it == cache.end()) {
    Fixture f;
    f.m = make_procedural_body({r, seed}, &f.info);
    it = cache.emplace(key, std::move(f)).first;
  }
  return it->second;
}
const BodyModel& low() { return body(BodyResolution::low).m; }
const BodyModel& full() { return body(BodyResolution::full).m; }

V3 vert(const BodyModel& m, int i) { return {m.v_template[3 * i], m.v_template[3 * i + 1], m.v_template[3 * i + 2]}; }
V3 vert_of(const std::vector<float>& v, int i) { return {v[3 * i], v[3 * i + 1], v[3 * i + 2]}; }

std::vector<V3> joints_of(const BodyModel& m, const std::vector<float>& verts) {
  std::vector<V3> j(kJ, V3(0, 0, 0));
  for (int k = 0; k < kJ; ++k)
    for (int i = 0; i < m.num_verts; ++i) {
      const double w = m.j_regressor[size_t(k) * m.num_verts + i];
      if (w != 0) j[k] += w * vert_of(verts, i);
    }
  return j;
}

const ProceduralPart& part(const ProceduralBodyInfo& info, const std::string& name) {
  for (const auto& p : info.parts)
    if (p.name == name) return p;
  throw std::runtime_error("no part " + name);
}

// Point-in-closed-surface by ray parity along a skewed direction (no edge hits).
bool inside_part(const BodyModel& m, const ProceduralPart& p, V3 q) {
  const V3 dir = V3(0.5773, 0.6211, 0.5301);
  int hits = 0;
  for (int f = p.first_face; f < p.first_face + p.num_faces; ++f) {
    const V3 a = vert(m, m.faces[3 * f]), b = vert(m, m.faces[3 * f + 1]), c = vert(m, m.faces[3 * f + 2]);
    const V3 e1 = b - a, e2 = c - a, pv = cross(dir, e2);
    const double det = dot(e1, pv);
    if (std::abs(det) < 1e-18) continue;
    const V3 tv = q - a;
    const double u = dot(tv, pv) / det;
    if (u < 0 || u > 1) continue;
    const V3 qv = cross(tv, e1);
    const double v = dot(dir, qv) / det;
    if (v < 0 || u + v > 1) continue;
    if (dot(e2, qv) / det > 0) ++hits;
  }
  return hits % 2 == 1;
}

// ---- layout of the real file ----------------------------------------------------------
void expect_smplx_layout(const BodyModel& m) {
  const size_t V = m.num_verts, F = m.num_faces;
  EXPECT_EQ(m.v_template.size(), V * 3);
  EXPECT_EQ(m.faces.size(), F * 3);
  EXPECT_EQ(m.j_regressor.size(), size_t(kJ) * V);
  EXPECT_EQ(m.weights.size(), V * kJ);
  EXPECT_EQ(m.num_shape, 300);
  EXPECT_EQ(m.num_expr, 100);
  EXPECT_EQ(m.shapedirs.size(), V * 3 * 400);
  EXPECT_EQ(m.posedirs.size(), V * 3 * size_t(kNumPoseFeatures));
  EXPECT_EQ(m.hands_components_l.size(), 45u * 45);
  EXPECT_EQ(m.hands_components_r.size(), 45u * 45);
  EXPECT_EQ(m.hands_mean_l.size(), 45u);
  EXPECT_EQ(m.hands_mean_r.size(), 45u);
  EXPECT_EQ(m.lmk_faces_idx.size(), 51u);
  EXPECT_EQ(m.lmk_bary_coords.size(), 51u * 3);
  EXPECT_EQ(m.ft.size(), F * 3);
  EXPECT_GT(m.num_uv(), int(V)) << "seams duplicate UV vertices";
  ASSERT_EQ(m.parents.size(), size_t(kJ));
  for (int j = 0; j < kJ; ++j) EXPECT_EQ(m.parents[j], kSmplxParents[j]) << "joint " << j;
  for (float x : m.v_template) ASSERT_TRUE(std::isfinite(x));
}

TEST(ProceduralBody, FullHasTheSmplxLayoutAndSize) {
  const BodyModel& m = full();
  expect_smplx_layout(m);
  EXPECT_GE(m.num_verts, 9930) << "tools built for SMPL-X index vertices up to 9929";
  EXPECT_NEAR(m.num_verts, 10475, 600);
  EXPECT_NEAR(m.num_faces, 20908, 1200);
}

TEST(ProceduralBody, LowHasTheSmplxLayoutAndIsSmall) {
  const BodyModel& m = low();
  expect_smplx_layout(m);
  EXPECT_GE(m.num_verts, 1000);
  EXPECT_LE(m.num_verts, 2500);
}

// ---- surface -------------------------------------------------------------------------
void expect_closed_outward_parts(const BodyModel& m, const ProceduralBodyInfo& info) {
  int covered_faces = 0, covered_verts = 0;
  for (const auto& p : info.parts) {
    covered_faces += p.num_faces;
    covered_verts += p.num_verts;
    // Every directed edge once, and its reverse once: closed, consistently oriented.
    std::set<std::pair<int, int>> edges;
    double volume = 0;
    for (int f = p.first_face; f < p.first_face + p.num_faces; ++f) {
      const int32_t* t = &m.faces[3 * f];
      for (int k = 0; k < 3; ++k) {
        ASSERT_GE(t[k], p.first_vert) << p.name;
        ASSERT_LT(t[k], p.first_vert + p.num_verts) << p.name;
        EXPECT_TRUE(edges.insert({t[k], t[(k + 1) % 3]}).second) << p.name << " face " << f;
      }
      const V3 a = vert(m, t[0]), b = vert(m, t[1]), c = vert(m, t[2]);
      const double area = 0.5 * norm(cross(b - a, c - a));
      EXPECT_GT(area, 1e-9) << p.name << " face " << f << " is degenerate";
      volume += dot(a, cross(b, c)) / 6;
    }
    for (const auto& e : edges) EXPECT_TRUE(edges.count({e.second, e.first})) << p.name << " has a boundary edge";
    EXPECT_GT(volume, 0) << p.name << " faces inward";
  }
  EXPECT_EQ(covered_faces, m.num_faces);
  EXPECT_EQ(covered_verts, m.num_verts);
}

TEST(ProceduralBody, PartsAreClosedOutwardSurfacesWithoutDegenerateFaces) {
  expect_closed_outward_parts(low(), body(BodyResolution::low).info);
  expect_closed_outward_parts(full(), body(BodyResolution::full).info);
}

TEST(ProceduralBody, HumanProportionsInTheSmplxRestPose) {
  const BodyModel& m = full();
  V3 lo(1e9), hi(-1e9);
  for (int i = 0; i < m.num_verts; ++i) {
    const V3 p = vert(m, i);
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p[c]), hi[c] = std::max(hi[c], p[c]);
  }
  EXPECT_GT(hi.y - lo.y, 1.6);  // about 1.7 m tall, Y up
  EXPECT_LT(hi.y - lo.y, 1.8);
  EXPECT_GT(hi.x - lo.x, 1.5);  // T-pose arm span along X
  EXPECT_LT(hi.x - lo.x, 1.95);
  EXPECT_LT(hi.z - lo.z, 0.45);
  const auto J = joints_of(m, m.v_template);
  EXPECT_NEAR(J[0].y, -0.35, 0.03);  // pelvis as in SMPL-X (origin in the lower chest)
  EXPECT_NEAR(J[0].x, 0.0, 1e-6);
  EXPECT_NEAR(J[0].z, 0.0, 0.03);
  // Facing +Z: nose in front of the head joint, toes in front of the ankles.
  const auto& info = body(BodyResolution::full).info;
  double head_front = -1e9, foot_front = -1e9;
  const auto& h = part(info, "head");
  for (int i = h.first_vert; i < h.first_vert + h.num_verts; ++i) head_front = std::max(head_front, vert(m, i).z);
  const auto& f = part(info, "foot_l");
  for (int i = f.first_vert; i < f.first_vert + f.num_verts; ++i) foot_front = std::max(foot_front, vert(m, i).z);
  EXPECT_GT(head_front, J[15].z + 0.07);
  EXPECT_GT(foot_front, J[7].z + 0.12);
  // T-pose: arms horizontal, wrists at shoulder height, hands far out.
  EXPECT_NEAR(J[20].y, J[16].y, 0.03);
  EXPECT_GT(J[20].x, 0.6);
}

// ---- joints --------------------------------------------------------------------------
void expect_regressor_and_joints(const BodyModel& m, const ProceduralBodyInfo& info) {
  for (int j = 0; j < kJ; ++j) {
    double sum = 0;
    for (int i = 0; i < m.num_verts; ++i) {
      const float w = m.j_regressor[size_t(j) * m.num_verts + i];
      ASSERT_GE(w, 0.f);
      sum += w;
    }
    EXPECT_NEAR(sum, 1.0, 1e-5) << "joint " << j;
  }
  const auto J = joints_of(m, m.v_template);
  // Spine chain upwards.
  for (int j : {3, 6, 9, 12, 15}) EXPECT_GT(J[j].y, J[m.parents[j]].y) << "joint " << j;
  // Legs downwards, feet forward.
  for (int j : {4, 5, 7, 8}) EXPECT_LT(J[j].y, J[m.parents[j]].y - 0.3) << "joint " << j;
  for (int j : {10, 11}) EXPECT_GT(J[j].z, J[m.parents[j]].z + 0.05) << "joint " << j;
  // Arms outwards: collar < shoulder < elbow < wrist < finger joints along +X (left).
  for (int j : {16, 18, 20}) EXPECT_GT(J[j].x, J[m.parents[j]].x + 0.05) << "joint " << j;
  for (int j = 25; j < 40; ++j) EXPECT_GT(J[j].x, J[m.parents[j]].x + 0.005) << "joint " << j;
  // Face: jaw below the eyes, eyes in front, above the head joint.
  EXPECT_LT(J[22].y, J[23].y);
  EXPECT_GT(J[23].z, J[15].z + 0.04);
  EXPECT_GT(J[23].y, J[15].y);
  // SMPL-X left is +X; the body is mirror symmetric.
  const int left[] = {1, 4, 7, 10, 13, 16, 18, 20, 23};
  for (int j : left) {
    EXPECT_GT(J[j].x, 0.02) << "joint " << j;
    EXPECT_NEAR(J[j + 1].x, -J[j].x, 1e-5) << "joint " << j;
    EXPECT_NEAR(J[j + 1].y, J[j].y, 1e-5) << "joint " << j;
    EXPECT_NEAR(J[j + 1].z, J[j].z, 1e-5) << "joint " << j;
  }
  for (int j = 25; j < 40; ++j) {
    EXPECT_GT(J[j].x, 0.5) << "joint " << j;
    EXPECT_NEAR(J[j + 15].x, -J[j].x, 1e-5) << "joint " << j;
    EXPECT_NEAR(J[j + 15].y, J[j].y, 1e-5) << "joint " << j;
    EXPECT_NEAR(J[j + 15].z, J[j].z, 1e-5) << "joint " << j;
  }
  for (int j : {0, 3, 6, 9, 12, 15, 22}) EXPECT_NEAR(J[j].x, 0.0, 1e-5) << "joint " << j;
  // Every joint lies inside the body (inside some closed part).
  for (int j = 0; j < kJ; ++j) {
    bool in = false;
    for (const auto& p : info.parts) in = in || inside_part(m, p, J[j]);
    EXPECT_TRUE(in) << "joint " << j << " at " << J[j].x << " " << J[j].y << " " << J[j].z;
  }
}

TEST(ProceduralBody, RegressorRowsAreAveragesAndJointsSitInTheBody) {
  expect_regressor_and_joints(low(), body(BodyResolution::low).info);
  expect_regressor_and_joints(full(), body(BodyResolution::full).info);
}

TEST(ProceduralBody, SkeletonDoesNotDependOnResolution) {
  const auto a = joints_of(low(), low().v_template), b = joints_of(full(), full().v_template);
  for (int j = 0; j < kJ; ++j) EXPECT_LT(norm(a[j] - b[j]), 0.01) << "joint " << j;
}

// ---- skinning ------------------------------------------------------------------------
void expect_weights(const BodyModel& m, const ProceduralBodyInfo& info) {
  std::vector<double> best(kJ, 0);
  for (int i = 0; i < m.num_verts; ++i) {
    double sum = 0;
    int influences = 0;
    for (int j = 0; j < kJ; ++j) {
      const float w = m.weights[size_t(i) * kJ + j];
      ASSERT_GE(w, 0.f) << "vertex " << i;
      sum += w;
      influences += w > 0;
      best[j] = std::max(best[j], double(w));
    }
    ASSERT_NEAR(sum, 1.0, 1e-5) << "vertex " << i;
    EXPECT_LE(influences, 4) << "vertex " << i;
  }
  for (int j = 0; j < kJ; ++j) EXPECT_GE(best[j], 0.5) << "joint " << j << " drives no vertex";
  // Eyeballs rotate rigidly with their joints.
  for (auto [name, joint] : {std::pair<const char*, int>{"eye_l", 23}, {"eye_r", 24}}) {
    const auto& p = part(info, name);
    for (int i = p.first_vert; i < p.first_vert + p.num_verts; ++i)
      EXPECT_EQ(m.weights[size_t(i) * kJ + joint], 1.f) << name;
  }
  // The lower face follows the jaw.
  int jaw = 0;
  const auto& h = part(info, "head");
  for (int i = h.first_vert; i < h.first_vert + h.num_verts; ++i) jaw += m.weights[size_t(i) * kJ + 22] > 0.5;
  EXPECT_GT(jaw, h.num_verts / 40);
}

TEST(ProceduralBody, WeightsAreSparseNonNegativeAndSumToOne) {
  expect_weights(low(), body(BodyResolution::low).info);
  expect_weights(full(), body(BodyResolution::full).info);
}

// Smooth skinning: bending joints stretches no edge by much (hard skinning tears the
// ring at a joint apart: 90 degree elbow and knee bends stretch edges there ~3.9x; LBS
// compression on the inner side is expected and not measured), eyeballs stay rigid, the
// jaw opens the mouth.
double max_stretch(const BodyModel& m, const std::vector<float>& posed) {
  double worst = 0;
  for (int f = 0; f < m.num_faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.faces[3 * f + k], b = m.faces[3 * f + (k + 1) % 3];
      worst = std::max(worst, norm(vert_of(posed, a) - vert_of(posed, b)) / norm(vert(m, a) - vert(m, b)));
    }
  return worst;
}

TEST(ProceduralBody, PosingStretchesEdgesSmoothly) {
  const BodyModel& m = full();
  const auto& info = body(BodyResolution::full).info;
  const Lbs<float> lbs(m);
  SmplxParams p;
  auto set = [&](int joint, double x, double y, double z) {
    p.pose[3 * joint] = float(x), p.pose[3 * joint + 1] = float(y), p.pose[3 * joint + 2] = float(z);
  };
  set(18, 0, -1.6, 0);  // left elbow 90 degrees
  set(19, 0, 1.6, 0);
  set(4, 1.6, 0, 0);    // left knee
  set(1, -1.0, 0, 0.3);  // left hip
  set(16, 0, 0, -0.9);  // shoulders down
  set(17, 0, 0, 0.9);
  set(6, 0.4, 0, 0);    // spine
  set(12, 0.3, 0.5, 0);  // neck
  set(15, -0.2, 0.4, 0);  // head
  set(23, 0, 0.3, 0);    // eyes
  set(24, 0, 0.3, 0);
  set(20, 0.5, 0, 0.6);  // wrist
  for (int j = 25; j < 55; ++j) set(j, 0, 0, j < 40 ? -0.8 : 0.8);  // curl fingers
  std::vector<float> posed(size_t(m.num_verts) * 3), joints(kJ * 3);
  lbs.forward(p, posed.data(), joints.data(), nullptr);
  EXPECT_LT(max_stretch(m, posed), 2.5);
  // Eyeballs: rigid about the eye joint.
  const auto Jr = joints_of(m, m.v_template);
  const auto& e = part(info, "eye_l");
  for (int i = e.first_vert; i < e.first_vert + e.num_verts; ++i)
    EXPECT_NEAR(norm(vert_of(posed, i) - vert_of(joints, 23)), norm(vert(m, i) - Jr[23]), 1e-5);
  // Jaw: the lower lip moves away from the upper lip (landmarks 40 and 34 of the 51, the
  // iBUG points 57 and 51); the brows (landmark 2) stay.
  auto lmk = [&](const std::vector<float>& v, int l) {
    V3 q(0, 0, 0);
    for (int k = 0; k < 3; ++k) q += double(m.lmk_bary_coords[3 * l + k]) * vert_of(v, m.faces[3 * m.lmk_faces_idx[l] + k]);
    return q;
  };
  SmplxParams jaw_only;
  jaw_only.pose[3 * 22] = 0.35f;
  std::vector<float> open(posed.size());
  lbs.forward(jaw_only, open.data(), nullptr, nullptr);
  const double gap_rest = norm(lmk(m.v_template, 40) - lmk(m.v_template, 34));
  const double gap_open = norm(lmk(open, 40) - lmk(open, 34));
  EXPECT_GT(gap_open, gap_rest + 0.01);
  EXPECT_LT(max_stretch(m, open), 3.0);
  EXPECT_LT(norm(lmk(open, 2) - lmk(m.v_template, 2)), 1e-6) << "brows do not follow the jaw";
}

// ---- pose correctives ----------------------------------------------------------------
TEST(ProceduralBody, PoseCorrectivesAreSmallAndLocalToEachVertexJoints) {
  const BodyModel& m = low();
  size_t nonzero = 0;
  for (int i = 0; i < m.num_verts; ++i)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < kNumPoseFeatures; ++k) {
        const float x = m.posedirs[(size_t(i) * 3 + c) * kNumPoseFeatures + k];
        if (x == 0) continue;
        ++nonzero;
        const int joint = 1 + k / 9;
        const float w = m.weights[size_t(i) * kJ + joint];
        EXPECT_GT(w, 0.f) << "vertex " << i << " corrective for a joint that does not move it";
        EXPECT_LT(std::abs(x), 0.01f);
      }
  EXPECT_GT(nonzero, size_t(m.num_verts) / 4);
}

// ---- shape and expression directions --------------------------------------------------
std::vector<float> shaped(const BodyModel& m, int column, float coef) {
  std::vector<float> v = m.v_template;
  for (int i = 0; i < m.num_verts * 3; ++i) v[i] += coef * m.shapedirs[size_t(i) * 400 + column];
  return v;
}
double extent(const std::vector<float>& v, int axis, const ProceduralPart* p = nullptr) {
  double lo = 1e9, hi = -1e9;
  const int first = p ? p->first_vert : 0, n = p ? p->num_verts : int(v.size() / 3);
  for (int i = first; i < first + n; ++i) lo = std::min(lo, double(v[3 * i + axis])), hi = std::max(hi, double(v[3 * i + axis]));
  return hi - lo;
}

TEST(ProceduralBody, ShapeDirectionsAreMeaningful) {
  const BodyModel& m = full();
  const auto& info = body(BodyResolution::full).info;
  ASSERT_EQ(info.num_meaningful_shape, 10);
  ASSERT_EQ(info.num_meaningful_expr, 10);
  for (int col = 0; col < 400; ++col) {
    double mag = 0;
    for (int i = 0; i < m.num_verts * 3; ++i) mag = std::max(mag, double(std::abs(m.shapedirs[size_t(i) * 400 + col])));
    const bool meaningful = col < 10 || (col >= 300 && col < 310);
    if (meaningful) {
      EXPECT_GT(mag, 0.002) << "column " << col;
    } else {
      EXPECT_EQ(mag, 0.0) << "column " << col;
    }
    EXPECT_LT(mag, 0.2) << "column " << col;
  }
  // beta 0: height (a few cm per unit).
  const double h0 = extent(m.v_template, 1), h1 = extent(shaped(m, 0, 1), 1);
  EXPECT_GT(h1 - h0, 0.03);
  EXPECT_LT(h1 - h0, 0.15);
  // beta 1: girth (torso wider and deeper, height unchanged).
  const auto& torso = part(info, "torso");
  EXPECT_GT(extent(shaped(m, 1, 1), 0, &torso) - extent(m.v_template, 0, &torso), 0.01);
  EXPECT_GT(extent(shaped(m, 1, 1), 2, &torso) - extent(m.v_template, 2, &torso), 0.005);
  EXPECT_NEAR(extent(shaped(m, 1, 1), 1), h0, 0.01);
  // beta 2: leg length (hip to ankle longer).
  const auto J0 = joints_of(m, m.v_template), J2 = joints_of(m, shaped(m, 2, 1));
  EXPECT_GT((J2[1].y - J2[7].y) - (J0[1].y - J0[7].y), 0.01);
  // beta 4: arm length (wrist further out).
  const auto J4 = joints_of(m, shaped(m, 4, 1));
  EXPECT_GT((J4[20].x - J4[16].x) - (J0[20].x - J0[16].x), 0.01);
  // beta 5: head size.
  const auto& head = part(info, "head");
  EXPECT_GT(extent(shaped(m, 5, 1), 1, &head) - extent(m.v_template, 1, &head), 0.005);
  // Shape directions keep the body mirror symmetric.
  const auto Js = joints_of(m, shaped(m, 3, 2));
  EXPECT_NEAR(Js[16].x, -Js[17].x, 1e-4);
}

TEST(ProceduralBody, ExpressionDirectionsMoveOnlyTheFace) {
  const BodyModel& m = full();
  const auto& head = part(body(BodyResolution::full).info, "head");
  const auto J = joints_of(m, m.v_template);
  for (int col = 300; col < 310; ++col) {
    double on_face = 0;
    for (int i = 0; i < m.num_verts; ++i) {
      double d = 0;
      for (int c = 0; c < 3; ++c) d = std::max(d, double(std::abs(m.shapedirs[(size_t(i) * 3 + c) * 400 + col])));
      const bool in_head = i >= head.first_vert && i < head.first_vert + head.num_verts;
      if (!in_head) {
        ASSERT_EQ(d, 0.0) << "expression " << col - 300 << " moves vertex " << i << " outside the head";
      } else if (d > 1e-4) {
        on_face = std::max(on_face, d);
        EXPECT_GT(vert(m, i).z, J[15].z) << "expression " << col - 300 << " moves the back of the head";
      }
    }
    EXPECT_GT(on_face, 0.002) << "expression " << col - 300;
  }
}

// ---- hand PCA ------------------------------------------------------------------------
TEST(ProceduralBody, HandComponentsAreOrthonormalAndMirrored) {
  const BodyModel& m = low();
  for (const auto* C : {&m.hands_components_l, &m.hands_components_r})
    for (int a = 0; a < 45; ++a)
      for (int b = 0; b < 45; ++b) {
        double d = 0;
        for (int k = 0; k < 45; ++k) d += double((*C)[45 * a + k]) * (*C)[45 * b + k];
        ASSERT_NEAR(d, a == b ? 1.0 : 0.0, 1e-5) << a << " " << b;
      }
  for (int i = 0; i < 45 * 45; ++i)
    EXPECT_EQ(m.hands_components_r[i], (i % 3 == 0 ? 1.f : -1.f) * m.hands_components_l[i]);
  double mean = 0;
  for (int i = 0; i < 45; ++i) {
    mean += std::abs(m.hands_mean_l[i]);
    EXPECT_EQ(m.hands_mean_r[i], (i % 3 == 0 ? 1.f : -1.f) * m.hands_mean_l[i]);
  }
  EXPECT_GT(mean, 0.5);
  // The first component curls the left fingers toward the palm (-Y).
  const Lbs<float> lbs(m);
  SmplxParams p;
  for (int k = 0; k < 45; ++k) p.pose[3 * 25 + k] = 1.5f * m.hands_components_l[k];
  std::vector<float> rest(m.v_template), curled(rest.size()), joints(kJ * 3);
  lbs.forward(p, curled.data(), joints.data(), nullptr);
  const auto Jr = joints_of(m, rest);
  EXPECT_LT(joints[3 * 27 + 1], Jr[27].y - 0.01) << "index tip joint moves down";
}

// ---- landmarks -----------------------------------------------------------------------
TEST(ProceduralBody, LandmarksLieOnTheFaceInIbugOrder) {
  const BodyModel& m = full();
  const auto& head = part(body(BodyResolution::full).info, "head");
  const auto J = joints_of(m, m.v_template);
  std::vector<V3> L;
  for (int l = 0; l < 51; ++l) {
    const int f = m.lmk_faces_idx[l];
    ASSERT_GE(f, head.first_face);
    ASSERT_LT(f, head.first_face + head.num_faces);
    double s = 0;
    V3 q(0, 0, 0);
    for (int k = 0; k < 3; ++k) {
      const float b = m.lmk_bary_coords[3 * l + k];
      EXPECT_GE(b, 0.f);
      s += b;
      q += double(b) * vert(m, m.faces[3 * f + k]);
    }
    EXPECT_NEAR(s, 1.0, 1e-5);
    EXPECT_GT(q.z, J[15].z + 0.05) << "landmark " << l << " on the face";
    L.push_back(q);
  }
  // 0-9 brows, 10-18 nose, 19-30 eyes, 31-50 mouth: brows above eyes above nose tip
  // above mouth; subject's right (-X) first.
  EXPECT_GT(L[2].y, L[19 + 1].y);
  EXPECT_GT(L[19].y, L[13].y);
  EXPECT_GT(L[13].y, L[31 + 3].y);
  EXPECT_LT(L[0].x, 0);
  EXPECT_GT(L[9].x, 0);
  EXPECT_NEAR(0.5 * (L[19].x + L[22].x), J[24].x, 0.01) << "right eye corners around the right eye";
  EXPECT_NEAR(0.5 * (L[25].x + L[28].x), J[23].x, 0.01);
  EXPECT_GT(L[13].z, L[19].z + 0.01) << "nose tip in front of the eyes";
}

// ---- UV atlas ------------------------------------------------------------------------
// Separating-axis test on the 6 edge normals with a tolerance: touching triangles
// (shared edges or vertices) do not overlap.
bool uv_overlap(const std::array<Vec2<double>, 3>& a, const std::array<Vec2<double>, 3>& b) {
  for (const auto* t : {&a, &b})
    for (int e = 0; e < 3; ++e) {
      const Vec2<double> p = (*t)[e], q = (*t)[(e + 1) % 3];
      const Vec2<double> n(q.y - p.y, p.x - q.x);
      const double len = std::hypot(n.x, n.y);
      double amin = 1e9, amax = -1e9, bmin = 1e9, bmax = -1e9;
      for (int k = 0; k < 3; ++k) {
        const double pa = (n.x * a[k].x + n.y * a[k].y) / len, pb = (n.x * b[k].x + n.y * b[k].y) / len;
        amin = std::min(amin, pa), amax = std::max(amax, pa), bmin = std::min(bmin, pb), bmax = std::max(bmax, pb);
      }
      if (amax <= bmin + 1e-9 || bmax <= amin + 1e-9) return false;
    }
  return true;
}

void expect_uv_atlas(const BodyModel& m) {
  const int F = m.num_faces;
  std::vector<std::array<Vec2<double>, 3>> tri(F);
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const int t = m.ft[3 * f + k];
      ASSERT_GE(t, 0);
      ASSERT_LT(t, m.num_uv());
      tri[f][k] = {m.vt[2 * t], m.vt[2 * t + 1]};
      ASSERT_GE(tri[f][k].x, 0.0);
      ASSERT_LE(tri[f][k].x, 1.0);
      ASSERT_GE(tri[f][k].y, 0.0);
      ASSERT_LE(tri[f][k].y, 1.0);
    }
  double used = 0;
  for (int f = 0; f < F; ++f) {
    const auto& t = tri[f];
    const double area = 0.5 * ((t[1].x - t[0].x) * (t[2].y - t[0].y) - (t[2].x - t[0].x) * (t[1].y - t[0].y));
    EXPECT_GT(area, 1e-10) << "UV triangle " << f << " degenerate or mirrored";
    used += area;
  }
  EXPECT_GT(used, 0.4) << "atlas uses a fair part of the texture";
  EXPECT_LT(used, 1.0);
  // All pairs, bucketed by a grid over the bounding boxes.
  constexpr int G = 128;
  std::vector<std::vector<int>> grid(G * G);
  for (int f = 0; f < F; ++f) {
    double x0 = 1, x1 = 0, y0 = 1, y1 = 0;
    for (const auto& p : tri[f]) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    for (int gy = std::max(0, int(y0 * G)); gy <= std::min(G - 1, int(y1 * G)); ++gy)
      for (int gx = std::max(0, int(x0 * G)); gx <= std::min(G - 1, int(x1 * G)); ++gx) grid[gy * G + gx].push_back(f);
  }
  int overlaps = 0;
  std::set<std::pair<int, int>> tested;
  for (const auto& cell : grid)
    for (size_t i = 0; i < cell.size(); ++i)
      for (size_t j = i + 1; j < cell.size(); ++j) {
        const int a = std::min(cell[i], cell[j]), b = std::max(cell[i], cell[j]);
        if (!tested.insert({a, b}).second) continue;
        if (uv_overlap(tri[a], tri[b])) {
          if (++overlaps <= 5) ADD_FAILURE() << "UV triangles " << a << " and " << b << " overlap";
        }
      }
  EXPECT_EQ(overlaps, 0);
  EXPECT_GT(tested.size(), size_t(F));  // the check did look at neighbours
}

TEST(ProceduralBody, UvAtlasHasNoOverlapsLow) { expect_uv_atlas(low()); }
TEST(ProceduralBody, UvAtlasHasNoOverlapsFull) { expect_uv_atlas(full()); }

// The overlap test itself catches overlaps and passes touching triangles.
TEST(ProceduralBody, UvOverlapPredicate) {
  using T = std::array<Vec2<double>, 3>;
  const T a = {{{0, 0}, {1, 0}, {0, 1}}};
  EXPECT_FALSE(uv_overlap(a, T{{{1, 0}, {1, 1}, {0, 1}}}));      // shared edge
  EXPECT_FALSE(uv_overlap(a, T{{{1, 0}, {2, 0}, {1.5, 1}}}));    // shared vertex
  EXPECT_TRUE(uv_overlap(a, T{{{0.2, 0.2}, {0.9, 0.2}, {0.2, 0.6}}}));  // inside
  EXPECT_TRUE(uv_overlap(a, T{{{0.4, 0.4}, {1, 1}, {0.3, 0.9}}}));   // crossing the hypotenuse
}

// ---- determinism ---------------------------------------------------------------------
TEST(ProceduralBody, DeterministicPerSeedAndSeedsVaryDetails) {
  const BodyModel a = make_procedural_body({BodyResolution::low, 7});
  const BodyModel b = make_procedural_body({BodyResolution::low, 7});
  EXPECT_EQ(a.v_template, b.v_template);
  EXPECT_EQ(a.faces, b.faces);
  EXPECT_EQ(a.weights, b.weights);
  EXPECT_EQ(a.shapedirs, b.shapedirs);
  EXPECT_EQ(a.posedirs, b.posedirs);
  EXPECT_EQ(a.j_regressor, b.j_regressor);
  EXPECT_EQ(a.vt, b.vt);
  EXPECT_EQ(a.lmk_faces_idx, b.lmk_faces_idx);
  EXPECT_EQ(a.lmk_bary_coords, b.lmk_bary_coords);
  const BodyModel& c = low();  // seed 0
  EXPECT_NE(a.v_template, c.v_template);
  EXPECT_EQ(a.faces, c.faces);
  EXPECT_EQ(a.ft, c.ft);
  double dmax = 0;
  for (size_t i = 0; i < a.v_template.size(); ++i) dmax = std::max(dmax, double(std::abs(a.v_template[i] - c.v_template[i])));
  EXPECT_GT(dmax, 0.002);
  EXPECT_LT(dmax, 0.1) << "seeds vary details, not the body";
}

TEST(ProceduralBody, ResolutionNames) {
  EXPECT_EQ(parse_body_resolution("low"), BodyResolution::low);
  EXPECT_EQ(parse_body_resolution("full"), BodyResolution::full);
  EXPECT_STREQ(body_resolution_name(BodyResolution::low), "low");
  try {
    parse_body_resolution("medium");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("medium"), std::string::npos);
  }
}

}  // namespace
}  // namespace haha
