// SMPL-X LBS: forward against a naive dense reference written from docs/method.md section 5,
// properties (zero pose, rigid segments, regressor consistency, full turns), hand-written
// backward against central finite differences in double for every parameter group, hard
// cases, float/double agreement, determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "body/lbs.h"
#include "body/rotation.h"
#include "core/error.h"
#include "core/parallel.h"
#include "support/body_synthetic_model.h"

namespace haha {
namespace {

using test::SynthOptions;
using test::make_synthetic_model;

constexpr double kPi = 3.14159265358979323846;
constexpr int kJ = kNumJoints;

// Parameters in double with a view for Lbs<double>.
struct Params {
  std::array<double, kNumPoseValues> pose{};
  std::vector<double> betas, expr;
  std::array<double, 3> transl{};
  SmplxView<double> view() const {
    return {pose.data(), betas.data(), int(betas.size()), expr.data(), int(expr.size()), transl.data()};
  }
  // Flat access for finite differences: pose | betas | expression | transl.
  int size() const { return kNumPoseValues + int(betas.size() + expr.size()) + 3; }
  double& at(int i) {
    if (i < kNumPoseValues) return pose[i];
    i -= kNumPoseValues;
    if (i < int(betas.size())) return betas[i];
    i -= int(betas.size());
    if (i < int(expr.size())) return expr[i];
    return transl[i - int(expr.size())];
  }
};

Params random_params(std::mt19937& rng, double angle, int nb, int ne, double transl = 0.3) {
  std::uniform_real_distribution<double> u(-1, 1);
  Params p;
  for (auto& x : p.pose) x = angle * u(rng);
  p.betas.resize(nb);
  p.expr.resize(ne);
  for (auto& x : p.betas) x = 2 * u(rng);
  for (auto& x : p.expr) x = 2 * u(rng);
  for (auto& x : p.transl) x = transl * u(rng);
  return p;
}

// ---- Naive reference (dense, 4x4 matrices, quaternion-based rotations) ----
struct Ref {
  std::vector<double> v_shaped, verts, joints, joints_rest;
  std::vector<std::array<double, 16>> G;
};

std::array<double, 16> mat4_mul(const std::array<double, 16>& a, const std::array<double, 16>& b) {
  std::array<double, 16> r{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) r[4 * i + j] += a[4 * i + k] * b[4 * k + j];
  return r;
}

Ref reference_lbs(const BodyModel& b, const Params& p) {
  const int V = b.num_verts, S = b.num_shape + b.num_expr;
  Ref r;
  r.v_shaped.resize(3 * V);
  for (int v = 0; v < V; ++v)
    for (int c = 0; c < 3; ++c) {
      double x = b.v_template[3 * v + c];
      for (size_t k = 0; k < p.betas.size(); ++k) x += b.shapedirs[(3 * v + c) * S + k] * p.betas[k];
      for (size_t k = 0; k < p.expr.size(); ++k) x += b.shapedirs[(3 * v + c) * S + b.num_shape + k] * p.expr[k];
      r.v_shaped[3 * v + c] = x;
    }
  r.joints_rest.assign(3 * kJ, 0.0);
  for (int j = 0; j < kJ; ++j)
    for (int v = 0; v < V; ++v)
      for (int c = 0; c < 3; ++c) r.joints_rest[3 * j + c] += b.j_regressor[size_t(j) * V + v] * r.v_shaped[3 * v + c];
  std::vector<Mat3d> R(kJ);
  for (int j = 0; j < kJ; ++j)
    R[j] = quat_to_mat(axis_angle_to_quat(Vec3d(p.pose[3 * j], p.pose[3 * j + 1], p.pose[3 * j + 2])));
  std::vector<double> feat(kNumPoseFeatures);
  for (int j = 1; j < kJ; ++j)
    for (int rr = 0; rr < 3; ++rr)
      for (int s = 0; s < 3; ++s) feat[9 * (j - 1) + 3 * rr + s] = R[j](rr, s) - (rr == s);
  r.G.resize(kJ);
  for (int j = 0; j < kJ; ++j) {
    std::array<double, 16> L{};
    const int par = b.parents[j];
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 3; ++k) L[4 * i + k] = R[j](i, k);
      L[4 * i + 3] = r.joints_rest[3 * j + i] - (par >= 0 ? r.joints_rest[3 * par + i] : 0.0);
    }
    L[15] = 1;
    r.G[j] = par >= 0 ? mat4_mul(r.G[par], L) : L;
  }
  r.verts.resize(3 * V);
  for (int v = 0; v < V; ++v) {
    double vp[3];
    for (int c = 0; c < 3; ++c) {
      vp[c] = r.v_shaped[3 * v + c];
      if (!b.posedirs.empty())
        for (int i = 0; i < kNumPoseFeatures; ++i) vp[c] += b.posedirs[(3 * size_t(v) + c) * kNumPoseFeatures + i] * feat[i];
    }
    for (int c = 0; c < 3; ++c) {
      double x = p.transl[c];
      for (int j = 0; j < kJ; ++j) {
        const double w = b.weights[size_t(v) * kJ + j];
        if (w == 0) continue;
        // A_j x = G_j (x - J_j)
        double y = r.G[j][4 * c + 3];
        for (int k = 0; k < 3; ++k) y += r.G[j][4 * c + k] * (vp[k] - r.joints_rest[3 * j + k]);
        x += w * y;
      }
      r.verts[3 * v + c] = x;
    }
  }
  r.joints.resize(3 * kJ);
  for (int j = 0; j < kJ; ++j)
    for (int c = 0; c < 3; ++c) r.joints[3 * j + c] = r.G[j][4 * c + 3] + p.transl[c];
  return r;
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  EXPECT_EQ(a.size(), b.size());
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
  return m;
}

