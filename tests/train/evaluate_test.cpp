// Evaluation: metrics of the stage-table variants, test-time pose optimisation, storage,
// body regions.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "train/evaluate.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

using test::scene_body;
using test::scene_frames;
using test::scene_truth;

TEST(Evaluate, TheRenderingAvatarScoresPerfectlyAndLayersMatter) {
  const Avatar a = scene_truth();
  const std::vector<TrainFrame> f = scene_frames(a, 3);
  EvalOptions o;
  o.tto_steps = 0;
  o.premultiplied = true;
  o.keep_images = 1;
  const VariantEval both = evaluate_variant({"haha", &a, true, true}, f, o);
  const VariantEval mesh = evaluate_variant({"mesh", &a, true, false}, f, o);
  ASSERT_EQ(both.frames.size(), 3u);
  EXPECT_GT(both.psnr, 60.0);  // same renderer, same pose: equal images (PSNR may be +inf)
  EXPECT_NEAR(both.ssim, 1.0, 1e-6);
  EXPECT_LT(mesh.psnr, 40.0);  // the "hair" Gaussians are missing
  EXPECT_LT(mesh.ssim, both.ssim);
  // The missing hair sits at the outline: the band's PSNR is below the whole frame's.
  EXPECT_GT(both.psnr_outline, 60.0);
  EXPECT_TRUE(std::isfinite(mesh.psnr_outline));
  EXPECT_LT(mesh.psnr_outline, mesh.psnr);
  EXPECT_EQ(both.num_gaussians, a.gaussians.size());
  EXPECT_EQ(mesh.num_gaussians, 0);
  EXPECT_LT(both.lpips, 0.0);  // no LPIPS network: unavailable
  EXPECT_EQ(both.frames[0].image.size(), size_t(40 * 40 * 3));
  EXPECT_TRUE(both.frames[1].image.empty());  // only keep_images frames keep pictures
  EXPECT_GT(both.render_ms, 0.0);
}

TEST(Evaluate, PersonPsnrIsOverTheMattesPixelsOnly) {
  const Avatar a = scene_truth();
  std::vector<TrainFrame> f = scene_frames(a, 2);
  EvalOptions o;
  o.tto_steps = 0;
  o.premultiplied = true;
  const EvalVariant mesh{"mesh", &a, true, false};
  const VariantEval plain = evaluate_variant(mesh, f, o);
  // The missing hair lies on the person, the matching background does not count.
  ASSERT_TRUE(std::isfinite(plain.psnr_person));
  EXPECT_LT(plain.psnr_person, plain.psnr - 1.0);
  // A wrong background pixel (mask 0) changes the whole frame's PSNR, not the person's.
  size_t bg = 0;
  while (bg < f[0].mask.size() && f[0].mask[bg] > 0) ++bg;
  ASSERT_LT(bg, f[0].mask.size());
  for (int c = 0; c < 3; ++c) f[0].rgb[3 * bg + size_t(c)] = 1.0f;
  const VariantEval off = evaluate_variant(mesh, f, o);
  EXPECT_LT(off.frames[0].psnr, plain.frames[0].psnr);
  EXPECT_DOUBLE_EQ(off.frames[0].psnr_person, plain.frames[0].psnr_person);
  // It is the PSNR over mask > 0.5, a hard cut: a matte of 0.4 everywhere has no person.
  for (TrainFrame& x : f) x.mask.assign(x.mask.size(), 0.4f);
  const VariantEval none = evaluate_variant(mesh, f, o);
  EXPECT_TRUE(std::isnan(none.psnr_person));
  EXPECT_TRUE(std::isnan(none.frames[1].psnr_person));
}

