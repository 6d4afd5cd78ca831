// Face frames (T, R, q, k) and the posed-Gaussian transform: definition checks, rigid
// and scale invariance, finite-difference gradients in double, degenerate triangles.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "body/face_frames.h"
#include "core/error.h"

namespace haha {
namespace {

using V3 = Vec3d;

double max_abs(const Mat3d& m) {
  double r = 0;
  for (int i = 0; i < 9; ++i) r = std::max(r, std::fabs(m.a[i / 3][i % 3]));
  return r;
}

void expect_rotation(const Mat3d& R, double tol, const std::string& what) {
  EXPECT_LT(max_abs(transpose(R) * R + (-1.0) * Mat3d::identity()), tol) << what;
  const double det = dot(R.col(0), cross(R.col(1), R.col(2)));
  EXPECT_NEAR(det, 1.0, tol) << what;
}

bool finite(const FaceFrame<double>& f) {
  bool ok = std::isfinite(f.k) && std::isfinite(f.t.x) && std::isfinite(f.t.y) && std::isfinite(f.t.z);
  for (int i = 0; i < 9; ++i) ok = ok && std::isfinite(f.R.a[i / 3][i % 3]);
  return ok && std::isfinite(f.q.w) && std::isfinite(f.q.x) && std::isfinite(f.q.y) && std::isfinite(f.q.z);
}

V3 rnd3(std::mt19937& rng, double s = 1) {
  std::uniform_real_distribution<double> u(-1, 1);
  return {s * u(rng), s * u(rng), s * u(rng)};
}

TEST(FaceFrame, MatchesTheDefinition) {
  // Right triangle: v1 at the origin, v2 on x, v0 on y.
  const V3 v0(0, 1, 0), v1(0, 0, 0), v2(1, 0, 0);
  const FaceFrame<double> f = face_frame(v0, v1, v2, 0.5);
  EXPECT_NEAR(f.t.x, 1.0 / 3, 1e-15);
  EXPECT_NEAR(f.t.y, 1.0 / 3, 1e-15);
  // e = x, n = normalize(x cross y) = z, e x n = -y
  const Mat3d want = Mat3d::from_cols(V3(1, 0, 0), V3(0, 0, 1), V3(0, -1, 0));
  EXPECT_LT(max_abs(f.R + (-1.0) * want), 1e-15);
  // |v0 - v2| = sqrt 2, h = 1 / sqrt 2, k = mean / 0.5
  EXPECT_NEAR(f.k, (std::sqrt(2.0) + 1 / std::sqrt(2.0)) / 2 / 0.5, 1e-15);
  EXPECT_LT(max_abs(quat_to_mat(f.q) + (-1.0) * f.R), 1e-15);
}

TEST(FaceFrame, IsARotationThatFollowsRigidMotionAndScale) {
  std::mt19937 rng(1);
  for (int rep = 0; rep < 50; ++rep) {
    const V3 v0 = rnd3(rng), v1 = rnd3(rng), v2 = rnd3(rng);
    const FaceFrame<double> f = face_frame(v0, v1, v2, 1.0);
    expect_rotation(f.R, 1e-14, "random triangle");
    EXPECT_LT(max_abs(quat_to_mat(f.q) + (-1.0) * f.R), 1e-14);
    // the normal column is perpendicular to the triangle
    EXPECT_NEAR(dot(f.R.col(1), v0 - v1), 0.0, 1e-14);
    EXPECT_NEAR(dot(f.R.col(1), v2 - v1), 0.0, 1e-14);
    // rigid motion x -> Q x + c
    const Mat3d Q = rodrigues(rnd3(rng, 2.0));
    const V3 c = rnd3(rng, 10.0);
    const FaceFrame<double> g = face_frame(Q * v0 + c, Q * v1 + c, Q * v2 + c, 1.0);
    EXPECT_LT(max_abs(g.R + (-1.0) * (Q * f.R)), 1e-13);
    EXPECT_NEAR(norm(g.t - (Q * f.t + c)), 0.0, 1e-13);
    EXPECT_NEAR(g.k, f.k, 1e-13);
    // uniform scale: k scales, R does not
    const FaceFrame<double> s = face_frame(3.0 * v0, 3.0 * v1, 3.0 * v2, 1.0);
    EXPECT_NEAR(s.k, 3.0 * f.k, 1e-13);
    EXPECT_LT(max_abs(s.R + (-1.0) * f.R), 1e-13);
  }
}

// L = <gT, T> + <gR, R> + <gq, q> + gk k; check dL/dv against central differences,
// h = 1e-6, tolerance 1e-7 relative to the largest component (+1e-9 absolute).
void check_frame_gradient(V3 v0, V3 v1, V3 v2, double divisor, uint32_t seed, const std::string& what) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  FaceFrameGrad<double> g;
  g.t = rnd3(rng);
  for (int i = 0; i < 9; ++i) g.R.a[i / 3][i % 3] = u(rng);
  g.q = {u(rng), u(rng), u(rng), u(rng)};
  g.k = u(rng);
  auto L = [&](V3 a, V3 b, V3 c) {
    const FaceFrame<double> f = face_frame(a, b, c, divisor);
    return dot(g.t, f.t) + frob(g.R, f.R) + g.q.w * f.q.w + g.q.x * f.q.x + g.q.y * f.q.y + g.q.z * f.q.z + g.k * f.k;
  };
  V3 d[3] = {};
  face_frame_backward(v0, v1, v2, divisor, g, d[0], d[1], d[2]);
  double scale = 0;
  for (auto& x : d) scale = std::max({scale, std::fabs(x.x), std::fabs(x.y), std::fabs(x.z)});
  const double h = 1e-6;
  for (int vi = 0; vi < 3; ++vi)
    for (int c = 0; c < 3; ++c) {
      V3 p[3] = {v0, v1, v2}, m[3] = {v0, v1, v2};
      p[vi][c] += h;
      m[vi][c] -= h;
      const double num = (L(p[0], p[1], p[2]) - L(m[0], m[1], m[2])) / (2 * h);
      EXPECT_NEAR(d[vi][c], num, 1e-7 * scale + 1e-9) << what << ": vertex " << vi << " coord " << c;
    }
}

TEST(FaceFrame, BackwardMatchesFiniteDifferences) {
  std::mt19937 rng(2);
  for (int rep = 0; rep < 40; ++rep)
    check_frame_gradient(rnd3(rng), rnd3(rng), rnd3(rng), rep % 2 ? 1.0 : 0.05, 100 + rep, "random triangle");
  // Body-sized triangles (1 cm) far from the origin, and a thin sliver (not degenerate).
  check_frame_gradient(V3(0.01, 0, 0) + V3(1, 2, 3), V3(1, 2, 3), V3(0, 0.01, 0.002) + V3(1, 2, 3), 0.05, 7, "1 cm");
  check_frame_gradient(V3(0, 1e-3, 0), V3(0, 0, 0), V3(1, 0, 0), 1.0, 8, "sliver");
  // Frames whose quaternion sits on each Shepperd branch (R near x / y / z half-turns).
  for (int rep = 0; rep < 20; ++rep) {
    const Mat3d Q = rodrigues(rnd3(rng, 3.1));
    check_frame_gradient(Q * V3(0, 1, 0.2), Q * V3(0, 0, 0), Q * V3(1, 0.1, 0), 1.0, 200 + rep, "rotated");
  }
}

TEST(FaceFrame, DegenerateTrianglesGiveFiniteDefinedFrames) {
  const V3 a(0.3, -0.2, 1.0), b(0.5, 0.1, 0.9);
  struct Case {
    const char* name;
    V3 v0, v1, v2;
  } cases[] = {
      {"collinear", a, b, 2.0 * b - a},
      {"collinear, v0 between", 0.5 * (a + b), a, b},
      {"v1 == v2", a, b, b},
      {"v0 == v2", a, b, a},
      {"v0 == v1", a, a, b},
      {"all equal", a, a, a},
      {"all zero", V3(0, 0, 0), V3(0, 0, 0), V3(0, 0, 0)},
      {"tiny (1e-15 m)", a, a + V3(1e-15, 0, 0), a + V3(0, 1e-15, 0)},
  };
  std::mt19937 rng(3);
  for (const Case& c : cases) {
    const FaceFrame<double> f = face_frame(c.v0, c.v1, c.v2, 0.05);
    ASSERT_TRUE(finite(f)) << c.name;
    expect_rotation(f.R, 1e-12, c.name);
    EXPECT_GE(f.k, 0.0) << c.name;
    EXPECT_NEAR(norm(f.t - (c.v0 + c.v1 + c.v2) / 3.0), 0.0, 1e-15) << c.name;
    FaceFrameGrad<double> g;
    g.t = rnd3(rng);
    g.R.a[0][1] = 1;
    g.R.a[2][2] = -1;
    g.q = {0.3, -0.2, 0.5, 0.1};
    g.k = 0.7;
    V3 d[3] = {};
    face_frame_backward(c.v0, c.v1, c.v2, 0.05, g, d[0], d[1], d[2]);
    for (auto& x : d) EXPECT_TRUE(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z)) << c.name;
    // float gives finite values too
    const FaceFrame<float> ff = face_frame(Vec3f(c.v0), Vec3f(c.v1), Vec3f(c.v2), 0.05f);
    EXPECT_TRUE(std::isfinite(ff.k) && std::isfinite(ff.q.w) && std::isfinite(ff.R.a[1][1])) << c.name;
  }
  // A collapsed triangle has k = 0; a segment (collinear) has k = half its v0-v2 length.
  EXPECT_EQ(face_frame(a, a, a, 1.0).k, 0.0);
  EXPECT_NEAR(face_frame(a, b, 2.0 * b - a, 1.0).k, norm(a - (2.0 * b - a)) / 2, 1e-15);
}