bool all_finite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

// ---- Forward ----

TEST(Lbs, ForwardMatchesNaiveDenseReference) {
  for (int variant = 0; variant < 3; ++variant) {
    const bool dense = variant == 1;
    SynthOptions o;
    o.dense_posedirs = dense;
    o.max_influences = 4;
    if (variant == 2) o.verts_per_joint = 40;  // enough chunks for the parallel path
    const BodyModel b = make_synthetic_model(o);
    const Lbs<double> lbs(b);
    std::mt19937 rng(11);
    for (int rep = 0; rep < 3; ++rep) {
      // fewer betas / expression values than the model has: the rest count as zero
      const Params p = random_params(rng, 0.8, rep == 0 ? 10 : 4, rep == 1 ? 0 : 7);
      std::vector<double> verts(3 * b.num_verts), joints(3 * kJ);
      lbs.forward(p.view(), verts.data(), joints.data(), nullptr);
      const Ref r = reference_lbs(b, p);
      EXPECT_LT(max_abs_diff(verts, r.verts), 1e-12) << "dense " << dense;
      EXPECT_LT(max_abs_diff(joints, r.joints), 1e-12);
    }
  }
}

TEST(Lbs, ZeroPoseReturnsShapedTemplatePlusTransl) {
  const BodyModel b = make_synthetic_model({});
  std::mt19937 rng(12);
  Params p = random_params(rng, 0.0, 10, 10, 2.0);
  for (auto x : p.pose) ASSERT_EQ(x, 0.0);
  std::vector<double> verts(3 * b.num_verts);
  LbsCache<double> cache;
  Lbs<double>(b).forward(p.view(), verts.data(), nullptr, &cache);
  const int S = b.num_shape + b.num_expr;
  double err = 0;
  for (int v = 0; v < b.num_verts; ++v)
    for (int c = 0; c < 3; ++c) {
      double want = b.v_template[3 * v + c] + p.transl[c];
      for (int k = 0; k < 10; ++k) want += b.shapedirs[(3 * v + c) * S + k] * p.betas[k];
      for (int k = 0; k < 10; ++k) want += b.shapedirs[(3 * v + c) * S + 10 + k] * p.expr[k];
      err = std::max(err, std::fabs(verts[3 * v + c] - want));
      EXPECT_EQ(cache.v_posed[3 * v + c], cache.v_shaped[3 * v + c]);
    }
  EXPECT_LT(err, 1e-14);
  // Float path, from SmplxParams.
  SmplxParams pf;
  for (int k = 0; k < 10; ++k) pf.betas.push_back(float(p.betas[k])), pf.expression.push_back(float(p.expr[k]));
  for (int c = 0; c < 3; ++c) pf.transl[c] = float(p.transl[c]);
  std::vector<float> vf(3 * b.num_verts);
  Lbs<float>(b).forward(pf, vf.data(), nullptr, nullptr);
  for (size_t i = 0; i < vf.size(); ++i) EXPECT_NEAR(vf[i], verts[i], 2e-6);
}