TEST(Evaluate, PartPsnrIsOverThePartsPixelsOnly) {
  const Avatar a = scene_truth();
  std::vector<TrainFrame> f = scene_frames(a, 2);
  EvalOptions o;
  o.tto_steps = 0;
  o.premultiplied = true;
  const EvalVariant mesh{"mesh", &a, true, false};
  EXPECT_TRUE(std::isnan(evaluate_variant(mesh, f, o).psnr_part));  // no part given
  // The person's pixels: the missing hair is there, the matching background is not.
  for (TrainFrame& x : f) x.part = x.mask;
  const VariantEval person = evaluate_variant(mesh, f, o);
  ASSERT_TRUE(std::isfinite(person.psnr_part));
  EXPECT_LT(person.psnr_part, person.psnr - 1.0);
  EXPECT_TRUE(std::isfinite(person.frames[1].psnr_part));
  // Transmittance: the person's pixels are covered but for the missing hair's, the
  // background's not at all.
  EXPECT_LT(person.transmittance_part, 0.25);
  EXPECT_GE(person.transmittance_part, 0.0);
  std::vector<TrainFrame> g = f;
  for (TrainFrame& x : g)
    for (float& m : x.part) m = 1 - m;
  EXPECT_GT(evaluate_variant(mesh, g, o).transmittance_part, 0.95);
  // A frame without the part's pixels does not count in the mean.
  f[1].part.assign(f[1].part.size(), 0.0f);
  const VariantEval one = evaluate_variant(mesh, f, o);
  EXPECT_TRUE(std::isnan(one.frames[1].psnr_part));
  EXPECT_DOUBLE_EQ(one.psnr_part, one.frames[0].psnr_part);
  f[0].part.resize(3);
  EXPECT_THROW(evaluate_variant(mesh, f, o), Error);
}

// One frame of the scene whose fitted translation is off by 2 cm / -1 cm (the pose to recover).
std::vector<TrainFrame> shifted_frames(const Avatar& a, int size) {
  std::vector<TrainFrame> f = scene_frames(a, 1, size);
  for (TrainFrame& x : f) {
    x.params.transl[0] += 0.02f;
    x.params.transl[1] -= 0.01f;
  }
  return f;
}

TEST(Evaluate, TestTimePoseOptimisationRecoversAShiftedPose) {
  const Avatar a = scene_truth();
  const std::vector<TrainFrame> f = shifted_frames(a, 40);
  EvalOptions o;
  o.premultiplied = true;
  o.tto_steps = 0;
  const VariantEval before = evaluate_variant({"haha", &a, true, true}, f, o);
  o.tto_steps = 30;
  o.lr_pose = 1e-3;
  const VariantEval after = evaluate_variant({"haha", &a, true, true}, f, o);
  EXPECT_GT(after.psnr, before.psnr + 2.0);  // measured: +3.4 dB
  for (const FrameEval& fe : after.frames) EXPECT_LT(fe.tto_loss_end, fe.tto_loss_start);
}

TEST(Evaluate, CoarseToFinePoseOptimisationRecoversTheShift) {
  // The same shifted pose on 64-px frames, three quarters of the steps at 32 px: it still
  // recovers most of the shift, and the losses it reports are the scored size's, the end
  // never above the start.
  const Avatar a = scene_truth();
  const std::vector<TrainFrame> f = shifted_frames(a, 64);
  EvalOptions o;
  o.premultiplied = true;
  o.tto_steps = 0;
  const VariantEval before = evaluate_variant({"haha", &a, true, true}, f, o);
  o.tto_steps = 40;
  o.lr_pose = 1e-3;
  const VariantEval full = evaluate_variant({"haha", &a, true, true}, f, o);
  o.tto_resolution = 32;
  const VariantEval c2f = evaluate_variant({"haha", &a, true, true}, f, o);
  EXPECT_GT(c2f.psnr, before.psnr + 2.0);
  EXPECT_GT(c2f.psnr, full.psnr - 1.0);
  EXPECT_NEAR(c2f.frames[0].tto_loss_start, full.frames[0].tto_loss_start, 1e-9);  // both at 64 px
  EXPECT_LT(c2f.frames[0].tto_loss_end, c2f.frames[0].tto_loss_start);
  for (const VariantEval& r : {full, c2f}) EXPECT_LE(r.frames[0].tto_loss_end, r.frames[0].tto_loss_start);
}