TEST(FaceFrame, FarFromTheOriginInFloatStaysCloseToDouble) {
  std::mt19937 rng(4);
  const V3 c(1e3, -1e3, 1e3);
  for (int rep = 0; rep < 20; ++rep) {
    // 2 cm triangles 1 km away: float spacing there is 6e-5 m, so R errs ~ 6e-5/0.02.
    const V3 v0 = c + rnd3(rng, 0.02), v1 = c + rnd3(rng, 0.02), v2 = c + rnd3(rng, 0.02);
    const FaceFrame<double> fd = face_frame(v0, v1, v2, 1.0);
    const FaceFrame<float> ff = face_frame(Vec3f(v0), Vec3f(v1), Vec3f(v2), 1.0f);
    ASSERT_TRUE(std::isfinite(ff.k));
    EXPECT_NEAR(ff.t.x, fd.t.x, 1e-4);
    EXPECT_NEAR(ff.k, fd.k, 1e-4);
  }
}

// ---- Posed Gaussians over arrays ----

struct Mesh {
  std::vector<double> verts;
  std::vector<int32_t> faces;
  std::vector<int32_t> gface;
  std::vector<double> offset, rotation, scale;
  GaussianLocalView<double> view() const {
    return {int(gface.size()), gface.data(), offset.data(), rotation.data(), scale.data()};
  }
};