// A rest displacement (BodyModel::rest_offsets) joins the shaped template at zero pose and
// leaves the joints where the bare body has them, with the betas too; one of the wrong size
// fails naming the key.
TEST(Lbs, RestOffsetsMoveTheSurfaceNotTheJoints) {
  BodyModel b = make_synthetic_model({});
  std::mt19937 rng(13);
  Params p = random_params(rng, 0.0, 10, 10, 0.0);
  std::vector<double> bare(3 * b.num_verts), moved(bare.size()), jb(3 * kNumJoints), jm(jb.size());
  Lbs<double>(b).forward(p.view(), bare.data(), jb.data(), nullptr);
  std::uniform_real_distribution<float> d(-0.02f, 0.05f);
  b.rest_offsets.resize(b.v_template.size());
  for (float& x : b.rest_offsets) x = d(rng);
  Lbs<double>(b).forward(p.view(), moved.data(), jm.data(), nullptr);
  for (size_t i = 0; i < bare.size(); ++i) EXPECT_NEAR(moved[i] - bare[i], double(b.rest_offsets[i]), 1e-12);
  EXPECT_EQ(jb, jm);
  b.rest_offsets.pop_back();
  try {
    Lbs<float> bad(b);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rest_offsets"), std::string::npos) << e.what();
  }
}

// Rotation of joint j in the world, chained independently of lbs.cpp.
Mat3d world_rotation(const BodyModel& b, const Params& p, int j) {
  Mat3d R = Mat3d::identity();
  for (int k = j; k >= 0; k = b.parents[k])
    R = quat_to_mat(axis_angle_to_quat(Vec3d(p.pose[3 * k], p.pose[3 * k + 1], p.pose[3 * k + 2]))) * R;
  return R;
}

TEST(Lbs, SegmentSkinnedToOneJointMovesRigidlyWithIt) {
  SynthOptions o;
  o.rigid_joints = {0, 4, 18, 21, 30, 54};
  o.verts_per_joint = 10;
  const BodyModel b = make_synthetic_model(o);
  const Lbs<double> lbs(b);
  std::mt19937 rng(13);
  for (int rep = 0; rep < 3; ++rep) {
    const Params p = random_params(rng, 1.2, 10, 10, 5.0);
    std::vector<double> verts(3 * b.num_verts), joints(3 * kJ);
    LbsCache<double> cache;
    lbs.forward(p.view(), verts.data(), joints.data(), &cache);
    for (int j : o.rigid_joints) {
      const Mat3d R = world_rotation(b, p, j);
      const Vec3d J = Vec3d::load(&cache.joints_rest[3 * j]), Jp = Vec3d::load(&joints[3 * j]);
      for (int i = 0; i < o.verts_per_joint; ++i) {
        const int v = j * o.verts_per_joint + i;
        const Vec3d want = R * (Vec3d::load(&cache.v_shaped[3 * v]) - J) + Jp;
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(verts[3 * v + c], want[c], 1e-12) << "joint " << j;
        // distances inside the segment are preserved
        const int w = j * o.verts_per_joint + (i + 1) % o.verts_per_joint;
        const double d_rest = norm(Vec3d::load(&cache.v_shaped[3 * v]) - Vec3d::load(&cache.v_shaped[3 * w]));
        const double d_posed = norm(Vec3d::load(&verts[3 * v]) - Vec3d::load(&verts[3 * w]));
        EXPECT_NEAR(d_posed, d_rest, 1e-12);
      }
    }
  }
}