TEST(Evaluate, FixedPosesScoreEveryVariantAtTheSamePose) {
  // The full Gaussians find the shifted pose; the mesh, given those poses, scores as if its
  // frames had been fitted exactly there, with no optimisation of its own.
  const Avatar a = scene_truth();
  const std::vector<TrainFrame> f = shifted_frames(a, 40);
  EvalOptions o;
  o.premultiplied = true;
  o.tto_steps = 30;
  o.lr_pose = 1e-3;
  const VariantEval gs = evaluate_variant({"full", &a, false, true}, f, o);
  ASSERT_EQ(gs.poses.size(), f.size());
  EXPECT_GT(std::abs(gs.poses[0].transl[0] - f[0].params.transl[0]), 1e-3f);  // it moved
  o.poses = &gs.poses;
  const VariantEval mesh = evaluate_variant({"mesh", &a, true, false}, f, o);
  EXPECT_EQ(mesh.frames[0].tto_loss_start, 0.0);  // no optimisation ran
  EXPECT_EQ(mesh.poses[0].transl, gs.poses[0].transl);
  std::vector<TrainFrame> at = f;
  at[0].params.pose = gs.poses[0].pose;
  at[0].params.transl = gs.poses[0].transl;
  EvalOptions fixed = o;
  fixed.poses = nullptr;
  fixed.tto_steps = 0;
  EXPECT_DOUBLE_EQ(mesh.psnr, evaluate_variant({"mesh", &a, true, false}, at, fixed).psnr);
  const std::vector<SmplxParams> wrong(2);
  o.poses = &wrong;
  EXPECT_THROW(evaluate_variant({"mesh", &a, true, false}, f, o), Error);  // one pose per frame
}

TEST(Evaluate, CoverageOracleCutsTheMeshToTheTrueMatte) {
  const Avatar a = scene_truth();
  std::vector<TrainFrame> f = scene_frames(a, 1);
  EvalOptions o;
  o.tto_steps = 0;
  o.premultiplied = true;
  o.keep_images = 1;
  const VariantEval plain = evaluate_variant({"haha", &a, true, true}, f, o);
  o.coverage_oracle = EvalOptions::CoverageOracle::pixel;
  // The matte is the avatar's own silhouette: nothing to cut, the same image.
  const VariantEval same = evaluate_variant({"haha", &a, true, true}, f, o);
  EXPECT_EQ(same.frames[0].image, plain.frames[0].image);
  // A matte cut in half: the mesh vanishes from the other half, only Gaussians remain there,
  // and the Gaussians its depth test hid there show.
  const int W = f[0].camera.width, H = f[0].camera.height;
  for (int y = 0; y < H; ++y)
    for (int x = W / 2; x < W; ++x) f[0].mask[size_t(y * W + x)] = 0;
  const VariantEval cut = evaluate_variant({"mesh", &a, true, false}, f, o);
  const VariantEval both = evaluate_variant({"haha", &a, true, true}, f, o);
  double right_mesh = 0, left_mesh = 0, right_both = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) {
        const size_t i = 3 * size_t(y * W + x) + c;
        (x >= W / 2 ? right_mesh : left_mesh) += cut.frames[0].image[i];
        if (x >= W / 2) right_both += both.frames[0].image[i];
      }
  EXPECT_EQ(right_mesh, 0.0);  // black background where the matte is 0
  EXPECT_GT(left_mesh, 1.0);
  EXPECT_GT(right_both, 0.1);  // the hair Gaussians on that side are no longer hidden
}