Mesh make_mesh(uint32_t seed, int gaussians_per_face) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Mesh m;
  const int V = 12;
  for (int i = 0; i < 3 * V; ++i) m.verts.push_back(u(rng));
  for (int f = 0; f < 10; ++f) m.faces.insert(m.faces.end(), {f, f + 1, f + 2});
  for (int f = 0; f < 10; ++f)
    for (int k = 0; k < gaussians_per_face; ++k) {
      m.gface.push_back((f * 7 + k) % 10);  // interleaved: not sorted by face
      for (int c = 0; c < 3; ++c) m.offset.push_back(0.3 * u(rng));
      Quat<double> q(u(rng), u(rng), u(rng), u(rng));
      const double n = std::sqrt(qnorm2(q));
      m.rotation.insert(m.rotation.end(), {q.w / n, q.x / n, q.y / n, q.z / n});
      for (int c = 0; c < 3; ++c) m.scale.push_back(0.1 + 0.05 * u(rng));
    }
  return m;
}

TEST(PoseGaussians, MatchesPerGaussianDefinition) {
  const Mesh m = make_mesh(5, 3);
  const int N = int(m.gface.size());
  std::vector<double> means(3 * N), quats(4 * N), scales(3 * N);
  pose_gaussians(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), means.data(), quats.data(), scales.data());
  for (int i = 0; i < N; ++i) {
    const int f = m.gface[i];
    const FaceFrame<double> fr = face_frame(V3::load(&m.verts[3 * m.faces[3 * f]]), V3::load(&m.verts[3 * m.faces[3 * f + 1]]),
                                            V3::load(&m.verts[3 * m.faces[3 * f + 2]]), 0.05);
    const V3 mu = fr.k * (fr.R * V3::load(&m.offset[3 * i])) + fr.t;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(means[3 * i + c], mu[c], 1e-14);
    // world rotation matrix = R_face * R_local
    const Mat3d Rw = quat_to_mat(Quat<double>::load(&quats[4 * i]));
    const Mat3d want = fr.R * quat_to_mat(Quat<double>::load(&m.rotation[4 * i]));
    EXPECT_LT(max_abs(Rw + (-1.0) * want), 1e-14);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(scales[3 * i + c], fr.k * m.scale[3 * i + c], 1e-15);
  }
}