TEST(Lbs, ConsistentRegressorReproducesPosedJoints) {
  SynthOptions o;
  o.all_rigid = true;  // every regressor row averages vertices bound rigidly to its joint
  const BodyModel b = make_synthetic_model(o);
  std::mt19937 rng(14);
  for (int rep = 0; rep < 3; ++rep) {
    const Params p = random_params(rng, 1.5, 10, 10, 3.0);
    std::vector<double> verts(3 * b.num_verts), joints(3 * kJ);
    Lbs<double>(b).forward(p.view(), verts.data(), joints.data(), nullptr);
    for (int j = 0; j < kJ; ++j)
      for (int c = 0; c < 3; ++c) {
        double x = 0;
        for (int v = 0; v < b.num_verts; ++v) x += b.j_regressor[size_t(j) * b.num_verts + v] * verts[3 * v + c];
        EXPECT_NEAR(x, joints[3 * j + c], 1e-12) << "joint " << j;
      }
  }
}

TEST(Lbs, FullTurnOfAnyJointChangesNothing) {
  const BodyModel b = make_synthetic_model({});
  const Lbs<double> lbs(b);
  std::mt19937 rng(15);
  const Params p = random_params(rng, 0.7, 10, 10);
  std::vector<double> v0(3 * b.num_verts), v1(3 * b.num_verts), j0(3 * kJ), j1(3 * kJ);
  lbs.forward(p.view(), v0.data(), j0.data(), nullptr);
  for (int j : {0, 1, 15, 22, 33, 54}) {
    Params q = p;
    const Vec3d w(q.pose[3 * j], q.pose[3 * j + 1], q.pose[3 * j + 2]);
    const Vec3d w2 = w * ((norm(w) + 2 * kPi) / norm(w));
    w2.store(&q.pose[3 * j]);
    lbs.forward(q.view(), v1.data(), j1.data(), nullptr);
    EXPECT_LT(max_abs_diff(v0, v1), 1e-13) << "joint " << j;
    EXPECT_LT(max_abs_diff(j0, j1), 1e-13);
  }
}

TEST(Lbs, FloatAgreesWithDoubleAndParamsOverloadMatchesView) {
  SynthOptions o;
  o.max_influences = 4;
  const BodyModel b = make_synthetic_model(o);
  std::mt19937 rng(16);
  const Params p = random_params(rng, 1.0, 10, 10);
  SmplxParams pf;
  for (int i = 0; i < kNumPoseValues; ++i) pf.pose[i] = float(p.pose[i]);
  pf.betas.assign(p.betas.begin(), p.betas.end());
  pf.expression.assign(p.expr.begin(), p.expr.end());
  for (int c = 0; c < 3; ++c) pf.transl[c] = float(p.transl[c]);
  Params pd;  // the float-rounded values in double
  for (int i = 0; i < kNumPoseValues; ++i) pd.pose[i] = pf.pose[i];
  pd.betas.assign(pf.betas.begin(), pf.betas.end());
  pd.expr.assign(pf.expression.begin(), pf.expression.end());
  for (int c = 0; c < 3; ++c) pd.transl[c] = pf.transl[c];
  std::vector<double> vd(3 * b.num_verts);
  Lbs<double>(b).forward(pd.view(), vd.data(), nullptr, nullptr);
  std::vector<double> vdp(3 * b.num_verts);
  Lbs<double>(b).forward(pf, vdp.data(), nullptr, nullptr);
  EXPECT_EQ(max_abs_diff(vd, vdp), 0.0);
  std::vector<float> vf(3 * b.num_verts);
  Lbs<float>(b).forward(pf, vf.data(), nullptr, nullptr);
  for (size_t i = 0; i < vf.size(); ++i) EXPECT_NEAR(vf[i], vd[i], 1e-5);
}

