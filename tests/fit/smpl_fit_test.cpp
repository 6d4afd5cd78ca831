// SMPL -> SMPL-X fitting (fit/smpl_fit.h) against an SMPL-layout stand-in of the procedural
// body with known offsets (template shift and shape, body/smpl_standin.h): the fit must
// recover them to < 5 mm, from the SMPL angles and from a perturbed start.
#include "fit/smpl_fit.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "body/smpl_standin.h"
#include "io/smpl_model_io.h"
#include "support/expect_error.h"

namespace haha {
namespace {

const BodyModel& smplx() {
  static const BodyModel b = make_procedural_body({BodyResolution::low, 5});
  return b;
}

const std::vector<float> kStandinBetas = {0.8f, -0.6f, 0.5f, 0.0f, 0.4f, 0.0f, -0.3f, 0.2f};
const std::array<float, 3> kShift = {0.012f, -0.025f, 0.018f};  // metres: more than stage 1 moves

struct Standin {
  BodyModel model;
  std::vector<int32_t> corr;
};

// Made, written in the SMPL file layout and read back (exercises io/smpl_model_io too).
const Standin& standin() {
  static const Standin s = [] {
    SmplStandinOptions o;
    o.betas = kStandinBetas;
    o.shift = kShift;
    Standin r;
    const BodyModel m = make_smpl_standin(smplx(), o, &r.corr);
    const std::string path = (std::filesystem::temp_directory_path() / ("smpl_standin_" + std::to_string(::getpid()) + ".npz")).string();
    save_smpl_model(m, path);
    r.model = load_smpl_model(path);
    std::filesystem::remove(path);
    return r;
  }();
  return s;
}

std::vector<SmplxParams> smpl_frames(int n, uint32_t seed, const std::vector<float>& betas) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 0.25);
  std::vector<SmplxParams> out;
  for (int f = 0; f < n; ++f) {
    double pose[72] = {}, t[3];
    for (int k = 0; k < 66; ++k) pose[k] = g(rng);
    pose[1] += 3.0 * g(rng);  // any heading
    for (double& x : t) x = 2 * g(rng);
    out.push_back(smpl_params(pose, betas, t));
  }
  return out;
}

TEST(SmplFit, StandinFileHasSmplLayoutAndPosesLikeTheShiftedShapedSmplx) {
  const Standin& s = standin();
  EXPECT_LT(s.model.num_verts, smplx().num_verts);  // eye-only vertices dropped
  EXPECT_EQ(s.corr.size(), size_t(s.model.num_verts));
  EXPECT_EQ(s.model.num_shape, 10);
  // Same pose, shape b* + b_s and transl + shift: the same body (hands at rest).
  const std::vector<SmplxParams> f = smpl_frames(1, 3, {0.3f, 0.2f});
  SmplxParams x = f[0];
  x.betas = kStandinBetas;
  x.betas[0] += 0.3f, x.betas[1] += 0.2f;
  for (int c = 0; c < 3; ++c) x.transl[size_t(c)] += kShift[size_t(c)];
  const Lbs<double> ls(s.model), lx(smplx());
  std::vector<double> vs(size_t(s.model.num_verts) * 3), vx(size_t(smplx().num_verts) * 3);
  ls.forward(f[0], vs.data(), nullptr, nullptr);
  lx.forward(x, vx.data(), nullptr, nullptr);
  double worst = 0;
  for (size_t v = 0; v < s.corr.size(); ++v)
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(vs[3 * v + size_t(c)] - vx[3 * size_t(s.corr[v]) + size_t(c)]));
  EXPECT_LT(worst, 1e-4);  // float model files
}