TEST(PoseGaussians, BackwardMatchesFiniteDifferences) {
  Mesh m = make_mesh(6, 3);
  const int N = int(m.gface.size());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> gm(3 * N), gq(4 * N), gs(3 * N);
  for (auto* v : {&gm, &gq, &gs})
    for (auto& x : *v) x = u(rng);
  std::vector<double> means(3 * N), quats(4 * N), scales(3 * N);
  auto loss = [&]() {
    pose_gaussians(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), means.data(), quats.data(), scales.data());
    double L = 0;
    for (int i = 0; i < 3 * N; ++i) L += gm[i] * means[i] + gs[i] * scales[i];
    for (int i = 0; i < 4 * N; ++i) L += gq[i] * quats[i];
    return L;
  };
  std::vector<double> dv(m.verts.size(), 0.0), doff(3 * N, 0.0), drot(4 * N, 0.0), dsc(3 * N, 0.0);
  pose_gaussians_backward(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), gm.data(), gq.data(), gs.data(),
                          dv.data(), doff.data(), drot.data(), dsc.data());
  const double h = 1e-6;
  auto check = [&](std::vector<double>& x, const std::vector<double>& an, const char* name) {
    double scale = 1e-3;
    for (double a : an) scale = std::max(scale, std::fabs(a));
    for (size_t i = 0; i < x.size(); ++i) {
      const double x0 = x[i];
      x[i] = x0 + h;
      const double lp = loss();
      x[i] = x0 - h;
      const double lm = loss();
      x[i] = x0;
      ASSERT_TRUE(std::isfinite(an[i]));
      EXPECT_NEAR(an[i], (lp - lm) / (2 * h), 1e-7 * scale) << name << " " << i;
    }
  };
  check(m.verts, dv, "d_verts");
  check(m.offset, doff, "d_offset");
  check(m.rotation, drot, "d_rotation");
  check(m.scale, dsc, "d_scale");
  // Without d_verts the per-Gaussian gradients are the same.
  std::vector<double> doff2(3 * N, 0.0);
  pose_gaussians_backward(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), gm.data(), gq.data(), gs.data(),
                          nullptr, doff2.data(), nullptr, nullptr);
  EXPECT_EQ(doff2, doff);
  // Gradients are added: a second call doubles them.
  std::vector<double> dv2 = dv;
  pose_gaussians_backward(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), gm.data(), gq.data(), gs.data(),
                          dv2.data(), nullptr, nullptr, nullptr);
  for (size_t i = 0; i < dv.size(); ++i) EXPECT_NEAR(dv2[i], 2 * dv[i], 1e-12 * (1 + std::fabs(dv[i])));
}

TEST(PoseGaussians, DegenerateFaceAndBadFaceIndex) {
  Mesh m = make_mesh(8, 2);
  // collapse face 0 (vertices 0, 1, 2) to a point and face 5 to a line
  for (int c = 0; c < 3; ++c) m.verts[3 + c] = m.verts[6 + c] = m.verts[c];
  for (int c = 0; c < 3; ++c) m.verts[3 * 7 + c] = 2 * m.verts[3 * 6 + c] - m.verts[3 * 5 + c];
  const int N = int(m.gface.size());
  std::vector<double> means(3 * N), quats(4 * N), scales(3 * N), dv(m.verts.size(), 0.0);
  pose_gaussians(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), means.data(), quats.data(), scales.data());
  std::vector<double> ones(4 * N, 1.0);
  pose_gaussians_backward(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), ones.data(), ones.data(), ones.data(),
                          dv.data(), nullptr, nullptr, nullptr);
  for (double x : means) EXPECT_TRUE(std::isfinite(x));
  for (double x : quats) EXPECT_TRUE(std::isfinite(x));
  for (double x : scales) EXPECT_TRUE(std::isfinite(x) && x >= 0);
  for (double x : dv) EXPECT_TRUE(std::isfinite(x));
  m.gface[3] = 10;
  try {
    pose_gaussians(m.verts.data(), m.faces.data(), 10, 0.05, m.view(), means.data(), quats.data(), scales.data());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("Gaussian 3"), std::string::npos) << e.what();
  }
}