TEST(Lbs, BatchOverFramesEqualsFrameByFrame) {
  const BodyModel b = make_synthetic_model({});
  const Lbs<float> lbs(b);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<SmplxParams> frames(3);
  for (auto& f : frames) {
    for (auto& x : f.pose) x = 0.5f * u(rng);
    f.betas = {u(rng), u(rng)};
    f.transl = {u(rng), u(rng), u(rng)};
  }
  const size_t n = 3 * size_t(b.num_verts);
  std::vector<float> all(3 * n), jall(3 * 3 * kJ), one(n), jone(3 * kJ);
  lbs.forward_frames(frames, all.data(), jall.data());
  for (int f = 0; f < 3; ++f) {
    lbs.forward(frames[f], one.data(), jone.data(), nullptr);
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(all[f * n + i], one[i]);
    for (int i = 0; i < 3 * kJ; ++i) ASSERT_EQ(jall[f * 3 * kJ + i], jone[i]);
  }
}

// ---- Backward ----

struct GradCase {
  std::string name;
  double angle;      // pose components uniform in [-angle, angle]
  double transl;     // translation magnitude
  bool use_dverts, use_djoints;
  int nb, ne;
  // FD step. Vertices near 1e3 m carry ~1e-13 m of roundoff each, which a 1e-6 step
  // turns into ~1e-5 of gradient noise; a 1e-4 step keeps both error terms ~1e-8.
  double h = 1e-6;
};

// Checks every parameter (pose: global orient, body, jaw, eyes, hands; betas; expression;
// transl) by central differences (step gc.h), tolerance 1e-6 relative to the largest
// gradient component.
void check_gradients(const BodyModel& b, Params p, const GradCase& gc, uint32_t seed) {
  const Lbs<double> lbs(b);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> gv(3 * b.num_verts, 0.0), gj(3 * kJ, 0.0);
  if (gc.use_dverts)
    for (auto& x : gv) x = u(rng);
  if (gc.use_djoints)
    for (auto& x : gj) x = u(rng);
  std::vector<double> verts(3 * b.num_verts), joints(3 * kJ);
  auto loss = [&](const Params& q) {
    lbs.forward(q.view(), verts.data(), joints.data(), nullptr);
    double L = 0;
    for (size_t i = 0; i < verts.size(); ++i) L += gv[i] * verts[i];
    for (size_t i = 0; i < joints.size(); ++i) L += gj[i] * joints[i];
    return L;
  };
  LbsCache<double> cache;
  lbs.forward(p.view(), verts.data(), joints.data(), &cache);
  ASSERT_TRUE(all_finite(verts) && all_finite(joints)) << gc.name;
  SmplxGrad<double> g = lbs.make_grad(p.view());
  lbs.backward(p.view(), cache, gc.use_dverts ? gv.data() : nullptr, gc.use_djoints ? gj.data() : nullptr, g);
  // analytic in the flat order
  std::vector<double> an;
  an.insert(an.end(), g.pose.begin(), g.pose.end());
  an.insert(an.end(), g.betas.begin(), g.betas.end());
  an.insert(an.end(), g.expression.begin(), g.expression.end());
  an.insert(an.end(), g.transl.begin(), g.transl.end());
  ASSERT_EQ(int(an.size()), p.size());
  ASSERT_TRUE(all_finite(an)) << gc.name;
  double scale = 1e-3;
  for (double x : an) scale = std::max(scale, std::fabs(x));
  const double h = gc.h;
  auto group = [&](int i) -> std::string {
    if (i < 3) return "global_orient";
    if (i < 66) return "body_pose";
    if (i < 69) return "jaw_pose";
    if (i < 75) return "eye_pose";
    if (i < 165) return "hand_pose";
    i -= 165;
    if (i < int(p.betas.size())) return "betas";
    i -= int(p.betas.size());
    if (i < int(p.expr.size())) return "expression";
    return "transl";
  };
  for (int i = 0; i < p.size(); ++i) {
    Params q = p;
    const double x = q.at(i);
    q.at(i) = x + h;
    const double lp = loss(q);
    q.at(i) = x - h;
    const double lm = loss(q);
    EXPECT_NEAR(an[i], (lp - lm) / (2 * h), 1e-6 * scale) << gc.name << ": " << group(i) << " parameter " << i;
  }
}

