// The stage-1 pose-refinement gradient, end to end: pose / translation / betas -> LBS ->
// face frames -> Gaussian rasterizer -> merge -> image loss (L2 + SSIM + edge) + Dice.
//
// The trainer runs this chain in float through render_avatar (whose buffers, request and
// mesh renderer exist in float only, shared with the CUDA backend), so a finite-difference
// test of the trainer's own numbers could only be a loose float one. Instead:
//  1. the same chain is composed here from the double instantiations of its pieces (the
//     ones render_avatar calls) and its analytic gradient checked against central
//     differences in double, tightly;
//  2. the trainer's float gradients (its pose-gradient test hook, batch of 2 copies of one
//     frame) are compared element by element with that double gradient: frame groups get
//     1/2 of it (the batch mean over two frames, one of which is theirs), the shared betas
//     all of it. A gradient divided by the batch size twice is off by 2x here.
// The KNN regulariser is off (its sets come from a float KNN search and it is added once
// per batch, not per frame); LPIPS is off (no weights).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "body/face_frames.h"
#include "body/lbs.h"
#include "render/gaussian_raster.h"
#include "render/merge.h"
#include "train/losses.h"
#include "train/pose_groups.h"
#include "train/trainer.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

using test::scene_body;
using test::scene_config;
using test::scene_frames;
using test::scene_input;
using test::scene_truth;

using Vd = std::vector<double>;
Vd to_double(const std::vector<float>& v) { return Vd(v.begin(), v.end()); }

// All differentiable parameters of one frame, flattened: pose (165), transl (3), betas.
struct Params {
  Vd pose, transl, betas;
  explicit Params(const SmplxParams& p)
      : pose(p.pose.begin(), p.pose.end()), transl(p.transl.begin(), p.transl.end()),
        betas(p.betas.begin(), p.betas.end()) {}
  size_t size() const { return pose.size() + transl.size() + betas.size(); }
  double& operator[](size_t i) {
    if (i < pose.size()) return pose[i];
    i -= pose.size();
    return i < transl.size() ? transl[i] : betas[i - transl.size()];
  }
};

// The stage-1 chain of one frame in double (black background, as random_background=false).
struct Chain {
  const BodyModel& body = scene_body();
  Lbs<double> lbs{body};
  CameraT<double> cam;
  Vd gt, mask, offset, rotation, scale, color, opacity;
  std::vector<int32_t> face;
  double divisor = 1;
  LossWeights w;

