#include "train/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "body/lbs.h"
#include "core/error.h"
#include "render/avatar_render.h"
#include "train/adam.h"
#include "train/image_loss.h"
#include "train/levels.h"
#include "train/losses.h"
#include "train/outline_band.h"
#include "train/pose_groups.h"

namespace haha {

namespace {

bool finite_all(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

std::vector<EvalVariant> paper_variants(const Avatar& filtered, const Avatar& stage1) {
  return {{"mesh only", &filtered, true, false},
          {"full Gaussians", &stage1, false, true},
          {"naive merge", &stage1, true, true},
          {"HAHA filtered", &filtered, true, true}};
}

double variant_train_seconds(const std::array<double, 3>& s, size_t variant_index) {
  switch (variant_index) {
    case 0: return s[1];
    case 1: return s[0];
    case 2: return s[0] + s[1];
    default: return s[0] + s[1] + s[2];
  }
}

EvalOptions eval_options_of(const TrainConfig& c) {
  EvalOptions o;
  o.tto_steps = c.eval_tto_steps;
  o.tto_resolution = c.eval_tto_resolution;
  o.lr_pose = c.eval_lr_pose;
  o.lr_pose_fine = c.eval_lr_pose_fine;
  o.antialias = c.eval_antialias;
  return o;
}

int64_t storage_bytes(const Avatar& a, bool mesh, bool gaussians) {
  int64_t b = 0;
  if (gaussians) b += int64_t(a.gaussians.size()) * (56 + 4);
  if (mesh) b += int64_t(a.texture.width) * a.texture.height * 3;
  return b;
}

namespace {

// 0/1 weights of the person's pixels: the ground-truth matte above one half (a soft edge
// counts where it is mostly person; the black background, which every variant gets right,
// does not dilute the score).
std::vector<float> person_pixels(const std::vector<float>& mask, int P) {
  std::vector<float> w(size_t(P), 0.0f);
  for (size_t q = 0; q < w.size() && q < mask.size(); ++q) w[q] = mask[q] > 0.5f ? 1.0f : 0.0f;
  return w;
}

// Mean of (1 - A)(1 - mesh coverage) weighted by `part` (P): how much background shows
// through the rendered avatar there. NaN when the part has no weight.
double part_transmittance(const AvatarRenderBuffers& buf, const float* part, int P) {
  double num = 0, den = 0;
  for (int q = 0; q < P; ++q) {
    if (part[q] <= 0) continue;
    const double a = buf.alpha.empty() ? 0.0 : double(buf.alpha[size_t(q)]);
    const double m = buf.mesh.mask ? double(buf.mesh.mask[q]) : 0.0;
    num += part[q] * (1 - a) * (1 - m);
    den += part[q];
  }
  return den > 0 ? num / den : std::nan("");
}

// `steps` of test-time pose optimisation on frame f: the avatar frozen, the frame's pose and
// transl move (loss L2 + w (1 - SSIM) + w Dice). Returns the pose of the lowest loss seen
// (the start included); sets fe's loss at the start and that lowest loss.
SmplxParams optimise_test_pose(const TrainFrame& f, SmplxParams p, const Lbs<float>& lbs, const Avatar& a,
                               const AvatarViews& views, const EvalVariant& v, const EvalOptions& opt, int steps,
                               FrameEval& fe) {
  const BodyModel& body = a.body;
  const int W = f.camera.width, H = f.camera.height, P = W * H;
  LbsCache<float> cache;
  AvatarRenderBuffers buf;
  LossScratch<float> scratch;
  std::vector<float> verts(3 * size_t(body.num_verts)), d_verts, gt(3 * size_t(P)), d_image, sil, d_sil, d_alpha;
  composite_ground_truth(f.rgb.data(), f.mask.data(), P, opt.premultiplied, opt.background, gt.data());
  AvatarRenderRequest req = avatar_request(a, views, f.camera, verts.data(), v.mesh, v.gaussians);
  req.antialias = opt.antialias;
  for (int c = 0; c < 3; ++c) req.background[c] = opt.background[c];
  Adam adam;
  const int gb = adam.add_group("body", kPoseBodyGroup, opt.lr_pose);
  const int gf = adam.add_group("fine", kPoseFineGroup, opt.lr_pose_fine);
  std::vector<float> pb(kPoseBodyGroup), pf(kPoseFineGroup), db(kPoseBodyGroup), dfn(kPoseFineGroup);
  SmplxParams best = p;
  double best_loss = INFINITY;
  for (int s = 0; s <= steps; ++s) {
    lbs.forward(p, verts.data(), nullptr, &cache);
    render_avatar(req, buf);
    d_image.assign(3 * size_t(P), 0.0f);
    double loss = l2_loss<float>(buf.image.data(), gt.data(), H, W, nullptr, d_image.data(), 1.0f);
    loss += opt.tto_w_ssim *
            ssim_loss<float>(buf.image.data(), gt.data(), H, W, scratch, nullptr, d_image.data(), float(opt.tto_w_ssim));
    const float* da = nullptr;
    if (opt.tto_w_dice > 0 && v.gaussians) {
      sil.resize(size_t(P));
      d_sil.assign(size_t(P), 0.0f);
      silhouette_union(buf.mesh.mask, buf.alpha.data(), P, sil.data());
      loss += opt.tto_w_dice * dice_loss(sil.data(), f.mask.data(), P, d_sil.data(), float(opt.tto_w_dice));
      d_alpha.resize(size_t(P));
      silhouette_union_backward(buf.mesh.mask, d_sil.data(), P, d_alpha.data());
      da = d_alpha.data();
    }
    if (s == 0) fe.tto_loss_start = loss;
    if (loss < best_loss) best_loss = loss, best = p;  // keep the best pose seen
    if (s == steps) break;
    d_verts.assign(3 * size_t(body.num_verts), 0.0f);
    AvatarRenderGrads gr;
    gr.verts = d_verts.data();
    render_avatar_backward(req, buf, d_image.data(), da, nullptr, gr);
    SmplxGrad<float> sg = lbs.make_grad(p);
    lbs.backward(p, cache, d_verts.data(), nullptr, sg);
    pose_to_groups(sg, db.data(), dfn.data());
    if (!finite_all(db) || !finite_all(dfn)) break;  // keep the last finite pose
    pose_to_groups(p, pb.data(), pf.data());
    adam.step(gb, pb.data(), db.data());
    adam.step(gf, pf.data(), dfn.data());
    groups_to_pose(pb.data(), pf.data(), p);
  }
  fe.tto_loss_end = best_loss;
  return best;
}

// EvalOptions::coverage_oracle: the mesh layer of `req` (rendered into `buf` already) with its
// coverage times `matte` (the true matte, or a per-pixel 0/1 coverage) and no depth test where
// that is under one half, then the merge again with that layer.
void render_with_oracle_coverage(const AvatarRenderRequest& req, const std::vector<float>& matte,
                                 AvatarRenderBuffers& buf) {
  const size_t P = matte.size();
  std::vector<float> depth(buf.mesh.depth, buf.mesh.depth + P), color(buf.mesh.color, buf.mesh.color + 3 * P),
      mask(buf.mesh.mask, buf.mesh.mask + P);
  for (size_t q = 0; q < P; ++q) {
    mask[q] *= matte[q];
    if (matte[q] < 0.5f) depth[q] = INFINITY;
  }
  const MeshLayerView layer{depth.data(), color.data(), mask.data()};
  AvatarRenderRequest r = req;
  r.texture = nullptr;
  r.mesh_layer = &layer;
  AvatarRenderBuffers again;
  render_avatar(r, again);
  buf.image = again.image;
  buf.color_front = again.color_front;
  buf.alpha = again.alpha;
}

// The texel a covered pixel of the mesh render samples (nearest; row 0 = v = 1).
size_t pixel_texel(const AvatarRenderBuffers& buf, int q, const Texture& tex) {
  const float u = buf.mesh_render.uv[2 * size_t(q)], v = buf.mesh_render.uv[2 * size_t(q) + 1];
  const int x = std::clamp(int(u * float(tex.width)), 0, tex.width - 1);
  const int y = std::clamp(int((1 - v) * float(tex.height)), 0, tex.height - 1);
  return size_t(y) * size_t(tex.width) + size_t(x);
}

// CoverageOracle::texel, mesh-only pass: each covered pixel adds its matte to its texel.
void count_texel_matte(const AvatarRenderBuffers& buf, const std::vector<float>& matte, const Texture& tex,
                       std::vector<double>& in, std::vector<double>& all) {
  if (all.empty()) in.assign(size_t(tex.width) * tex.height, 0.0), all.assign(size_t(tex.width) * tex.height, 0.0);
  const std::vector<int32_t>& tri = buf.mesh_render.raster.tri;
  for (size_t q = 0; q < tri.size(); ++q)
    if (tri[q] >= 0) {
      const size_t t = pixel_texel(buf, int(q), tex);
      all[t] += 1;
      in[t] += matte[q];
    }
}

// CoverageOracle::texel, merges: the per-texel 0/1 coverage at each covered pixel (1 elsewhere:
// the antialiased rim outside the raster keeps its coverage).
std::vector<float> pixel_coverage(const AvatarRenderBuffers& buf, const std::vector<float>& texel, const Texture& tex) {
  const std::vector<int32_t>& tri = buf.mesh_render.raster.tri;
  std::vector<float> c(tri.size(), 1.0f);
  for (size_t q = 0; q < tri.size(); ++q)
    if (tri[q] >= 0) c[q] = texel[pixel_texel(buf, int(q), tex)];
  return c;
}

}  // namespace

VariantEval evaluate_variant(const EvalVariant& v, const std::vector<TrainFrame>& frames, const EvalOptions& opt) {
  if (!v.avatar) fail("evaluate", v.name + ": no avatar");
  const Avatar& a = *v.avatar;
  const BodyModel& body = a.body;
  if (body.num_faces <= 0) fail("evaluate", v.name + ": the avatar has no body model");
  if (v.mesh && (a.texture.width <= 0 || a.texture.rgb.size() != size_t(a.texture.width) * a.texture.height * 3))
    fail("evaluate", v.name + ": the avatar has no texture");
  VariantEval out;
  out.name = v.name;
  out.mesh = v.mesh;
  out.gaussians = v.gaussians;
  out.num_gaussians = v.gaussians ? a.gaussians.size() : 0;
  out.storage_bytes = storage_bytes(a, v.mesh, v.gaussians);
  if (frames.empty()) return out;
  if (opt.poses && opt.poses->size() != frames.size())
    fail("evaluate", v.name + ": " + std::to_string(opt.poses->size()) + " fixed poses for " +
                         std::to_string(frames.size()) + " frames");

  if (opt.coverage_oracle == EvalOptions::CoverageOracle::texel && opt.texel_coverage && v.mesh && v.gaussians &&
      opt.texel_coverage->size() != size_t(a.texture.width) * a.texture.height)
    fail("evaluate", v.name + ": the texel coverage does not match the texture");
  std::vector<double> texel_in, texel_all;  // texel mode, mesh only: matte over the pixels each texel drew

  Lbs<float> lbs(body);
  const AvatarViews views(a);
  AvatarRenderBuffers buf;
  std::vector<float> verts(3 * size_t(body.num_verts)), gt;

  for (size_t fi = 0; fi < frames.size(); ++fi) {
    const TrainFrame& f = frames[fi];
    const int W = f.camera.width, H = f.camera.height, P = W * H;
    if (f.rgb.size() != size_t(P) * 3 || f.mask.size() != size_t(P)) fail(f.name, "image buffers do not match the camera");
    gt.resize(3 * size_t(P));
    composite_ground_truth(f.rgb.data(), f.mask.data(), P, opt.premultiplied, opt.background, gt.data());
    SmplxParams p = f.params;
    p.betas = a.betas;
    if (!a.expression.empty()) p.expression = a.expression;
    if (p.expression.size() > size_t(body.num_expr)) p.expression.resize(size_t(body.num_expr));

    AvatarRenderRequest req = avatar_request(a, views, f.camera, verts.data(), v.mesh, v.gaussians);
    req.antialias = opt.antialias;
    for (int c = 0; c < 3; ++c) req.background[c] = opt.background[c];

    FrameEval fe;
    if (opt.poses) {
      p.pose = (*opt.poses)[fi].pose;
      p.transl = (*opt.poses)[fi].transl;
    } else if (opt.tto_steps > 0) {
      // Test-time pose optimisation coarse to fine: three quarters of the steps on the frame
      // downscaled to opt.tto_resolution, the rest at the scored size from there. The coarse
      // steps are cheap; the fine ones remove what the coarse image biases (Gaussians fitted
      // to fine pixels alias at coarse ones, and the pose would follow the aliasing).
      const int side = std::max(W, H);
      if (opt.tto_resolution > 0 && side > opt.tto_resolution) {
        const int coarse = opt.tto_steps * 3 / 4;
        FrameEval at_start, coarse_run;
        optimise_test_pose(f, p, lbs, a, views, v, opt, 0, at_start);  // the starting loss at the scored size
        const SmplxParams p0 = p;
        p = optimise_test_pose(downscale_train_frame(f, opt.tto_resolution), p, lbs, a, views, v, opt, coarse, coarse_run);
        p = optimise_test_pose(f, p, lbs, a, views, v, opt, opt.tto_steps - coarse, fe);
        fe.tto_loss_start = at_start.tto_loss_start;
        if (at_start.tto_loss_start < fe.tto_loss_end) {  // as without coarse steps: never worse than the start
          p = p0;
          fe.tto_loss_end = at_start.tto_loss_start;
        }
      } else {
        p = optimise_test_pose(f, p, lbs, a, views, v, opt, opt.tto_steps, fe);
      }
    }
    out.poses.push_back(p);
    const auto t0 = std::chrono::steady_clock::now();
    lbs.forward(p, verts.data(), nullptr, nullptr);
    render_avatar(req, buf);
    fe.render_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (opt.coverage_oracle == EvalOptions::CoverageOracle::pixel && v.mesh) {
      render_with_oracle_coverage(req, f.mask, buf);
    } else if (opt.coverage_oracle == EvalOptions::CoverageOracle::texel && v.mesh) {
      if (!v.gaussians) {
        count_texel_matte(buf, f.mask, a.texture, texel_in, texel_all);
      } else if (opt.texel_coverage) {
        render_with_oracle_coverage(req, pixel_coverage(buf, *opt.texel_coverage, a.texture), buf);
      }
    }
    fe.psnr = psnr(buf.image.data(), gt.data(), H, W);
    fe.ssim = ssim_metric(buf.image.data(), gt.data(), H, W);
    const std::vector<float> band = outline_band(f.mask.data(), H, W, kOutlineBandPx);
    fe.psnr_outline = psnr(buf.image.data(), gt.data(), H, W, band.data());  // NaN without an outline
    fe.psnr_person = psnr(buf.image.data(), gt.data(), H, W, person_pixels(f.mask, P).data());  // NaN: no person
    if (f.part.size() == size_t(P)) {
      fe.psnr_part = psnr(buf.image.data(), gt.data(), H, W, f.part.data());
      fe.transmittance_part = part_transmittance(buf, f.part.data(), P);
    } else if (!f.part.empty()) {
      fail(f.name, "part weights do not match the camera");
    }
    if (opt.lpips) fe.lpips = opt.lpips->distance(buf.image.data(), gt.data(), H, W);
    if (int(fi) < opt.keep_images) {
      fe.image = buf.image;
      fe.ground_truth = gt;
      fe.gaussian_layer = buf.color_front;  // premultiplied: the Gaussians in front of the mesh, on black
      fe.mesh_layer.assign(3 * size_t(P), 0.0f);
      if (buf.mesh.mask)
        for (int q = 0; q < P; ++q)
          for (int c = 0; c < 3; ++c)
            fe.mesh_layer[3 * size_t(q) + c] = buf.mesh.mask[q] * buf.mesh.color[3 * size_t(q) + c];
    }
    out.frames.push_back(std::move(fe));
  }
  if (!texel_all.empty()) {
    out.texel_coverage.assign(texel_all.size(), 1.0f);  // never drawn: kept
    for (size_t t = 0; t < texel_all.size(); ++t)
      if (texel_all[t] > 0 && texel_in[t] < 0.5 * texel_all[t]) out.texel_coverage[t] = 0.0f;
  }
  const double n = double(out.frames.size());
  out.psnr = out.ssim = out.render_ms = 0;
  double lp = 0, outline = 0, part = 0, daylight = 0, person = 0;
  int with_outline = 0, with_part = 0, with_person = 0;
  for (const FrameEval& fe : out.frames) {
    if (!std::isnan(fe.psnr_outline)) outline += fe.psnr_outline, ++with_outline;  // NaN: no outline
    if (!std::isnan(fe.psnr_person)) person += fe.psnr_person, ++with_person;
    if (!std::isnan(fe.psnr_part)) part += fe.psnr_part, daylight += fe.transmittance_part, ++with_part;
    out.psnr += fe.psnr / n;
    out.ssim += fe.ssim / n;
    out.render_ms += fe.render_ms / n;
    lp += fe.lpips / n;
  }
  out.lpips = opt.lpips ? lp : -1;
  out.psnr_outline = with_outline > 0 ? outline / with_outline : std::nan("");
  out.psnr_person = with_person > 0 ? person / with_person : std::nan("");
  out.psnr_part = with_part > 0 ? part / with_part : std::nan("");
  out.transmittance_part = with_part > 0 ? daylight / with_part : std::nan("");
  return out;
}

const char* region_name(BodyRegion r) {
  switch (r) {
    case BodyRegion::head: return "head/hair";
    case BodyRegion::torso: return "torso";
    case BodyRegion::arms: return "arms";
    case BodyRegion::hands: return "hands";
    case BodyRegion::legs: return "legs";
    case BodyRegion::feet: return "feet";
    default: return "?";
  }
}

BodyRegion joint_region(int j) {
  // SMPL-X joints: 0 pelvis, 1/2 hips, 3/6/9 spine, 4/5 knees, 7/8 ankles, 10/11 feet,
  // 12 neck, 13/14 collars, 15 head, 16/17 shoulders, 18/19 elbows, 20/21 wrists,
  // 22 jaw, 23/24 eyes, 25..54 fingers.
  if (j == 12 || j == 15 || (j >= 22 && j <= 24)) return BodyRegion::head;
  if (j == 0 || j == 3 || j == 6 || j == 9 || j == 13 || j == 14) return BodyRegion::torso;
  if (j >= 16 && j <= 21) return BodyRegion::arms;
  if (j >= 25) return BodyRegion::hands;
  if (j == 1 || j == 2 || j == 4 || j == 5) return BodyRegion::legs;
  return BodyRegion::feet;  // 7, 8, 10, 11
}

std::vector<BodyRegion> face_regions(const BodyModel& body) {
  std::vector<BodyRegion> r(size_t(body.num_faces), BodyRegion::torso);
  const int J = kNumJoints;
  if (body.weights.size() != size_t(body.num_verts) * J) return r;
  for (int f = 0; f < body.num_faces; ++f) {
    double w[kNumJoints] = {};
    for (int k = 0; k < 3; ++k) {
      const int v = body.faces[3 * size_t(f) + size_t(k)];
      for (int j = 0; j < J; ++j) w[j] += body.weights[size_t(v) * J + size_t(j)];
    }
    r[size_t(f)] = joint_region(int(std::max_element(w, w + J) - w));
  }
  return r;
}

std::vector<int> gaussians_per_region(const BodyModel& body, const BoundGaussians& g) {
  const std::vector<BodyRegion> fr = face_regions(body);
  std::vector<int> counts(size_t(BodyRegion::count), 0);
  for (int32_t f : g.face)
    if (f >= 0 && f < body.num_faces) ++counts[size_t(fr[size_t(f)])];
  return counts;
}

}  // namespace haha