TEST(LbsGradient, EveryParameterGroupMatchesFiniteDifferences) {
  SynthOptions o;
  o.max_influences = 4;
  o.verts_per_joint = 6;
  const BodyModel b = make_synthetic_model(o);
  const GradCase cases[] = {
      {"moderate, d_verts", 0.6, 0.3, true, false, 10, 10},
      {"moderate, d_joints", 0.6, 0.3, false, true, 10, 10},
      {"moderate, both, partial betas/expr", 0.6, 0.3, true, true, 4, 3},
      {"zero pose", 0.0, 0.0, true, true, 10, 10},
      {"extreme bends (up to 3 rad per axis)", 3.0, 0.3, true, true, 10, 10},
      {"translation 1e3 m", 0.6, 1e3, true, true, 10, 10, 1e-4},
  };
  uint32_t seed = 200;
  for (const GradCase& gc : cases) {
    std::mt19937 rng(seed);
    check_gradients(b, random_params(rng, gc.angle, gc.nb, gc.ne, gc.transl), gc, seed + 1);
    seed += 2;
  }
}

TEST(LbsGradient, HardRotationsNearZeroPiAndTwoPi) {
  SynthOptions o;
  o.verts_per_joint = 5;
  const BodyModel b = make_synthetic_model(o);
  std::mt19937 rng(300);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double angle : {0.0, 1e-9, kPi - 1e-7, kPi, kPi + 1e-7, 2 * kPi, 10.0}) {
    Params p = random_params(rng, 0.3, 10, 10);
    // every joint gets exactly this angle about a random axis
    for (int j = 0; j < kJ; ++j) {
      Vec3d a(u(rng), u(rng), u(rng));
      (angle * (a / norm(a))).store(&p.pose[3 * j]);
    }
    check_gradients(b, p, {"all joints at angle " + std::to_string(angle), angle, 0.3, true, true, 10, 10}, 301);
  }
}

TEST(LbsGradient, ResultDoesNotDependOnThreadCount) {
  SynthOptions o;
  o.verts_per_joint = 40;  // several reduction chunks
  const BodyModel b = make_synthetic_model(o);
  const Lbs<float> lbs(b);
  SmplxParams p;
  std::mt19937 rng(18);
  std::uniform_real_distribution<float> u(-1, 1);
  for (auto& x : p.pose) x = 0.5f * u(rng);
  p.betas = {0.3f, -0.2f};
  std::vector<float> verts(3 * b.num_verts), dv(3 * b.num_verts);
  for (auto& x : dv) x = u(rng);
  SmplxGrad<float> g[2];
  const int saved = num_threads();
  for (int t = 0; t < 2; ++t) {
    set_num_threads(t + 1);
    LbsCache<float> cache;
    lbs.forward(p, verts.data(), nullptr, &cache);
    g[t] = lbs.make_grad(p);
    lbs.backward(p, cache, dv.data(), nullptr, g[t]);
  }
  set_num_threads(saved);
  for (int i = 0; i < kNumPoseValues; ++i) EXPECT_EQ(g[0].pose[i], g[1].pose[i]);
  EXPECT_EQ(g[0].betas, g[1].betas);
}

