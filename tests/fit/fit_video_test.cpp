// The video fit (fit/fit_video.h): the objective's gradient against central finite
// differences in double (every term, a rotated camera, linked frames, an extra vertex term),
// its hard cases (a keypoint behind the camera, zero visibility), the BlazePose -> body
// correspondence on the procedural body, frame selection (nobody, cut off, scene cut, low
// score) and fit_video's report and errors. The accuracy of the fit: fit_video_slow_test.cpp.
#include "fit/fit_video.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fit/fit_video_frames.h"
#include "fit/fit_video_objective.h"
#include "fit/fit_video_points.h"
#include "fit/fit_video_world_init.h"
#include "body/procedural_body.h"
#include "body/rotation.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "support/body_synthetic_model.h"
#include "support/expect_error.h"
#include "support/fit_video_fixtures.h"

namespace haha {
namespace {

namespace bp = blazepose;

const BodyModel& small_body() {
  static const BodyModel b = [] {
    test::SynthOptions o;
    o.verts_per_joint = 3;
    return test::make_synthetic_model(o);
  }();
  return b;
}

const BodyModel& procedural() {
  static const BodyModel b = make_procedural_body({BodyResolution::low, 3});
  return b;
}

// 12 joints and 3 vertices of the small body, like the real correspondence.
std::vector<FitVideoPoint> small_points() {
  std::vector<FitVideoPoint> p;
  const int joints[][2] = {{bp::left_shoulder, 16}, {bp::right_shoulder, 17}, {bp::left_elbow, 18}, {bp::right_elbow, 19},
                           {bp::left_wrist, 20},    {bp::right_wrist, 21},    {bp::left_hip, 1},    {bp::right_hip, 2},
                           {bp::left_knee, 4},      {bp::right_knee, 5},      {bp::left_ankle, 7},  {bp::right_ankle, 8}};
  for (auto& j : joints) p.push_back({j[0], j[1], -1, j[0] == bp::left_hip || j[0] == bp::right_hip ? 0.4 : 1.0, j[1] < 18, "j"});
  p.push_back({bp::nose, -1, 3 * 15, 0.3, true, "nose"});
  p.push_back({bp::left_heel, -1, 3 * 7 + 1, 0.7, false, "heel"});
  p.push_back({bp::right_foot_index, -1, 3 * 11 + 2, 0.7, false, "toe"});
  return p;
}

CameraT<double> rotated_camera() {
  CameraT<double> c;
  c.width = 320;
  c.height = 240;
  c.fx = 400, c.fy = 410, c.cx = 160, c.cy = 120;
  c.R = rodrigues(Vec3d(0.05, -0.1, 0.03));
  c.t = Vec3d(0.02, -0.01, 0.1);
  return c;
}

// Parameters of n frames: poses about 0.3 rad, knees and elbows partly bent the wrong way
// (inside the limits' penalty, away from its kink), the body about 3 m in front.
std::vector<double> random_params(int n, int nb, std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 0.3);
  std::vector<double> p(size_t(n) * kFitVideoFrameParams + size_t(nb));
  for (int f = 0; f < n; ++f) {
    double* q = p.data() + size_t(f) * kFitVideoFrameParams;
    for (int k = 0; k < kFitVideoPoseValues; ++k) q[k] = g(rng);
    q[0] += 3.0;  // near pi about x: upright in the camera
    q[3 * 4] = -0.4, q[3 * 5] = 0.5, q[3 * 18 + 1] = 0.3, q[3 * 19 + 1] = 0.35;
    q[kFitVideoPoseValues] = 0.1 * g(rng), q[kFitVideoPoseValues + 1] = 0.1 * g(rng), q[kFitVideoPoseValues + 2] = 3.0;
  }
  for (int k = 0; k < nb; ++k) p[size_t(n) * kFitVideoFrameParams + size_t(k)] = g(rng);
  return p;
}

// Targets near the projections (some beyond the Geman-McClure knee), random visibility,
// world points scattered around the hips (bone directions anywhere, some beyond the knee of
// the bone term), frames 1/20 s apart.
std::vector<FitVideoTargets> random_targets(const FitVideoObjective<double>& obj, const std::vector<double>& p, int n,
                                            std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 15.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<FitVideoTargets> t(static_cast<size_t>(n));
  const double* betas = p.data() + size_t(n) * kFitVideoFrameParams;
  for (int f = 0; f < n; ++f) {
    std::vector<double> pu, pv;
    obj.project(p.data() + size_t(f) * kFitVideoFrameParams, betas, pu, pv);
    for (size_t k = 0; k < pu.size(); ++k) {
      const double far = k % 5 == 0 ? 6 : 1;
      t[size_t(f)].x.push_back(pu[k] + far * g(rng));
      t[size_t(f)].y.push_back(pv[k] + far * g(rng));
      t[size_t(f)].vis.push_back(u(rng));
      for (int c = 0; c < 3; ++c) t[size_t(f)].world.push_back(0.5 * (u(rng) - 0.5));
    }
    t[size_t(f)].linked = f > 0;
    t[size_t(f)].dt = 0.05;
  }
  return t;
}

FitVideoWeights strong_weights() {  // every term well above rounding in the check
  FitVideoWeights w;
  w.pose_prior = 1e-2, w.angle_limit = 0.5, w.smooth_pose = 0.1, w.smooth_transl = 0.3, w.betas = 1e-2, w.behind = 2;
  w.world = 0.2, w.world_sigma = 0.7;
  return w;
}

// A smooth extra term on the posed vertices, standing in for the silhouette.
double extra_term(const double* verts, double* d_verts, int V) {
  double e = 0;
  for (int v = 0; v < V; ++v) {
    const double a = 0.3 * verts[3 * v] - 0.2 * verts[3 * v + 1] + 0.1 * verts[3 * v + 2];
    e += 0.05 * a * a;
    if (d_verts) {
      d_verts[3 * v] += 0.1 * a * 0.3;
      d_verts[3 * v + 1] += 0.1 * a * -0.2;
      d_verts[3 * v + 2] += 0.1 * a * 0.1;
    }
  }
  return e;
}

// Largest |analytic - numeric| / (|numeric| + scale) over all parameters.
double gradient_error(const FitVideoObjective<double>& obj, const std::vector<FitVideoTargets>& t, std::vector<double> p,
                      const FitVideoObjective<double>::Extra& extra) {
  std::vector<double> g(p.size());
  const double e0 = obj.evaluate(t, p.data(), g.data(), extra);
  EXPECT_TRUE(std::isfinite(e0));
  double scale = 0;
  for (double x : g) scale = std::max(scale, std::abs(x));
  double worst = 0;
  const double h = 1e-6;
  for (size_t i = 0; i < p.size(); ++i) {
    const double keep = p[i];
    p[i] = keep + h;
    const double ep = obj.evaluate(t, p.data(), nullptr, extra);
    p[i] = keep - h;
    const double em = obj.evaluate(t, p.data(), nullptr, extra);
    p[i] = keep;
    const double num = (ep - em) / (2 * h);
    EXPECT_TRUE(std::isfinite(g[i])) << i;
    worst = std::max(worst, std::abs(g[i] - num) / (std::abs(num) + 1e-3 * scale));
  }
  return worst;
}

TEST(FitVideoObjective, GradientMatchesFiniteDifferencesInDouble) {
  std::mt19937 rng(5);
  const int n = 3, nb = 4;
  const FitVideoObjective<double> obj(small_body(), small_points(), rotated_camera(), nb, strong_weights());
  const std::vector<double> p = random_params(n, nb, rng);
  const std::vector<FitVideoTargets> t = random_targets(obj, p, n, rng);
  const int V = small_body().num_verts;
  const FitVideoObjective<double>::Extra extra = [&](int, const double* v, double* d) { return extra_term(v, d, V); };
  FitVideoTerms terms;
  obj.evaluate(t, p.data(), nullptr, extra, &terms);
  // Every term is active, so the check covers each.
  EXPECT_GT(terms.keypoints, 0);
  EXPECT_GT(terms.prior, 0);
  EXPECT_GT(terms.limits, 0);
  EXPECT_GT(terms.smooth, 0);
  EXPECT_GT(terms.betas, 0);
  EXPECT_GT(terms.extra, 0);
  EXPECT_GT(terms.world, 0);
  EXPECT_LT(gradient_error(obj, t, p, extra), 1e-5);
  // The bone term alone (its gradient is small beside the keypoints').
  FitVideoWeights only_world;
  only_world.keypoints = 0, only_world.pose_prior = 0, only_world.smooth_pose = only_world.smooth_transl = 0;
  only_world.betas = 0, only_world.world = 1;
  const FitVideoObjective<double> wobj(small_body(), small_points(), rotated_camera(), nb, only_world);
  FitVideoTerms wt;
  wobj.evaluate(t, p.data(), nullptr, {}, &wt);
  EXPECT_GT(wt.world, 0);
  EXPECT_EQ(wt.keypoints, 0);
  EXPECT_LT(gradient_error(wobj, t, p, {}), 1e-5);
  // The robust smoothness (frames ~0.3 rad apart per value: past both knees).
  FitVideoWeights robust = strong_weights();
  robust.smooth_pose = 1, robust.smooth_sigma = 0.15;
  const FitVideoObjective<double> robj(small_body(), small_points(), rotated_camera(), nb, robust);
  FitVideoTerms rt;
  robj.evaluate(t, p.data(), nullptr, {}, &rt);
  EXPECT_GT(rt.smooth, 0);
  EXPECT_LT(gradient_error(robj, t, p, {}), 1e-5);
}

// Robust smoothness: a small change costs what the quadratic costs, a jump (a cut between
// stills, a fast move) at most w sigma^2 per value, so it is not pulled towards its neighbour.
TEST(FitVideoObjective, RobustSmoothnessCapsTheCostOfAJump) {
  FitVideoWeights w;
  w.keypoints = 0, w.pose_prior = 0, w.angle_limit = 0, w.betas = 0, w.behind = 0, w.world = 0;
  w.smooth_transl = 0;
  std::mt19937 rng(29);
  auto smooth = [&](double sigma, double change, int k) {
    FitVideoWeights ww = w;
    ww.smooth_sigma = sigma;
    const FitVideoObjective<double> obj(small_body(), small_points(), rotated_camera(), 0, ww);
    std::vector<double> p = random_params(2, 0, rng);
    for (int j = 0; j < kFitVideoFrameParams; ++j) p[size_t(kFitVideoFrameParams + j)] = p[size_t(j)];
    p[size_t(kFitVideoFrameParams + k)] += change;
    std::vector<FitVideoTargets> t = random_targets(obj, p, 2, rng);
    for (FitVideoTargets& x : t) x.dt = kFitVideoSmoothInterval;
    FitVideoTerms terms;
    obj.evaluate(t, p.data(), nullptr, {}, &terms);
    return terms.smooth * 2;  // the objective divides by the frame count
  };
  const double wsp = w.smooth_pose;
  const double s = 0.15;
  EXPECT_NEAR(smooth(0, 1.0, 40), wsp * 1.0, 1e-12);                    // quadratic
  EXPECT_NEAR(smooth(s, 1e-3, 40), wsp * 1e-6, 1e-4 * wsp * 1e-6);       // small: nearly the same
  const double jump = smooth(s, 1.0, 40);                                // a body joint
  EXPECT_NEAR(jump, wsp * s * s / (s * s + 1.0), 1e-12);
  EXPECT_LT(jump, wsp * s * s);
  EXPECT_NEAR(smooth(s, 1.0, 1), wsp * 1.0, 1e-12);  // the global orient stays quadratic
}

TEST(FitVideoObjective, PointBehindTheCameraIsFiniteAndPulledForward) {
  std::mt19937 rng(7);
  const int n = 2, nb = 2;
  const FitVideoObjective<double> obj(small_body(), small_points(), rotated_camera(), nb, strong_weights());
  std::vector<double> p = random_params(n, nb, rng);
  const std::vector<FitVideoTargets> t = random_targets(obj, p, n, rng);
  // Frame 1 straddles the camera plane: some points behind it, some in front.
  p[kFitVideoFrameParams + kFitVideoPoseValues + 2] = 0.0;
  FitVideoTerms terms;
  std::vector<double> g(p.size());
  const double e = obj.evaluate(t, p.data(), g.data(), {}, &terms);
  ASSERT_TRUE(std::isfinite(e));
  EXPECT_GT(terms.behind, 0);
  for (double x : g) ASSERT_TRUE(std::isfinite(x));
  std::vector<double> u, v;
  obj.project(p.data() + kFitVideoFrameParams, p.data() + 2 * kFitVideoFrameParams, u, v);
  for (size_t k = 0; k < u.size(); ++k) EXPECT_TRUE(std::isfinite(u[k]) && std::isfinite(v[k]));
  // Descending the gradient moves the body away from the camera (+z).
  EXPECT_LT(g[kFitVideoFrameParams + kFitVideoPoseValues + 2], 0);
  EXPECT_LT(gradient_error(obj, t, p, {}), 1e-5);
}

TEST(FitVideoObjective, ZeroVisibilityAndAllInvisibleFramesGiveNoKeypointTermAndNoNan) {
  std::mt19937 rng(9);
  const int n = 2, nb = 3;
  const FitVideoObjective<double> obj(small_body(), small_points(), rotated_camera(), nb, strong_weights());
  const std::vector<double> p = random_params(n, nb, rng);
  std::vector<FitVideoTargets> t = random_targets(obj, p, n, rng);
  for (FitVideoTargets& f : t) std::fill(f.vis.begin(), f.vis.end(), 0.0);
  FitVideoTerms terms;
  std::vector<double> g(p.size());
  ASSERT_TRUE(std::isfinite(obj.evaluate(t, p.data(), g.data(), {}, &terms)));
  EXPECT_EQ(terms.keypoints, 0.0);
  for (double x : g) ASSERT_TRUE(std::isfinite(x));
  // Only the priors act: at rest pose with no betas, nothing pulls at all.
  std::vector<double> rest(p.size(), 0.0);
  for (int f = 0; f < n; ++f) rest[size_t(f) * kFitVideoFrameParams + kFitVideoPoseValues + 2] = 3.0;
  ASSERT_EQ(obj.evaluate(t, rest.data(), g.data()), 0.0);
  for (double x : g) EXPECT_EQ(x, 0.0);
  EXPECT_LT(gradient_error(obj, t, p, {}), 1e-5);
}

TEST(FitVideoObjective, GemanMcClureBoundsTheOutlierCost) {
  std::mt19937 rng(11);
  FitVideoWeights w;
  const FitVideoObjective<double> obj(small_body(), small_points(), rotated_camera(), 0, w);
  std::vector<double> p = random_params(1, 0, rng);
  std::vector<FitVideoTargets> t = random_targets(obj, p, 1, rng);
  std::fill(t[0].vis.begin(), t[0].vis.end(), 1.0);
  FitVideoTerms near, far;
  obj.evaluate(t, p.data(), nullptr, {}, &near);
  t[0].x[0] += 1e6;  // one absurd point costs at most its weight x sigma^2
  obj.evaluate(t, p.data(), nullptr, {}, &far);
  EXPECT_GT(far.keypoints, near.keypoints);
  EXPECT_LE(far.keypoints - near.keypoints, small_points()[0].weight * w.gm_sigma * w.gm_sigma + 1e-12);
}

// World points of frame parameters q: the posed points in camera axes, hip-centred.
std::vector<double> exact_world(const FitVideoObjective<double>& obj, const BodyModel& body, const CameraT<double>& cam,
                                const double* q, const double* betas, int nb) {
  std::vector<double> v(size_t(body.num_verts) * 3), j(size_t(kNumJoints) * 3), w;
  Lbs<double>(body).forward(FitVideoObjective<double>::to_params(q, betas, nb), v.data(), j.data(), nullptr);
  for (const FitVideoPoint& p : obj.points()) {
    const double* x = p.joint >= 0 ? &j[size_t(3 * p.joint)] : &v[size_t(3 * p.vertex)];
    const Vec3d c = cam.to_camera(Vec3d(x[0], x[1], x[2])) - cam.to_camera(Vec3d::load(&j[0]));
    w.insert(w.end(), {c.x, c.y, c.z});
  }
  return w;
}

TEST(FitVideoObjective, BoneTermIsZeroOnTheTruthAndTellsDepthFlips) {
  std::mt19937 rng(21);
  const int nb = 2;
  FitVideoWeights w;
  w.keypoints = 0, w.pose_prior = 0, w.angle_limit = 0, w.betas = 0, w.world = 1;
  const CameraT<double> cam = rotated_camera();
  const FitVideoObjective<double> obj(small_body(), small_points(), cam, nb, w);
  const std::vector<double> p = random_params(1, nb, rng);
  std::vector<FitVideoTargets> t = random_targets(obj, p, 1, rng);
  std::fill(t[0].vis.begin(), t[0].vis.end(), 1.0);
  t[0].world = exact_world(obj, small_body(), cam, p.data(), p.data() + kFitVideoFrameParams, nb);
  FitVideoTerms exact, flipped, hidden;
  obj.evaluate(t, p.data(), nullptr, {}, &exact);
  EXPECT_LT(exact.world, 1e-12);  // rounding only
  // Mirrored in depth (what the 2D points cannot tell apart): the term sees it.
  for (size_t k = 2; k < t[0].world.size(); k += 3) t[0].world[k] = -t[0].world[k];
  obj.evaluate(t, p.data(), nullptr, {}, &flipped);
  EXPECT_GT(flipped.world, 0.05);
  // Unseen bones, or world points all at one place (no direction): no term, no NaN.
  std::fill(t[0].vis.begin(), t[0].vis.end(), 0.0);
  std::vector<double> g(p.size());
  obj.evaluate(t, p.data(), g.data(), {}, &hidden);
  EXPECT_EQ(hidden.world, 0.0);
  std::fill(t[0].vis.begin(), t[0].vis.end(), 1.0);
  std::fill(t[0].world.begin(), t[0].world.end(), 0.25);
  obj.evaluate(t, p.data(), g.data(), {}, &hidden);
  EXPECT_EQ(hidden.world, 0.0);
  for (double x : g) ASSERT_TRUE(std::isfinite(x));
}

TEST(FitVideoObjective, SmoothnessDoesNotDependOnTheFrameRate) {
  // A body moving at a constant rate, sampled at 30 and at 10 frames per second: the same
  // smoothness per frame (the squared velocity), so the same balance with the data.
  FitVideoWeights w;
  w.keypoints = 0, w.pose_prior = 0, w.angle_limit = 0, w.betas = 0, w.behind = 0;
  const FitVideoObjective<double> obj(small_body(), small_points(), rotated_camera(), 0, w);
  std::mt19937 rng(23);
  const int n = 4;
  const std::vector<double> base = random_params(n, 0, rng);
  std::vector<double> rate(kFitVideoFrameParams);
  std::normal_distribution<double> g(0.0, 1.0);
  for (double& r : rate) r = g(rng);  // per second
  double smooth[2];
  for (int i = 0; i < 2; ++i) {
    const double dt = i == 0 ? 1.0 / 30 : 1.0 / 10;
    std::vector<double> p = base;
    for (int f = 0; f < n; ++f)
      for (int k = 0; k < kFitVideoFrameParams; ++k)
        p[size_t(f * kFitVideoFrameParams + k)] = base[size_t(k)] + rate[size_t(k)] * dt * f;
    std::vector<FitVideoTargets> t = random_targets(obj, p, n, rng);
    for (FitVideoTargets& x : t) x.dt = dt;
    FitVideoTerms terms;
    obj.evaluate(t, p.data(), nullptr, {}, &terms);
    smooth[i] = terms.smooth;
  }
  EXPECT_GT(smooth[0], 0);
  EXPECT_NEAR(smooth[1], smooth[0], 1e-9 * smooth[0]);
  std::vector<FitVideoTargets> t = random_targets(obj, base, n, rng);
  t[1].dt = 0;
  test::expect_error([&] { obj.evaluate(t, base.data(), nullptr); }, {"time since the previous frame"});
}

TEST(FitVideoWorldInit, RotationBetweenTurnsOneDirectionOntoTheOther) {
  const Vec3d pairs[][2] = {{{1, 0, 0}, {0, 1, 0}}, {{0.3, -0.2, 0.9}, {-0.5, 0.1, 0.4}}, {{0, 0, 1}, {0, 0, 2}},
                            {{0, 1, 0}, {0, -3, 0}}, {{1, 2, 3}, {-1, -2, -3}}};
  for (const auto& ab : pairs) {
    const Vec3d w = rotation_between(ab[0], ab[1]);
    const Vec3d r = rodrigues(w) * (ab[0] / norm(ab[0]));
    EXPECT_LT(norm(r - ab[1] / norm(ab[1])), 1e-9) << ab[0].x << " " << ab[1].x;
  }
}

TEST(FitVideoWorldInit, ExactWorldPointsGiveTheOrientAndEveryLimbDirection) {
  const BodyModel& b = procedural();
  const std::vector<FitVideoPoint> pts = fit_video_points(b);
  const CameraT<double> cam = rotated_camera();
  const FitVideoObjective<double> obj(b, pts, cam, 0, FitVideoWeights{});
  // A pose with the spine straight (the torso then turns with the global orient alone).
  std::vector<double> truth(kFitVideoFrameParams, 0.0);
  const Vec3d orient = matrix_to_axis_angle(rodrigues(Vec3d(3.0, 0, 0)) * rodrigues(Vec3d(0, 2.4, 0)));  // facing away
  for (int c = 0; c < 3; ++c) truth[size_t(c)] = orient[c];
  const int limbs[] = {16, 17, 18, 19, 1, 2, 4, 5};
  std::mt19937 rng(29);
  std::normal_distribution<double> g(0.0, 0.5);
  for (int j : limbs)
    for (int c = 0; c < 3; ++c) truth[size_t(3 * j + c)] = g(rng);
  truth[kFitVideoPoseValues + 2] = 3;
  FitVideoTargets tg;
  tg.vis.assign(pts.size(), 1.0);
  tg.world = exact_world(obj, b, cam, truth.data(), nullptr, 0);
  std::vector<float> rest_v(size_t(b.num_verts) * 3), rest_j(size_t(kNumJoints) * 3);
  Lbs<float>(b).forward(SmplxParams{}, rest_v.data(), rest_j.data(), nullptr);
  std::vector<float> q(kFitVideoFrameParams, 0.0f);
  ASSERT_TRUE(init_pose_from_world(b, pts, tg, rest_j, cam.R, 0.5, q.data()));
  const Mat3<double> R0 = rodrigues(Vec3d(q[0], q[1], q[2])), Rt = rodrigues(orient);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(R0(r, c), Rt(r, c), 1e-5);
  const std::vector<double> qd(q.begin(), q.end());
  const std::vector<double> got = exact_world(obj, b, cam, qd.data(), nullptr, 0);
  for (const FitVideoBone& bone : fit_video_bones(pts)) {
    auto dir = [&](const std::vector<double>& w) {
      const Vec3d d = Vec3d::load(&w[size_t(3 * bone.b)]) - Vec3d::load(&w[size_t(3 * bone.a)]);
      return d / norm(d);
    };
    EXPECT_LT(norm(dir(got) - dir(tg.world)), 1e-5) << pts[size_t(bone.a)].name << " -> " << pts[size_t(bone.b)].name;
  }
  // Without world points, or with a torso point unseen: nothing set (the 2D search runs).
  std::vector<float> untouched(kFitVideoFrameParams, 0.5f);
  FitVideoTargets none = tg;
  none.world.clear();
  EXPECT_FALSE(init_pose_from_world(b, pts, none, rest_j, cam.R, 0.5, untouched.data()));
  none = tg;
  none.vis[0] = 0.2;  // the left shoulder
  EXPECT_FALSE(init_pose_from_world(b, pts, none, rest_j, cam.R, 0.5, untouched.data()));
  for (float x : untouched) EXPECT_EQ(x, 0.5f);
}

TEST(FitVideoPoints, ProceduralBodyPointsSitWhereTheirNamesSay) {
  const BodyModel& b = procedural();
  const std::vector<FitVideoPoint> pts = fit_video_points(b);
  std::vector<float> v(size_t(b.num_verts) * 3), j(size_t(kNumJoints) * 3);
  Lbs<float>(b).forward(SmplxParams{}, v.data(), j.data(), nullptr);
  auto at = [&](int blaze) {
    for (const FitVideoPoint& p : pts)
      if (p.blazepose == blaze) return p.joint >= 0 ? Vec3d(j[3 * p.joint], j[3 * p.joint + 1], j[3 * p.joint + 2])
                                                    : Vec3d(v[3 * p.vertex], v[3 * p.vertex + 1], v[3 * p.vertex + 2]);
    ADD_FAILURE() << "no point " << blaze;
    return Vec3d(0, 0, 0);
  };
  EXPECT_EQ(pts.size(), 21u);
  const Vec3d nose = at(bp::nose), le = at(bp::left_eye), re = at(bp::right_eye), lear = at(bp::left_ear), rear = at(bp::right_ear);
  const Vec3d head(j[3 * 15], j[3 * 15 + 1], j[3 * 15 + 2]);
  EXPECT_GT(nose.z, le.z);                 // the nose in front of the eyes
  EXPECT_LT(nose.y, le.y);                 // and below them
  EXPECT_GT(le.x, 0.01);                   // left = +x
  EXPECT_LT(re.x, -0.01);
  EXPECT_GT(lear.x, le.x + 0.03);          // ears outside the eyes
  EXPECT_LT(rear.x, re.x - 0.03);
  EXPECT_LT(lear.z, le.z - 0.03);          // and behind them
  EXPECT_GT(nose.y, head.y - 0.05);
  for (int side = 0; side < 2; ++side) {
    const Vec3d heel = at(side ? bp::right_heel : bp::left_heel), toe = at(side ? bp::right_foot_index : bp::left_foot_index);
    const Vec3d ankle = at(side ? bp::right_ankle : bp::left_ankle);
    EXPECT_LT(heel.z, ankle.z);
    EXPECT_GT(toe.z, ankle.z + 0.08);
    EXPECT_LT(heel.y, ankle.y);
    EXPECT_LT(toe.y, ankle.y);
    EXPECT_EQ(heel.x > 0, side == 0);
    EXPECT_EQ(toe.x > 0, side == 0);
  }
  double hips = 0;
  for (const FitVideoPoint& p : pts)
    if (p.blazepose == bp::left_hip) hips = p.weight;
  EXPECT_LT(hips, 1.0);  // down-weighted
}

// A person frame of the procedural body facing the camera.
KeypointsFrame person_frame(const std::string& name, double dx = 0, double yaw = 0) {
  static const std::vector<FitVideoPoint> pts = fit_video_points(procedural());
  static const Lbs<double> lbs(procedural());
  Camera cam;
  cam.width = 256, cam.height = 256, cam.fx = cam.fy = 250, cam.cx = cam.cy = 128;
  SmplxParams p;
  const Vec3d w = matrix_to_axis_angle(rodrigues(Vec3d(3.14159265358979, 0, 0)) * rodrigues(Vec3d(0, yaw, 0)));
  for (int c = 0; c < 3; ++c) p.pose[size_t(c)] = float(w[c]);
  p.transl = {float(dx), 0.3f, 3.5f};
  std::mt19937 rng(1);
  test::SyntheticKeypointOptions o;
  o.dropout = 0;
  return test::synthetic_keypoints(lbs, pts, p, cam, name, o, rng);
}

TEST(FitVideoFrames, DropsNobodyCutOffLowScoreAndSceneCutsWithReasons) {
  std::vector<FitVideoInputFrame> f(7);
  f[0].keypoints = person_frame("a.png");
  f[1].keypoints = person_frame("b.png", 0.02);
  f[2].keypoints = person_frame("c.png");
  f[2].keypoints.people = 0, f[2].keypoints.body.clear();  // nobody
  f[3].keypoints = person_frame("d.png", 3.0);               // walked out of view (to the right)
  f[4].keypoints = person_frame("e.png", 0.04);
  f[5].keypoints = person_frame("f.png", -1.2);              // a jump of more than a torso: cut
  f[6].keypoints = person_frame("g.png", -1.2);
  f[6].keypoints.score = 0.2;
  const FitVideoSelection s = select_video_frames(f, fit_video_points(procedural()), FitVideoOptions{});
  EXPECT_EQ(s.reason[0], "");
  EXPECT_EQ(s.reason[1], "");
  EXPECT_EQ(s.reason[2], "nobody in the frame");
  EXPECT_EQ(s.reason[3].rfind("person cut off", 0), 0u) << s.reason[3];
  EXPECT_EQ(s.reason[4], "");
  EXPECT_EQ(s.reason[5].rfind("scene cut", 0), 0u) << s.reason[5];
  EXPECT_EQ(s.reason[6].rfind("low detection score", 0), 0u) << s.reason[6];
  EXPECT_EQ(s.kept, (std::vector<int>{0, 1, 4}));
  ASSERT_EQ(s.targets.size(), 3u);
  EXPECT_FALSE(s.targets[0].linked);
  EXPECT_TRUE(s.targets[1].linked);
  EXPECT_FALSE(s.targets[2].linked);  // frames 2, 3 dropped between
}

TEST(FitVideoFrames, PointsOutsideTheFrameCountAsInvisible) {
  std::vector<FitVideoInputFrame> f(1);
  f[0].keypoints = person_frame("a.png");
  f[0].keypoints.body[bp::left_ankle].x = -10;
  const std::vector<FitVideoPoint> pts = fit_video_points(procedural());
  const FitVideoSelection s = select_video_frames(f, pts, FitVideoOptions{});
  ASSERT_EQ(s.kept.size(), 1u);
  for (size_t k = 0; k < pts.size(); ++k)
    EXPECT_EQ(s.targets[0].vis[k] == 0.0, pts[k].blazepose == bp::left_ankle) << pts[k].name;
}

TEST(FitVideo, ReportsEveryFrameAndFitsOnlyTheKeptOnes) {
  std::vector<FitVideoInputFrame> f(4);
  f[0].keypoints = person_frame("a.png", 0.0, 0.3);
  f[1].keypoints = person_frame("b.png");
  f[1].keypoints.people = 0, f[1].keypoints.body.clear();
  f[2].keypoints = person_frame("c.png", 4.0);
  f[3].keypoints = person_frame("d.png", 0.02, 0.3);
  FitVideoOptions o;
  o.progress = false;
  o.focal_px = 250;
  o.iters_global = 10, o.iters_body = 10;
  const FitVideoResult r = fit_video(procedural(), f, o);
  ASSERT_EQ(r.report.size(), 4u);
  EXPECT_EQ(r.kept, (std::vector<int>{0, 3}));
  EXPECT_EQ(r.params.size(), 2u);
  EXPECT_EQ(r.report[1].reason, "nobody in the frame");
  EXPECT_TRUE(r.report[2].dropped);
  EXPECT_EQ(r.report[2].reason.rfind("person cut off", 0), 0u);
  for (int i : {0, 3}) {
    EXPECT_FALSE(r.report[size_t(i)].dropped);
    EXPECT_EQ(r.report[size_t(i)].frame, f[size_t(i)].keypoints.frame);
    EXPECT_TRUE(std::isfinite(r.report[size_t(i)].reprojection_px));
    EXPECT_TRUE(std::isnan(r.report[size_t(i)].silhouette_iou));  // no mask
  }
  EXPECT_EQ(r.camera.fx, 250.0f);
  EXPECT_EQ(r.camera.cx, 128.0f);
  EXPECT_EQ(r.camera.t.z, 0.0f);
  for (const SmplxParams& p : r.params) {
    for (float x : p.pose) ASSERT_TRUE(std::isfinite(x));
    EXPECT_EQ(p.betas, r.params[0].betas);  // shared
    EXPECT_GT(p.transl[2], 1.0f);           // in front of the camera
  }
  // Focal from the field of view: 90 degrees over 256 px is 128 px.
  o.focal_px = 0, o.fov_deg = 90;
  o.iters_global = o.iters_body = 0;
  EXPECT_NEAR(fit_video(procedural(), f, o).camera.fx, 128.0f, 1e-3);
}

TEST(FitVideo, InconsistentInputThrows) {
  FitVideoOptions o;
  o.progress = false;
  std::vector<FitVideoInputFrame> f(2);
  f[0].keypoints = person_frame("a.png");
  f[1].keypoints = person_frame("b.png");
  f[1].keypoints.width = 300;
  test::expect_error([&] { fit_video(procedural(), f, o); }, "b.png: frame is 300 x 256, the first frame 256 x 256");
  f[1].keypoints.width = 256;
  f[1].mask = Image(10, 10, 1);
  test::expect_error([&] { fit_video(procedural(), f, o); }, "b.png: mask is 10 x 10");
  for (FitVideoInputFrame& x : f) x.keypoints.people = 0, x.keypoints.body.clear(), x.mask = Image();
  test::expect_error([&] { fit_video(procedural(), f, o); }, "no frame with a person");
  test::expect_error([&] { fit_video(procedural(), {}, o); }, "no frames");
}

TEST(FitVideo, InterruptStopsTheFitWithOneLine) {
  std::vector<FitVideoInputFrame> f(1);
  f[0].keypoints = person_frame("a.png");
  FitVideoOptions o;
  o.progress = false;
  request_interrupt();  // what SIGINT does (core/interrupt.h)
  test::expect_error([&] { fit_video(procedural(), f, o); }, {"interrupted"});
  clear_interrupt();
  o.iters_global = o.iters_body = 1;
  EXPECT_EQ(fit_video(procedural(), f, o).kept.size(), 1u);
}

TEST(FitVideo, SyntheticKeypointsRoundTripThroughTheJsonContract) {
  const KeypointsFrame k = person_frame("a.png");
  const KeypointsFrame r = parse_keypoints_json(test::keypoints_json(k), "a.json");
  ASSERT_EQ(r.body.size(), k.body.size());
  for (size_t i = 0; i < k.body.size(); ++i) {
    EXPECT_NEAR(r.body[i].x, k.body[i].x, 1e-4);
    EXPECT_NEAR(r.body[i].y, k.body[i].y, 1e-4);
  }
  ASSERT_EQ(r.body_world.size(), k.body_world.size());  // the fixture's world points, 33
  for (size_t i = 0; i < k.body_world.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.body_world[i][size_t(c)], k.body_world[i][size_t(c)], 1e-5);
  EXPECT_EQ(r.frame, "a.png");
}

}  // namespace
}  // namespace haha