TEST(PoseGaussians, LargeMeshOnTheParallelPathMatchesSerialKernels) {
  // 3000 faces, 2 Gaussians each: above the launchers' serial cut-off.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  const int F = 3000, V = F + 2, N = 2 * F;
  Mesh m;
  for (int i = 0; i < 3 * V; ++i) m.verts.push_back(u(rng));
  for (int f = 0; f < F; ++f) m.faces.insert(m.faces.end(), {f, f + 1, f + 2});
  for (int i = 0; i < N; ++i) {
    m.gface.push_back((i * 7919) % F);
    for (int c = 0; c < 3; ++c) m.offset.push_back(0.3 * u(rng)), m.scale.push_back(0.1);
    m.rotation.insert(m.rotation.end(), {1.0, 0.0, 0.0, 0.0});
  }
  std::vector<double> means(3 * N), quats(4 * N), scales(3 * N), dm(3 * N), dq(4 * N), ds(3 * N);
  for (auto* v : {&dm, &dq, &ds})
    for (auto& x : *v) x = u(rng);
  pose_gaussians(m.verts.data(), m.faces.data(), F, 0.05, m.view(), means.data(), quats.data(), scales.data());
  std::vector<double> dv(3 * V, 0.0);
  pose_gaussians_backward(m.verts.data(), m.faces.data(), F, 0.05, m.view(), dm.data(), dq.data(), ds.data(),
                          dv.data(), nullptr, nullptr, nullptr);
  // Serial evaluation with the kernels.
  std::vector<double> dv_ref(3 * V, 0.0);
  for (int i = 0; i < N; ++i) {
    const int f = m.gface[i];
    V3 c[3];
    for (int k = 0; k < 3; ++k) c[k] = V3::load(&m.verts[3 * m.faces[3 * f + k]]);
    const FaceFrame<double> fr = face_frame(c[0], c[1], c[2], 0.05);
    V3 mu, sw, dmu, dsc;
    Quat<double> rw, dr{0, 0, 0, 0};
    pose_gaussian(fr, V3::load(&m.offset[3 * i]), Quat<double>::load(&m.rotation[4 * i]), V3::load(&m.scale[3 * i]),
                  mu, rw, sw);
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(means[3 * i + k], mu[k], 1e-14);
    FaceFrameGrad<double> g;
    pose_gaussian_backward(fr, V3::load(&m.offset[3 * i]), Quat<double>::load(&m.rotation[4 * i]),
                           V3::load(&m.scale[3 * i]), V3::load(&dm[3 * i]), Quat<double>::load(&dq[4 * i]),
                           V3::load(&ds[3 * i]), dmu, dr, dsc, g);
    V3 d[3] = {};
    face_frame_backward(c[0], c[1], c[2], 0.05, g, d[0], d[1], d[2]);
    for (int k = 0; k < 3; ++k)
      for (int x = 0; x < 3; ++x) dv_ref[3 * m.faces[3 * f + k] + x] += d[k][x];
  }
  for (int i = 0; i < 3 * V; ++i) EXPECT_NEAR(dv[i], dv_ref[i], 1e-12 * (1 + std::fabs(dv_ref[i])));
}

TEST(PoseGaussians, BoundGaussiansConvenienceMatchesTheArrayLauncher) {
  BodyModel body;
  body.num_verts = 4;
  body.num_faces = 2;
  body.faces = {0, 1, 2, 1, 3, 2};
  const std::vector<float> verts = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.5f};
  BoundGaussians g;
  g.resize(3);
  g.face = {1, 0, 1};
  for (int i = 0; i < 3; ++i) {
    g.offset[3 * i] = 0.1f * i;
    g.rotation[4 * i] = 1;
    g.scale[3 * i] = g.scale[3 * i + 1] = g.scale[3 * i + 2] = 0.2f;
  }
  std::vector<float> m1(9), q1(12), s1(9), m2(9), q2(12), s2(9);
  pose_gaussians(verts.data(), body, 0.05f, g, m1.data(), q1.data(), s1.data());
  pose_gaussians(verts.data(), body.faces.data(), 2, 0.05f, view_of(g), m2.data(), q2.data(), s2.data());
  EXPECT_EQ(m1, m2);
  EXPECT_EQ(q1, q2);
  EXPECT_EQ(s1, s2);
  // identity local rotation: world rotation is the face's
  const FaceFrame<float> f1 = face_frame(Vec3f(1, 0, 0), Vec3f(1, 1, 0.5f), Vec3f(0, 1, 0), 0.05f);
  EXPECT_NEAR(q1[0], f1.q.w, 1e-7);
  EXPECT_NEAR(q1[3], f1.q.z, 1e-7);
}

}  // namespace
}  // namespace haha