  // L and, when `grad` is given, dL/d(params) (same layout as Params).
  double loss(Params& p, Vd* grad) {
    const int W = cam.width, H = cam.height, P = W * H, n = int(face.size());
    const SmplxView<double> v{p.pose.data(), p.betas.data(), int(p.betas.size()), nullptr, 0, p.transl.data()};
    LbsCache<double> cache;
    Vd verts(3 * size_t(body.num_verts));
    lbs.forward(v, verts.data(), nullptr, &cache);
    const GaussianLocalView<double> local{n, face.data(), offset.data(), rotation.data(), scale.data()};
    Vd means(3 * size_t(n)), quats(4 * size_t(n)), scales(3 * size_t(n));
    pose_gaussians(verts.data(), body.faces.data(), body.num_faces, divisor, local, means.data(), quats.data(),
                   scales.data());
    GaussianInputs<double> gi;
    gi.count = n;
    gi.means = means.data();
    gi.quats = quats.data();
    gi.scales = scales.data();
    gi.opacities = opacity.data();
    gi.colors = color.data();
    GaussianRasterSettings<double> rs;
    GaussianRasterState<double> st;
    Vd front(3 * static_cast<size_t>(P)), alpha(static_cast<size_t>(P)), image(3 * static_cast<size_t>(P));
    GaussianRasterOutputs<double> ro;
    ro.color = front.data();
    ro.alpha = alpha.data();
    rasterize_gaussians(gi, cam, rs, st, ro);
    MergeInputsT<double> mi;
    mi.num_pixels = P;
    mi.color_front = front.data();
    mi.alpha = alpha.data();
    merge(mi, image.data());

    Vd d_image(3 * static_cast<size_t>(P), 0.0), d_alpha(static_cast<size_t>(P), 0.0);
    double* gi_ptr = grad ? d_image.data() : nullptr;
    LossScratch<double> scratch;
    const double* none = nullptr;  // no pixel weights
    double L = w.l2 * l2_loss(image.data(), gt.data(), H, W, none, gi_ptr, w.l2);
    L += w.ssim * ssim_loss(image.data(), gt.data(), H, W, scratch, none, gi_ptr, w.ssim);
    L += w.sobel * edge_loss(image.data(), gt.data(), H, W, scratch, none, gi_ptr, w.sobel);
    L += w.dice * dice_loss(alpha.data(), mask.data(), P, grad ? d_alpha.data() : nullptr, w.dice);
    if (!grad) return L;

    Vd d_front(3 * static_cast<size_t>(P)), d_alpha_merge(static_cast<size_t>(P));
    MergeGradsT<double> mg;
    mg.color_front = d_front.data();
    mg.alpha = d_alpha_merge.data();
    merge_backward(mi, d_image.data(), mg);
    for (int q = 0; q < P; ++q) d_alpha[size_t(q)] += d_alpha_merge[size_t(q)];
    Vd d_means(3 * size_t(n)), d_quats(4 * size_t(n)), d_scales(3 * size_t(n)), d_verts(3 * size_t(body.num_verts), 0.0);
    GaussianRasterOutputGrads<double> dout;
    dout.color = d_front.data();
    dout.alpha = d_alpha.data();
    GaussianGrads<double> gg;
    gg.means = d_means.data();
    gg.quats = d_quats.data();
    gg.scales = d_scales.data();
    rasterize_gaussians_backward(gi, cam, rs, st, dout, gg);
    pose_gaussians_backward<double>(verts.data(), body.faces.data(), body.num_faces, divisor, local, d_means.data(),
                                    d_quats.data(), d_scales.data(), d_verts.data(), nullptr, nullptr, nullptr);
    SmplxGrad<double> sg = lbs.make_grad(v);
    lbs.backward(v, cache, d_verts.data(), nullptr, sg);
    grad->assign(p.size(), 0.0);
    for (size_t i = 0; i < sg.pose.size(); ++i) (*grad)[i] = sg.pose[i];
    for (size_t i = 0; i < 3; ++i) (*grad)[sg.pose.size() + i] = sg.transl[i];
    for (size_t i = 0; i < sg.betas.size(); ++i) (*grad)[sg.pose.size() + 3 + i] = sg.betas[i];
    return L;
  }
};

struct Fixture {
  TrainConfig cfg = scene_config(1, 0, 0);
  std::vector<TrainFrame> frames;
  Chain chain;
  Fixture() {
    cfg.random_background = false;
    cfg.s1.w.knn = 0;
    cfg.s1.refine_pose = true;
    cfg.batch = 2;
    // One frame, twice: a batch of 2 draws each copy once.
    TrainFrame f = scene_frames(scene_truth(), 6, 40)[1];
    f.params.pose[3 * kJaw + 0] = 0.2f;  // jaw open: the fine group has something to move
    // Off the symmetric rest: at exactly zero tilt, mirror Gaussians tie in depth and a
    // perturbation of either sign swaps their blending order (a jump of ~1e-7 in L).
    f.params.pose[0] = 0.05f;
    f.params.pose[2] = -0.04f;
    frames = {f, f};
    frames[1].name = "copy";
  }
};

void fill_chain(Fixture& s, const Avatar& a) {
  Chain& c = s.chain;
  const TrainFrame& f = s.frames[0];
  c.cam = f.camera.cast<double>();
  c.gt = to_double(f.rgb);  // premultiplied on black: the ground truth as it is
  c.mask = to_double(f.mask);
  const BoundGaussians& g = a.gaussians;
  c.face = g.face;
  c.offset = to_double(g.offset);
  c.rotation = to_double(g.rotation);
  c.scale = to_double(g.scale);
  c.color = to_double(g.color);
  c.opacity = to_double(g.opacity);
  c.divisor = a.face_scale_divisor;
  c.w = s.cfg.s1.w;  // as the trainer's effective weights: flags off = weight 0
  if (!s.cfg.use_sobel) c.w.sobel = 0;
  if (!s.cfg.use_dice) c.w.dice = 0;
}