void expect_recovered(const SmplFitResult& r, const std::vector<SmplxParams>& frames, const std::vector<float>& smpl_betas,
                      bool vertices) {
  ASSERT_EQ(r.frames.size(), frames.size());
  for (size_t f = 0; f < frames.size(); ++f) {
    std::printf("frame %zu: joints %.2f mm, vertices %.2f mm\n", f, r.joint_mm[f], vertices ? r.vertex_mm[f] : -1.0);
    EXPECT_LT(r.joint_mm[f], 5.0) << f;
    if (vertices) {
      EXPECT_LT(r.vertex_mm[f], 5.0) << f;
    }
    double dt = 0;
    for (int c = 0; c < 3; ++c) dt += std::pow(r.frames[f].transl[size_t(c)] - (frames[f].transl[size_t(c)] + kShift[size_t(c)]), 2);
    EXPECT_LT(std::sqrt(dt), 0.005) << "frame " << f << ": transl does not carry the template shift";
    for (int k = 66; k < kNumPoseValues; ++k) EXPECT_EQ(r.frames[f].pose[size_t(k)], 0.0f);  // hands, face at rest
  }
  if (!vertices) return;
  // The shape offset: the fitted betas' rest body against the stand-in's (shape b* + b_s;
  // some shape directions of the procedural body are nearly collinear, so the betas
  // themselves are not unique, the surface is).
  SmplxParams want;
  want.betas = kStandinBetas;
  for (size_t k = 0; k < smpl_betas.size(); ++k) want.betas[k] += smpl_betas[k];
  SmplxParams got;
  got.betas = r.frames[0].betas;
  const Lbs<double> lx(smplx());
  std::vector<double> a(size_t(smplx().num_verts) * 3), b(a.size());
  lx.forward(want, a.data(), nullptr, nullptr);
  lx.forward(got, b.data(), nullptr, nullptr);
  double worst = 0;
  for (size_t v = 0; v < a.size() / 3; ++v)
    worst = std::max(worst, std::hypot(a[3 * v] - b[3 * v], a[3 * v + 1] - b[3 * v + 1], a[3 * v + 2] - b[3 * v + 2]));
  std::printf("rest shape: worst vertex %.2f mm\n", worst * 1000);
  EXPECT_LT(worst, 0.005) << "rest shape off by " << worst * 1000 << " mm";
}

TEST(SmplFit, RecoversTemplateShiftAndShapeWithVertices) {
  const std::vector<float> sb = {0.3f, 0.2f};
  const std::vector<SmplxParams> frames = smpl_frames(4, 11, sb);
  SmplFitOptions o;
  o.progress = false;
  const SmplFitResult r = fit_smplx_to_smpl(standin().model, smplx(), standin().corr, frames, {}, o);
  expect_recovered(r, frames, sb, true);
  // The copy that `convert` used to do (SMPL numbers into SMPL-X) is centimetres off.
  const SmplFitResult copy = [&] {
    SmplFitOptions z = o;
    z.iterations = 0;
    std::vector<SmplxParams> init = frames;
    for (auto& p : init) p.betas.clear();
    return fit_smplx_to_smpl(standin().model, smplx(), standin().corr, frames, init, z);
  }();
  EXPECT_GT(copy.vertex_mm[0], 15.0);
}

TEST(SmplFit, ConvergesFromAPerturbedStart) {
  const std::vector<SmplxParams> frames = smpl_frames(3, 12, {});
  std::vector<SmplxParams> init = frames;
  std::mt19937 rng(4);
  std::normal_distribution<float> g(0.0f, 0.15f);
  for (auto& p : init) {
    p.betas.clear();
    for (int k = 0; k < 66; ++k) p.pose[size_t(k)] += g(rng);
    for (float& t : p.transl) t += g(rng) * 0.2f;
  }
  SmplFitOptions o;
  o.progress = false;
  o.iterations = 1000;
  expect_recovered(fit_smplx_to_smpl(standin().model, smplx(), standin().corr, frames, init, o), frames, {}, true);
}

TEST(SmplFit, JointsOnlyWithoutCorrespondence) {
  const std::vector<SmplxParams> frames = smpl_frames(3, 13, {});
  SmplFitOptions o;
  o.progress = false;
  const SmplFitResult r = fit_smplx_to_smpl(standin().model, smplx(), {}, frames, {}, o);
  EXPECT_TRUE(r.vertex_mm.empty());
  expect_recovered(r, frames, {}, false);
}

TEST(SmplFit, BadInputs) {
  using test::expect_error;
  const std::vector<SmplxParams> frames = smpl_frames(1, 1, {});
  expect_error([&] { fit_smplx_to_smpl(standin().model, smplx(), {1, 2, 3}, frames); }, {"correspondence", "entries"});
  expect_error([&] { fit_smplx_to_smpl(standin().model, smplx(), standin().corr, {}); }, {"no frames"});
}

}  // namespace
}  // namespace haha