TEST(Evaluate, TexelCoverageOracleFadesTexelsThatFellOutsideTheMatte) {
  const Avatar a = scene_truth();
  std::vector<TrainFrame> f = scene_frames(a, 2);
  EvalOptions o;
  o.tto_steps = 0;
  o.premultiplied = true;
  o.keep_images = 1;
  o.coverage_oracle = EvalOptions::CoverageOracle::texel;
  // The true matte: every texel drawn inside it, none faded, the merge as without the oracle.
  const VariantEval mesh = evaluate_variant({"mesh", &a, true, false}, f, o);
  ASSERT_EQ(mesh.texel_coverage.size(), size_t(a.texture.width) * a.texture.height);
  for (float c : mesh.texel_coverage) ASSERT_EQ(c, 1.0f);
  o.texel_coverage = &mesh.texel_coverage;
  EvalOptions none = o;
  none.coverage_oracle = EvalOptions::CoverageOracle::none;
  EXPECT_EQ(evaluate_variant({"haha", &a, true, true}, f, o).frames[0].image,
            evaluate_variant({"haha", &a, true, true}, f, none).frames[0].image);
  // A matte without the right half: the texels drawn only there fade (0), the others stay;
  // the merge then shows less of the mesh on that side.
  const int W = f[0].camera.width, H = f[0].camera.height;
  for (TrainFrame& x : f)
    for (int y = 0; y < H; ++y)
      for (int c = W / 2; c < W; ++c) x.mask[size_t(y * W + c)] = 0;
  const VariantEval cut = evaluate_variant({"mesh", &a, true, false}, f, o);
  size_t faded = 0;
  for (float c : cut.texel_coverage) faded += c == 0.0f;
  EXPECT_GT(faded, 0u);
  EXPECT_LT(faded, cut.texel_coverage.size() / 2);
  o.texel_coverage = &cut.texel_coverage;
  const VariantEval merged = evaluate_variant({"haha", &a, true, true}, f, o);
  EXPECT_NE(merged.frames[0].image, evaluate_variant({"haha", &a, true, true}, f, none).frames[0].image);
  const std::vector<float> wrong(3, 1.0f);
  o.texel_coverage = &wrong;
  EXPECT_THROW(evaluate_variant({"haha", &a, true, true}, f, o), Error);
}

TEST(Evaluate, StorageCountsGaussiansAndTexture) {
  const Avatar a = scene_truth(32);
  const int64_t n = a.gaussians.size();
  EXPECT_EQ(storage_bytes(a, false, true), 60 * n);
  EXPECT_EQ(storage_bytes(a, true, false), 32 * 32 * 3);
  EXPECT_EQ(storage_bytes(a, true, true), 60 * n + 32 * 32 * 3);
}

TEST(Evaluate, MissingPiecesAreErrors) {
  Avatar a = scene_truth();
  const std::vector<TrainFrame> f = scene_frames(a, 1);
  EvalOptions o;
  o.tto_steps = 0;
  EXPECT_THROW(evaluate_variant({"x", nullptr, true, true}, f, o), Error);
  a.texture = Texture{};
  EXPECT_THROW(evaluate_variant({"x", &a, true, false}, f, o), Error);
  EXPECT_NO_THROW(evaluate_variant({"x", &a, false, true}, f, o));  // Gaussians need no texture
}

TEST(Regions, JointsMapToBodyRegions) {
  EXPECT_EQ(joint_region(15), BodyRegion::head);
  EXPECT_EQ(joint_region(22), BodyRegion::head);
  EXPECT_EQ(joint_region(0), BodyRegion::torso);
  EXPECT_EQ(joint_region(9), BodyRegion::torso);
  EXPECT_EQ(joint_region(18), BodyRegion::arms);
  EXPECT_EQ(joint_region(21), BodyRegion::arms);
  EXPECT_EQ(joint_region(25), BodyRegion::hands);
  EXPECT_EQ(joint_region(54), BodyRegion::hands);
  EXPECT_EQ(joint_region(4), BodyRegion::legs);
  EXPECT_EQ(joint_region(10), BodyRegion::feet);
  // Every region has faces on the procedural body, and the counts add up.
  const BodyModel& b = scene_body();
  const std::vector<BodyRegion> r = face_regions(b);
  ASSERT_EQ(int(r.size()), b.num_faces);
  BoundGaussians g;
  for (int f = 0; f < b.num_faces; ++f) g.face.push_back(f);
  const std::vector<int> c = gaussians_per_region(b, g);
  int total = 0;
  for (size_t k = 0; k < c.size(); ++k) {
    EXPECT_GT(c[k], 0) << region_name(BodyRegion(k));
    total += c[k];
  }
  EXPECT_EQ(total, b.num_faces);
  // The head is above the feet in the rest pose.
  double hy = 0, fy = 0;
  int hn = 0, fn = 0;
  for (int f = 0; f < b.num_faces; ++f) {
    const double y = b.v_template[3 * size_t(b.faces[3 * size_t(f)]) + 1];
    if (r[size_t(f)] == BodyRegion::head) hy += y, ++hn;
    if (r[size_t(f)] == BodyRegion::feet) fy += y, ++fn;
  }
  EXPECT_GT(hy / hn, fy / fn + 1.0);
}

}  // namespace
}  // namespace haha