TEST(PoseChain, DoubleGradientMatchesCentralDifferences) {
  Fixture s;
  Trainer t(s.cfg, scene_input(s.frames));
  fill_chain(s, t.avatar());
  Params p(s.frames[0].params);
  Vd grad;
  s.chain.loss(p, &grad);
  // Coordinates: global orient, spine, left shoulder, jaw, a left-hand finger, the
  // translation, two betas; then random directions over everything.
  const size_t np = p.pose.size();
  const std::vector<size_t> coords = {0,          1,          3 * 3 + 0, 3 * 16 + 2, 3 * kJaw + 0, 3 * kLeftHandFirst + 2,
                                     np + 0,     np + 2,     np + 3,    np + 4};
  // Small steps: the rasterizer's footprint, tile and alpha cuts move with the pose; at
  // h = 1e-5 some pixels already cross one (a jump); at 1e-6 and 1e-7 none does here.
  const double h = 1e-7;
  auto fd_along = [&](const Vd& d) {
    Params a = p, b = p;
    for (size_t i = 0; i < d.size(); ++i) a[i] += h * d[i], b[i] -= h * d[i];
    return (s.chain.loss(a, nullptr) - s.chain.loss(b, nullptr)) / (2 * h);
  };
  double gmax = 0;
  for (double x : grad) gmax = std::max(gmax, std::fabs(x));
  ASSERT_GT(gmax, 1e-4);  // the loss does depend on the pose
  int nonzero = 0;
  for (size_t i : coords) {
    Vd d(p.size(), 0.0);
    d[i] = 1;
    const double fd = fd_along(d);
    EXPECT_NEAR(grad[i], fd, 1e-6 * gmax + 1e-5 * std::fabs(fd)) << "parameter " << i;
    nonzero += std::fabs(grad[i]) > 1e-3 * gmax;
  }
  EXPECT_GE(nonzero, 7);  // most of the chosen coordinates matter
  std::mt19937 rng(3);
  std::normal_distribution<double> nd(0, 1);
  for (int r = 0; r < 3; ++r) {
    Vd d(p.size());
    double len = 0;
    for (double& x : d) x = nd(rng), len += x * x;
    for (double& x : d) x /= std::sqrt(len);  // unit length: the step stays h
    double an = 0;
    for (size_t i = 0; i < d.size(); ++i) an += grad[i] * d[i];
    const double fd = fd_along(d);
    EXPECT_NEAR(an, fd, 1e-6 * std::fabs(fd) + 1e-7) << "random direction " << r;
  }
}

TEST(PoseChain, TrainerGradientsAreThoseOfTheBatchMean) {
  Fixture s;
  Trainer t(s.cfg, scene_input(s.frames));
  fill_chain(s, t.avatar());
  Params p(s.frames[0].params);
  Vd grad;
  s.chain.loss(p, &grad);
  // The double gradient in the trainer's optimiser groups.
  SmplxGrad<double> sg;
  for (size_t i = 0; i < sg.pose.size(); ++i) sg.pose[i] = grad[i];
  for (size_t i = 0; i < 3; ++i) sg.transl[i] = grad[sg.pose.size() + i];
  std::vector<float> body(kPoseBodyGroup), fine(kPoseFineGroup);
  pose_to_groups(sg, body.data(), fine.data());
  const std::vector<float> betas(grad.begin() + std::ptrdiff_t(sg.pose.size() + 3), grad.end());

  std::map<std::string, std::vector<float>> got;
  t.set_pose_gradient_hook([&](const std::string& name, const std::vector<float>& g) { got[name] = g; });
  ASSERT_FALSE(t.step().skipped);
  ASSERT_EQ(got.size(), 5u);  // betas + both frames' two groups
  auto expect_scaled = [](const char* what, const std::vector<float>& trainer, const std::vector<float>& ref,
                          double k) {
    ASSERT_EQ(trainer.size(), ref.size()) << what;
    double rmax = 0;
    for (float x : ref) rmax = std::max(rmax, k * std::fabs(x));
    ASSERT_GT(rmax, 0) << what;
    // Float against double: measured at most 6.2e-6 of the largest value.
    for (size_t i = 0; i < ref.size(); ++i)
      EXPECT_NEAR(trainer[i], k * ref[i], 1e-4 * rmax) << what << " value " << i;
  };
  for (const char* frame : {"frame0", "frame1"}) {
    expect_scaled((std::string(frame) + ".body").c_str(), got.at(std::string(frame) + ".body"), body, 0.5);
    expect_scaled((std::string(frame) + ".fine").c_str(), got.at(std::string(frame) + ".fine"), fine, 0.5);
  }
  expect_scaled("betas", got.at("betas"), betas, 1.0);
}

}  // namespace
}  // namespace haha