TEST(LbsGradient, AccumulatesIntoGrad) {
  const BodyModel b = make_synthetic_model({});
  const Lbs<double> lbs(b);
  std::mt19937 rng(19);
  const Params p = random_params(rng, 0.5, 3, 2);
  std::vector<double> verts(3 * b.num_verts), dv(3 * b.num_verts, 0.5);
  LbsCache<double> cache;
  lbs.forward(p.view(), verts.data(), nullptr, &cache);
  SmplxGrad<double> g1 = lbs.make_grad(p.view()), g2 = lbs.make_grad(p.view());
  lbs.backward(p.view(), cache, dv.data(), nullptr, g1);
  lbs.backward(p.view(), cache, dv.data(), nullptr, g2);
  lbs.backward(p.view(), cache, dv.data(), nullptr, g2);
  for (int i = 0; i < kNumPoseValues; ++i) EXPECT_NEAR(g2.pose[i], 2 * g1.pose[i], 1e-12 * (1 + std::fabs(g1.pose[i])));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(g2.betas[k], 2 * g1.betas[k], 1e-12 * (1 + std::fabs(g1.betas[k])));
}

// ---- Hard cases and bad input ----

TEST(Lbs, LargeTranslationStaysFiniteAndFloatIsAccurate) {
  const BodyModel b = make_synthetic_model({});
  SmplxParams p;
  std::mt19937 rng(20);
  std::uniform_real_distribution<float> u(-1, 1);
  for (auto& x : p.pose) x = 3.0f * u(rng);
  p.transl = {1e3f, -1e3f, 1e3f};
  std::vector<float> vf(3 * b.num_verts), jf(3 * kJ);
  std::vector<double> vd(3 * b.num_verts);
  LbsCache<float> cache;
  const Lbs<float> lbs(b);
  lbs.forward(p, vf.data(), jf.data(), &cache);
  Lbs<double>(b).forward(p, vd.data(), nullptr, nullptr);
  for (size_t i = 0; i < vf.size(); ++i) {
    ASSERT_TRUE(std::isfinite(vf[i]));
    EXPECT_NEAR(vf[i], vd[i], 3e-4);  // float spacing at 1e3 m is 6e-5 m
  }
  SmplxGrad<float> g = lbs.make_grad(p);
  std::vector<float> dv(vf.size(), 1.0f);
  lbs.backward(p, cache, dv.data(), jf.data(), g);
  for (float x : g.pose) ASSERT_TRUE(std::isfinite(x));
  for (float x : g.transl) ASSERT_TRUE(std::isfinite(x));
}

TEST(Lbs, RejectsBadModelsAndTooManyCoefficients) {
  BodyModel b = make_synthetic_model({});
  b.source = "model.npz";
  {
    SmplxParams p;
    p.betas.assign(11, 0.1f);  // model has 10 shape components
    std::vector<float> v(3 * b.num_verts);
    try {
      Lbs<float>(b).forward(p, v.data(), nullptr, nullptr);
      FAIL() << "expected an error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("model.npz"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("betas"), std::string::npos) << e.what();
    }
  }
  BodyModel bad = b;
  bad.parents[5] = 7;  // child before parent
  EXPECT_THROW(Lbs<float>{bad}, Error);
  bad = b;
  bad.weights.pop_back();
  try {
    Lbs<double>{bad};
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("model.npz: weights"), std::string::npos) << e.what();
  }
  const Lbs<float> lbs(b);
  SmplxParams p;
  LbsCache<float> empty;
  SmplxGrad<float> g = lbs.make_grad(p);
  std::vector<float> dv(3 * b.num_verts, 1.0f);
  EXPECT_THROW(lbs.backward(p, empty, dv.data(), nullptr, g), Error);
}

TEST(Lbs, ModelWithoutCorrectivesOrShapeColumnsWorks) {
  SynthOptions o;
  o.with_posedirs = false;
  o.num_shape = 0;
  o.num_expr = 0;
  const BodyModel b = make_synthetic_model(o);
  std::mt19937 rng(21);
  const Params p = random_params(rng, 0.9, 0, 0);
  std::vector<double> verts(3 * b.num_verts), joints(3 * kJ);
  Lbs<double>(b).forward(p.view(), verts.data(), joints.data(), nullptr);
  const Ref r = reference_lbs(b, p);
  EXPECT_LT(max_abs_diff(verts, r.verts), 1e-12);
  check_gradients(b, p, {"no posedirs, no shapedirs", 0.9, 0.3, true, true, 0, 0}, 22);
}

}  // namespace
}  // namespace haha
