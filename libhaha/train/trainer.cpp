#include "train/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

#include "body/lbs.h"
#include "core/error.h"
#include "core/parallel.h"
#include "render/mesh_raster.h"
#include "render/texture.h"
#include "train/adam.h"
#include "train/avatar_render.h"
#include "train/gaussian_params.h"
#include "train/knn.h"
#include "train/losses.h"

namespace haha {

namespace {

constexpr int kPoseBody = 66;   // global orient + 21 body joints
constexpr int kPoseFineFirst = 66;  // jaw .. right hand: pose values 66..164
constexpr int kEyesFirst = 69, kEyesEnd = 75;  // eyes are not refined
constexpr int kBodyGroup = kPoseBody + 3;       // + transl
constexpr int kFineGroup = kNumPoseValues - kPoseFineFirst - (kEyesEnd - kEyesFirst);  // jaw + hands = 93

// RNG streams (the stage is folded in).
enum Stream : uint64_t { kFrameOrder = 1, kBackground = 2, kSplit = 3 };
uint64_t stream(int stage, Stream s) { return uint64_t(stage) * 16 + uint64_t(s); }

bool finite_all(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

std::string frame_label(const TrainFrame& f, size_t i) {
  return f.name.empty() ? "training frame " + std::to_string(i) : f.name;
}

}  // namespace

void validate_train_input(const TrainInput& in) {
  if (!in.body) fail("training data", "no body model");
  const BodyModel& b = *in.body;
  const std::string bw = b.source.empty() ? "body model" : b.source;
  if (b.num_faces <= 0 || b.num_verts <= 0) fail(bw, "the body model has no faces");
  if (b.vt.empty() || b.ft.size() != size_t(b.num_faces) * 3)
    fail(bw, "vt/ft: the body model has no UV map (the texture stage needs one)");
  if (in.frames.empty()) fail("training data", "no training frames");
  const int W = in.frames[0].camera.width, H = in.frames[0].camera.height;
  for (size_t i = 0; i < in.frames.size(); ++i) {
    const TrainFrame& f = in.frames[i];
    const std::string w = frame_label(f, i);
    const Camera& c = f.camera;
    if (c.width != W || c.height != H)
      fail(w, "image size " + std::to_string(c.width) + "x" + std::to_string(c.height) + " differs from the first frame's " +
                  std::to_string(W) + "x" + std::to_string(H));
    if (W < 8 || H < 8) fail(w, "image smaller than 8x8");
    if (!(c.fx > 0 && c.fy > 0 && std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) &&
          std::isfinite(c.cy)))
      fail(w, "camera intrinsics not finite / positive");
    for (int r = 0; r < 3; ++r) {
      if (!std::isfinite(c.t[r])) fail(w, "camera translation not finite");
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(c.R.a[r][k])) fail(w, "camera rotation not finite");
    }
    if (f.rgb.size() != size_t(W) * H * 3) fail(w, "RGB buffer does not hold " + std::to_string(W) + "x" + std::to_string(H) + "x3 values");
    if (f.mask.size() != size_t(W) * H) fail(w, "mask buffer does not hold " + std::to_string(W) + "x" + std::to_string(H) + " values");
    for (size_t k = 0; k < f.rgb.size(); ++k)
      if (!std::isfinite(f.rgb[k])) fail(w, "non-finite pixel value at index " + std::to_string(k));
    double mass = 0;
    for (size_t k = 0; k < f.mask.size(); ++k) {
      if (!std::isfinite(f.mask[k]) || f.mask[k] < 0 || f.mask[k] > 1)
        fail(w, "mask value outside [0, 1] at pixel " + std::to_string(k));
      mass += f.mask[k];
    }
    if (!(mass > 0)) fail(w, "empty person mask");
    const SmplxParams& p = f.params;
    for (int k = 0; k < kNumPoseValues; ++k)
      if (!std::isfinite(p.pose[size_t(k)])) fail(w, "SMPL-X pose value " + std::to_string(k) + " is not finite");
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(p.transl[size_t(k)])) fail(w, "SMPL-X transl is not finite");
    for (size_t k = 0; k < p.betas.size(); ++k)
      if (!std::isfinite(p.betas[k])) fail(w, "SMPL-X betas are not finite");
    for (size_t k = 0; k < p.expression.size(); ++k)
      if (!std::isfinite(p.expression[k])) fail(w, "SMPL-X expression is not finite");
  }
}

struct Trainer::Impl {
  TrainConfig cfg;
  TrainInput in;
  const BodyModel& body;
  Lbs<float> lbs;
  int W = 0, H = 0, P = 0, nf = 0;
  std::unique_ptr<LpipsNet<float>> lpips;

  // ---- state (what a checkpoint holds) ----
  int stage = 1, step = 0;
  GaussianParams g, g_s1;
  bool have_s1 = false;
  std::vector<float> betas;
  std::vector<SmplxParams> params;  // per frame; betas are replaced by `betas` at use
  std::vector<float> texture;       // (S, S, 3)
  int tex_size = 0;
  Adam adam;
  std::vector<float> grad_accum, grad_count;  // densification statistics
  std::vector<int32_t> knn_idx;
  std::array<double, 3> seconds{0, 0, 0};
  int64_t skipped = 0;
  int nan_streak = 0;

  // ---- derived / scratch ----
  std::vector<std::vector<float>> frame_verts;  // stages 2-3: posed bodies (frozen)
  struct MeshCache {
    std::vector<int32_t> tri;
    std::vector<float> uv, mask, depth, color;
    bool ready = false;
  };
  std::vector<MeshCache> mesh_cache;
  bool cache_all = true;
  MeshCache scratch_cache;
  MeshRaster raster;
  ActivatedGaussians act;
  AvatarRenderBuffers rbuf;
  LbsCache<float> lcache;
  std::vector<float> verts, d_verts, gt, d_image, d_alpha, sil, d_sil, rot_unit, d_rot_unit, d_means_extra;
  ImageLossContext lctx;
  std::vector<float> d_offset, d_rotation, d_scale, d_color, d_opacity, d_scale_logit, d_color_logit,
      d_opacity_logit, d_texture, d_betas, tex_color;
  std::vector<std::vector<float>> d_frame_body, d_frame_fine;
  std::vector<uint8_t> frame_touched;
  std::function<void(int, std::vector<float>&)> hook;

  Impl(const TrainConfig& c, TrainInput input)
      : cfg(c), in(std::move(input)), body(*in.body), lbs(*in.body) {}

  int stage_steps(int s) const { return s == 1 ? cfg.s1.steps : s == 2 ? cfg.s2.steps : s == 3 ? cfg.s3.steps : 0; }
  const LossWeights& weights(int s) const { return s == 1 ? cfg.s1.w : s == 2 ? cfg.s2.w : cfg.s3.w; }
  LossWeights effective(int s) const {
    LossWeights w = weights(s);
    if (!cfg.use_sobel) w.sobel = 0;
    if (!cfg.use_opacity_reg) w.opacity = 0;
    if (!cfg.use_dice) w.dice = 0;
    if (!lpips) w.lpips = 0;
    return w;
  }

  // Frame of sample k of stage s: epochs are seeded permutations of the frames.
  int frame_of(int s, int64_t k) const {
    const int64_t epoch = k / nf, pos = k % nf;
    std::vector<int> perm(static_cast<size_t>(nf));
    std::iota(perm.begin(), perm.end(), 0);
    for (int i = nf - 1; i > 0; --i) {
      const int j = int(uniform01(cfg.seed, stream(s, kFrameOrder), uint64_t(epoch) * uint64_t(nf) + uint64_t(i)) * (i + 1));
      std::swap(perm[size_t(i)], perm[size_t(std::min(j, i))]);
    }
    return perm[size_t(pos)];
  }
  void background(int s, int64_t k, float bg[3]) const {
    for (int c = 0; c < 3; ++c)
      bg[c] = cfg.random_background ? float(uniform01(cfg.seed, stream(s, kBackground), uint64_t(k) * 3 + uint64_t(c))) : 0.0f;
  }

  SmplxParams frame_params(int fi) const {
    SmplxParams p = params[size_t(fi)];
    p.betas = betas;
    return p;
  }

  void pose_frame(int fi, bool keep_cache) {
    verts.resize(3 * size_t(body.num_verts));
    lbs.forward(frame_params(fi), verts.data(), nullptr, keep_cache ? &lcache : nullptr);
  }

  // ---------------------------------------------------------------------------------
  void setup(bool fresh) {
    validate_config(cfg);
    validate_train_input(in);
    W = in.frames[0].camera.width;
    H = in.frames[0].camera.height;
    P = W * H;
    nf = int(in.frames.size());
    if (in.lpips && in.lpips->has_backbone(LpipsBackbone::Vgg16)) {
      lpips = std::make_unique<LpipsNet<float>>(*in.lpips, LpipsBackbone::Vgg16);
      if (std::min(W, H) < lpips->min_size()) lpips.reset();
    }
    lctx.lpips = lpips.get();
    // Shared betas: mean of the fits (at most the model's shape columns).
    size_t nb = 0;
    for (const TrainFrame& f : in.frames) nb = std::max(nb, f.params.betas.size());
    if (nb == 0) nb = size_t(std::min(10, body.num_shape));
    nb = std::min(nb, size_t(body.num_shape));
    betas.assign(nb, 0.0f);
    for (const TrainFrame& f : in.frames)
      for (size_t k = 0; k < std::min(nb, f.params.betas.size()); ++k) betas[k] += f.params.betas[k] / float(nf);
    params.clear();
    for (const TrainFrame& f : in.frames) {
      SmplxParams p = f.params;
      if (p.expression.size() > size_t(body.num_expr)) p.expression.resize(size_t(body.num_expr));
      params.push_back(p);
    }
    tex_size = cfg.s2.texture_size;
    d_frame_body.assign(size_t(nf), std::vector<float>(kBodyGroup));
    d_frame_fine.assign(size_t(nf), std::vector<float>(kFineGroup));
    frame_touched.assign(size_t(nf), 0);
    if (fresh) {
      stage = 1;
      step = 0;
      g = init_one_per_face(body.num_faces, float(cfg.s1.init_scale), float(cfg.s1.init_color), float(cfg.s1.opacity),
                            float(cfg.scale_max));
      begin_stage(1);
    }
  }

  void begin_stage(int s) {
    adam = Adam();
    knn_idx.clear();
    if (s == 1) {
      const int n = g.size();
      adam.add_group("offset", 3 * int64_t(n), cfg.s1.lr_offset_init, 3);
      adam.add_group("rotation", 4 * int64_t(n), cfg.s1.lr_rotation, 4);
      adam.add_group("scale", 3 * int64_t(n), cfg.s1.lr_scale, 3);
      adam.add_group("color", 3 * int64_t(n), cfg.s1.lr_color, 3);
      if (cfg.s1.refine_pose) {
        adam.add_group("betas", int64_t(betas.size()), cfg.s1.lr_pose, 1);
        for (int i = 0; i < nf; ++i) {
          adam.add_group("frame" + std::to_string(i) + ".body", kBodyGroup, cfg.s1.lr_pose, 1);
          adam.add_group("frame" + std::to_string(i) + ".fine", kFineGroup, cfg.s1.lr_pose_fine, 1);
        }
      }
      grad_accum.assign(size_t(n), 0.0f);
      grad_count.assign(size_t(n), 0.0f);
    } else if (s == 2) {
      if (!have_s1) {
        g_s1 = g;
        have_s1 = true;
      }
      if (texture.empty()) texture.assign(size_t(tex_size) * tex_size * 3, float(cfg.s2.init_color));
      adam.add_group("texture", int64_t(texture.size()), cfg.s2.lr_texture, 3);
      build_frame_verts();
    } else if (s == 3) {
      const int n = g.size();
      adam.add_group("opacity", n, cfg.s3.lr_opacity, 1);
      adam.add_group("color", 3 * int64_t(n), cfg.s3.lr_color, 3);
      build_frame_verts();
    }
    for (MeshCache& m : mesh_cache) m.ready = false;
  }

  void build_frame_verts() {
    frame_verts.assign(size_t(nf), {});
    for (int i = 0; i < nf; ++i) {
      frame_verts[size_t(i)].resize(3 * size_t(body.num_verts));
      lbs.forward(frame_params(i), frame_verts[size_t(i)].data(), nullptr, nullptr);
    }
    // Per-frame caches: tri + uv + mask (stage 2) or depth + colour + mask (stage 3).
    const double per_frame = double(P) * (stage == 2 ? 4 + 8 + 4 : 4 + 12 + 4);
    cache_all = per_frame * nf <= cfg.max_cache_mb * 1024.0 * 1024.0;
    mesh_cache.assign(cache_all ? size_t(nf) : 0, MeshCache{});
  }

  // Mesh data of frame fi for the current stage (cached when memory allows).
  MeshCache& mesh_of(int fi) {
    MeshCache& m = cache_all ? mesh_cache[size_t(fi)] : scratch_cache;
    if (cache_all && m.ready) return m;
    const Camera& cam = in.frames[size_t(fi)].camera;
    rasterize_mesh(cam, MeshView{frame_verts[size_t(fi)].data(), body.num_verts, body.faces.data(), body.num_faces},
                   raster);
    m.tri = raster.tri;
    m.mask = raster.mask;
    m.uv.resize(2 * size_t(P));
    interpolate(P, raster.tri.data(), raster.bary.data(), body.ft.data(), body.vt.data(), 2, m.uv.data());
    if (stage == 3) {
      m.depth = raster.depth;
      m.color.resize(3 * size_t(P));
      sample_texture(texture_view(), P, m.tri.data(), m.uv.data(), m.color.data());
      m.tri.clear();
      m.uv.clear();
    }
    m.ready = true;
    return m;
  }

  TextureView texture_view() const { return TextureView{tex_size, tex_size, 3, texture.data()}; }

  GaussianSetView gaussian_view() const {
    GaussianSetView v;
    v.count = g.size();
    v.face = g.face.data();
    v.offset = g.offset.data();
    v.rotation = g.rotation.data();
    v.scale = act.scale.data();
    v.color = act.color.data();
    v.opacity = act.opacity.data();
    return v;
  }

  void prepare_ground_truth(int fi, const float bg[3]) {
    gt.resize(3 * size_t(P));
    const TrainFrame& f = in.frames[size_t(fi)];
    composite_ground_truth(f.rgb.data(), f.mask.data(), P, in.premultiplied, bg, gt.data());
  }

  // KNN sets over the posed centres `means`.
  void update_knn(const float* means) {
    const int n = g.size(), K = cfg.s1.knn_k;
    knn_idx.resize(size_t(n) * K);
    if (n > 0) haha::knn_sets(means, n, K, knn_idx.data());
  }

  // ---------------------------------------------------------------------------------
  // Stage 1.
  bool step1(LossTerms& terms, std::string& event) {
    const int n = g.size(), B = cfg.batch;
    const LossWeights w = effective(1);
    activate(g, float(cfg.scale_max), act);
    d_offset.assign(3 * size_t(n), 0.0f);
    d_rotation.assign(4 * size_t(n), 0.0f);
    d_scale.assign(3 * size_t(n), 0.0f);
    d_color.assign(3 * size_t(n), 0.0f);
    d_betas.assign(betas.size(), 0.0f);
    std::fill(frame_touched.begin(), frame_touched.end(), 0);
    const float inv_b = 1.0f / float(B);
    const bool need_knn = w.knn > 0 && n > 1 &&
                          (knn_idx.size() != size_t(n) * cfg.s1.knn_k || step % cfg.s1.knn_every == 0);
    for (int b = 0; b < B; ++b) {
      const int64_t k = int64_t(step) * B + b;
      const int fi = frame_of(1, k);
      float bg[3];
      background(1, k, bg);
      pose_frame(fi, cfg.s1.refine_pose);
      const GaussianSetView gv = gaussian_view();
      AvatarRenderRequest req;
      req.camera = &in.frames[size_t(fi)].camera;
      req.body = &body;
      req.verts = verts.data();
      req.face_scale_divisor = float(cfg.face_scale_divisor);
      req.gaussians = &gv;
      for (int c = 0; c < 3; ++c) req.background[c] = bg[c];
      render_avatar(req, rbuf);
      prepare_ground_truth(fi, bg);
      d_image.assign(3 * size_t(P), 0.0f);
      image_loss(rbuf.image.data(), gt.data(), H, W, nullptr, w, lctx, d_image.data(), inv_b, terms);
      const float* d_alpha_ptr = nullptr;
      if (w.dice > 0) {
        d_alpha.assign(size_t(P), 0.0f);
        const double v = dice_loss(rbuf.alpha.data(), in.frames[size_t(fi)].mask.data(), P, d_alpha.data(),
                                   float(w.dice * inv_b));
        terms.dice += v * inv_b;
        terms.total += w.dice * v * inv_b;
        d_alpha_ptr = d_alpha.data();
      }
      const float* d_means_ptr = nullptr;
      if (b == 0 && w.knn > 0 && n > 1) {
        if (need_knn) update_knn(rbuf.means.data());
        d_means_extra.assign(3 * size_t(n), 0.0f);
        rot_unit.resize(4 * size_t(n));
        d_rot_unit.assign(4 * size_t(n), 0.0f);
        for (int i = 0; i < n; ++i) {
          const float* r = &g.rotation[4 * size_t(i)];
          const float len = std::sqrt(std::max(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3], 1e-30f));
          for (int c = 0; c < 4; ++c) rot_unit[4 * size_t(i) + c] = r[c] / len;
        }
        KnnRegInputs<float> ki;
        ki.n = n;
        ki.position = rbuf.means.data();
        ki.rotation = rot_unit.data();
        ki.scale = act.scale.data();
        ki.color = act.color.data();
        KnnRegGrads<float> kg;
        kg.position = d_means_extra.data();
        kg.rotation = d_rot_unit.data();
        kg.scale = d_scale.data();
        kg.color = d_color.data();
        const double v = knn_reg(ki, knn_idx.data(), cfg.s1.knn_k, KnnRegWeights{}, &kg, float(w.knn));
        terms.knn += v;
        terms.total += w.knn * v;
        d_means_ptr = d_means_extra.data();
      }
      d_verts.assign(3 * size_t(body.num_verts), 0.0f);
      AvatarRenderGrads gr;
      gr.verts = cfg.s1.refine_pose ? d_verts.data() : nullptr;
      gr.offset = d_offset.data();
      gr.rotation = d_rotation.data();
      gr.scale = d_scale.data();
      gr.color = d_color.data();
      gr.means2d_norm_accum = grad_accum.data();
      render_avatar_backward(req, rbuf, d_image.data(), d_alpha_ptr, d_means_ptr, gr);
      for (int i = 0; i < n; ++i)
        if (rbuf.raster.radii[size_t(i)] > 0) grad_count[size_t(i)] += 1.0f;
      if (cfg.s1.refine_pose) {
        const SmplxParams fp = frame_params(fi);
        SmplxGrad<float> sg = lbs.make_grad(fp);
        lbs.backward(fp, lcache, d_verts.data(), nullptr, sg);
        std::vector<float>& db = d_frame_body[size_t(fi)];
        std::vector<float>& dfn = d_frame_fine[size_t(fi)];
        if (!frame_touched[size_t(fi)]) {
          std::fill(db.begin(), db.end(), 0.0f);
          std::fill(dfn.begin(), dfn.end(), 0.0f);
          frame_touched[size_t(fi)] = 1;
        }
        for (int q = 0; q < kPoseBody; ++q) db[size_t(q)] += sg.pose[size_t(q)];
        for (int q = 0; q < 3; ++q) db[size_t(kPoseBody + q)] += sg.transl[size_t(q)];
        int o = 0;
        for (int q = kPoseFineFirst; q < kNumPoseValues; ++q)
          if (q < kEyesFirst || q >= kEyesEnd) dfn[size_t(o++)] += sg.pose[size_t(q)];
        for (size_t q = 0; q < betas.size(); ++q) d_betas[q] += sg.betas[q] * inv_b;
      }
    }
    if (!rot_unit.empty() && !d_rot_unit.empty() && w.knn > 0 && n > 1)
      for (int i = 0; i < n; ++i) {
        float dr[4];
        normalize_quat_backward(&g.rotation[4 * size_t(i)], &d_rot_unit[4 * size_t(i)], dr);
        for (int c = 0; c < 4; ++c) d_rotation[4 * size_t(i) + c] += dr[c];
      }
    // The batch mean of the image terms is in d_image's scale; the KNN gradient was added
    // once; the densification statistic stays a per-view sum (3DGS).
    d_scale_logit.resize(3 * size_t(n));
    d_color_logit.resize(3 * size_t(n));
    activation_backward(act, float(cfg.scale_max), n, d_scale.data(), d_color.data(), nullptr, d_scale_logit.data(),
                        d_color_logit.data(), nullptr);
    if (hook) hook(1, d_offset);
    bool ok = std::isfinite(terms.total) && finite_all(d_offset) && finite_all(d_rotation) &&
              finite_all(d_scale_logit) && finite_all(d_color_logit) && finite_all(d_betas);
    for (int i = 0; i < nf && ok; ++i)
      if (frame_touched[size_t(i)]) ok = finite_all(d_frame_body[size_t(i)]) && finite_all(d_frame_fine[size_t(i)]);
    if (!ok) return false;

    const LogLinearLr sched{cfg.s1.lr_offset_init, cfg.s1.lr_offset_final, cfg.s1.steps};
    adam.set_lr(adam.group("offset"), sched(step));
    adam.step(adam.group("offset"), g.offset.data(), d_offset.data());
    adam.step(adam.group("rotation"), g.rotation.data(), d_rotation.data());
    adam.step(adam.group("scale"), g.scale_logit.data(), d_scale_logit.data());
    adam.step(adam.group("color"), g.color_logit.data(), d_color_logit.data());
    if (cfg.s1.refine_pose) {
      adam.step(adam.group("betas"), betas.data(), d_betas.data());
      for (int i = 0; i < nf; ++i) {
        if (!frame_touched[size_t(i)]) continue;
        // Mean over the batch: a frame drawn twice in one batch counts twice.
        for (float& x : d_frame_body[size_t(i)]) x *= inv_b;
        for (float& x : d_frame_fine[size_t(i)]) x *= inv_b;
        std::vector<float> body_vals(kBodyGroup), fine_vals(kFineGroup);
        SmplxParams& p = params[size_t(i)];
        for (int q = 0; q < kPoseBody; ++q) body_vals[size_t(q)] = p.pose[size_t(q)];
        for (int q = 0; q < 3; ++q) body_vals[size_t(kPoseBody + q)] = p.transl[size_t(q)];
        int o = 0;
        for (int q = kPoseFineFirst; q < kNumPoseValues; ++q)
          if (q < kEyesFirst || q >= kEyesEnd) fine_vals[size_t(o++)] = p.pose[size_t(q)];
        adam.step(adam.group("frame" + std::to_string(i) + ".body"), body_vals.data(), d_frame_body[size_t(i)].data());
        adam.step(adam.group("frame" + std::to_string(i) + ".fine"), fine_vals.data(), d_frame_fine[size_t(i)].data());
        for (int q = 0; q < kPoseBody; ++q) p.pose[size_t(q)] = body_vals[size_t(q)];
        for (int q = 0; q < 3; ++q) p.transl[size_t(q)] = body_vals[size_t(kPoseBody + q)];
        o = 0;
        for (int q = kPoseFineFirst; q < kNumPoseValues; ++q)
          if (q < kEyesFirst || q >= kEyesEnd) p.pose[size_t(q)] = fine_vals[size_t(o++)];
      }
    }
    // Densification, after the update (3DGS order), on the completed-step count.
    const int done_steps = step + 1;
    const Stage1Config& s1 = cfg.s1;
    if (s1.densify_every > 0 && done_steps > s1.densify_from && done_steps < s1.densify_until &&
        done_steps % s1.densify_every == 0)
      densify(event);
    return true;
  }

  void densify(std::string& event) {
    const Stage1Config& s1 = cfg.s1;
    // 3DGS's threshold is in NDC units: the pixel-space gradient times half the image size.
    std::vector<float> ndc(grad_accum.size());
    const float to_ndc = 0.5f * float(std::max(W, H));
    for (size_t i = 0; i < ndc.size(); ++i) ndc[i] = grad_accum[i] * to_ndc;
    const DensifyPlan plan =
        plan_densify(g, float(cfg.scale_max), ndc, grad_count, s1.densify_grad, s1.densify_clone_scale, s1.max_gaussians);
    const int before = g.size();
    const DensifyResult r = apply_densify(g, plan, float(cfg.scale_max), s1.densify_split_std, s1.densify_split_div,
                                          hash64(cfg.seed, stream(1, kSplit), uint64_t(step)));
    for (const char* name : {"offset", "rotation", "scale", "color"}) adam.reindex(adam.group(name), r.adam_source);
    knn_idx.clear();
    // Distribution of the statistic (visible Gaussians), to judge the threshold.
    std::vector<float> seen;
    for (size_t i = 0; i < ndc.size(); ++i)
      if (grad_count[i] > 0) seen.push_back(ndc[i] / grad_count[i]);
    std::sort(seen.begin(), seen.end());
    auto pct = [&](double q) { return seen.empty() ? 0.0 : double(seen[size_t(q * double(seen.size() - 1))]); };
    char buf[192];
    std::snprintf(buf, sizeof buf, "densify %d -> %d (clone %d, split %d; mean grad p50 %.2g p90 %.2g p99 %.2g)", before,
                  g.size(), r.cloned, r.split, pct(0.5), pct(0.9), pct(0.99));
    event = buf;
    grad_accum.assign(size_t(g.size()), 0.0f);
    grad_count.assign(size_t(g.size()), 0.0f);
  }

  // ---------------------------------------------------------------------------------
  // Stage 2.
  bool step2(LossTerms& terms, std::string&) {
    const int B = cfg.batch;
    const LossWeights w = effective(2);
    const float inv_b = 1.0f / float(B);
    d_texture.assign(texture.size(), 0.0f);
    const TextureView tv = texture_view();
    const float black[3] = {0, 0, 0};
    for (int b = 0; b < B; ++b) {
      const int64_t k = int64_t(step) * B + b;
      const int fi = frame_of(2, k);
      MeshCache& m = mesh_of(fi);
      tex_color.resize(3 * size_t(P));
      sample_texture(tv, P, m.tri.data(), m.uv.data(), tex_color.data());
      prepare_ground_truth(fi, black);
      d_image.assign(3 * size_t(P), 0.0f);
      image_loss(tex_color.data(), gt.data(), H, W, in.frames[size_t(fi)].mask.data(), w, lctx, d_image.data(), inv_b,
                 terms);
      sample_texture_backward(tv, P, m.tri.data(), m.uv.data(), d_image.data(), d_texture.data(), nullptr);
    }
    if (w.tv > 0) {
      const double v = texture_tv_loss(texture.data(), tex_size, tex_size, 3, d_texture.data(), float(w.tv));
      terms.tv += v;
      terms.total += w.tv * v;
    }
    if (hook) hook(2, d_texture);
    if (!std::isfinite(terms.total) || !finite_all(d_texture)) return false;
    adam.step(adam.group("texture"), texture.data(), d_texture.data());
    for (float& t : texture) t = std::clamp(t, 0.0f, 1.0f);
    return true;
  }

  // ---------------------------------------------------------------------------------
  // Stage 3.
  bool step3(LossTerms& terms, std::string& event) {
    const int n = g.size(), B = cfg.batch;
    const LossWeights w = effective(3);
    const float inv_b = 1.0f / float(B);
    activate(g, float(cfg.scale_max), act);
    d_color.assign(3 * size_t(n), 0.0f);
    d_opacity.assign(size_t(n), 0.0f);
    for (int b = 0; b < B; ++b) {
      const int64_t k = int64_t(step) * B + b;
      const int fi = frame_of(3, k);
      float bg[3];
      background(3, k, bg);
      MeshCache& m = mesh_of(fi);
      const MeshLayerView layer{m.depth.data(), m.color.data(), m.mask.data()};
      const GaussianSetView gv = gaussian_view();
      AvatarRenderRequest req;
      req.camera = &in.frames[size_t(fi)].camera;
      req.body = &body;
      req.verts = frame_verts[size_t(fi)].data();
      req.face_scale_divisor = float(cfg.face_scale_divisor);
      req.gaussians = &gv;
      req.mesh_layer = &layer;
      req.depth_margin = float(cfg.s3.depth_margin);
      for (int c = 0; c < 3; ++c) req.background[c] = bg[c];
      render_avatar(req, rbuf);
      prepare_ground_truth(fi, bg);
      d_image.assign(3 * size_t(P), 0.0f);
      image_loss(rbuf.image.data(), gt.data(), H, W, nullptr, w, lctx, d_image.data(), inv_b, terms);
      const float* d_alpha_ptr = nullptr;
      if (w.dice > 0) {
        sil.resize(size_t(P));
        d_sil.assign(size_t(P), 0.0f);
        silhouette_union(m.mask.data(), rbuf.alpha.data(), P, sil.data());
        const double v = dice_loss(sil.data(), in.frames[size_t(fi)].mask.data(), P, d_sil.data(), float(w.dice * inv_b));
        terms.dice += v * inv_b;
        terms.total += w.dice * v * inv_b;
        d_alpha.resize(size_t(P));
        silhouette_union_backward(m.mask.data(), d_sil.data(), P, d_alpha.data());
        d_alpha_ptr = d_alpha.data();
      }
      if (b == 0 && w.knn > 0 && n > 1) {
        if (knn_idx.size() != size_t(n) * cfg.s1.knn_k) update_knn(rbuf.means.data());
        KnnRegInputs<float> ki;
        ki.n = n;
        ki.opacity = act.opacity.data();
        ki.color = act.color.data();
        KnnRegGrads<float> kg;
        kg.opacity = d_opacity.data();
        kg.color = d_color.data();
        const double v = knn_reg(ki, knn_idx.data(), cfg.s1.knn_k, KnnRegWeights{}, &kg, float(w.knn));
        terms.knn += v;
        terms.total += w.knn * v;
      }
      AvatarRenderGrads gr;
      gr.color = d_color.data();
      gr.opacity = d_opacity.data();
      render_avatar_backward(req, rbuf, d_image.data(), d_alpha_ptr, nullptr, gr);
    }
    if (w.opacity > 0 && n > 0) {
      const double v = opacity_reg(act.opacity.data(), n, cfg.s3.opacity_mode, d_opacity.data(), float(w.opacity));
      terms.opacity += v;
      terms.total += w.opacity * v;
    }
    d_color_logit.resize(3 * size_t(n));
    d_opacity_logit.resize(size_t(n));
    activation_backward(act, float(cfg.scale_max), n, nullptr, d_color.data(), d_opacity.data(), nullptr,
                        d_color_logit.data(), d_opacity_logit.data());
    if (hook) hook(3, d_opacity_logit);
    if (!std::isfinite(terms.total) || !finite_all(d_opacity_logit) || !finite_all(d_color_logit)) return false;
    adam.step(adam.group("opacity"), g.opacity_logit.data(), d_opacity_logit.data());
    adam.step(adam.group("color"), g.color_logit.data(), d_color_logit.data());
    const int done_steps = step + 1;
    if ((cfg.s3.prune_every > 0 && done_steps % cfg.s3.prune_every == 0) || done_steps == cfg.s3.steps) prune(event);
    return true;
  }

  void prune(std::string& event) {
    const int before = g.size();
    const float thr = logit(float(cfg.s3.prune_threshold));
    std::vector<uint8_t> keep(static_cast<size_t>(before));
    for (int i = 0; i < before; ++i)
      keep[size_t(i)] = cfg.s3.prune_threshold <= 0 || g.opacity_logit[size_t(i)] >= thr;
    const std::vector<int64_t> idx = indices_where(keep);
    if (int(idx.size()) == before) return;
    select(g, idx);
    adam.reindex(adam.group("opacity"), idx);
    adam.reindex(adam.group("color"), idx);
    knn_idx.clear();
    event = "prune " + std::to_string(before) + " -> " + std::to_string(g.size());
  }

  StepReport run_step() {
    if (stage > 3) fail("trainer", "training has finished");
    const auto t0 = std::chrono::steady_clock::now();
    StepReport r;
    r.stage = stage;
    r.steps = stage_steps(stage);
    bool ok = true;
    if (r.steps > 0) {
      ok = stage == 1 ? step1(r.loss, r.event) : stage == 2 ? step2(r.loss, r.event) : step3(r.loss, r.event);
      if (ok) {
        nan_streak = 0;
      } else {
        ++skipped;
        ++nan_streak;
        r.skipped = true;
        if (nan_streak >= cfg.nan_patience)
          fail("training", "stage " + std::to_string(stage) + " step " + std::to_string(step + 1) + ": " +
                               std::to_string(nan_streak) +
                               " steps in a row with a non-finite loss or gradient; stopping (nothing was updated "
                               "by those steps; the last checkpoint is intact)");
      }
      ++step;
    }
    r.step = step;
    seconds[size_t(stage - 1)] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Advance through finished (or empty) stages.
    while (stage <= 3 && step >= stage_steps(stage)) {
      const auto t1 = std::chrono::steady_clock::now();
      ++stage;
      step = 0;
      if (stage <= 3) {
        begin_stage(stage);
        r.event += (r.event.empty() ? "" : "; ") + std::string("begin stage ") + std::to_string(stage);
      }
      if (stage <= 3)
        seconds[size_t(stage - 1)] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    }
    r.gaussians = g.size();
    return r;
  }

  // ---------------------------------------------------------------------------------
  static void put_gaussians(TrainCheckpoint& ck, const std::string& pre, const GaussianParams& x) {
    ck.i32[pre + "face"] = x.face;
    ck.f32[pre + "offset"] = x.offset;
    ck.f32[pre + "rotation"] = x.rotation;
    ck.f32[pre + "scale_logit"] = x.scale_logit;
    ck.f32[pre + "color_logit"] = x.color_logit;
    ck.f32[pre + "opacity_logit"] = x.opacity_logit;
  }

  TrainCheckpoint save() const {
    TrainCheckpoint ck;
    ck.i32["meta.version"] = {1};
    ck.i32["meta.stage"] = {stage};
    ck.i32["meta.step"] = {step};
    ck.i32["meta.num_frames"] = {nf};
    ck.i32["meta.texture_size"] = {tex_size};
    ck.i32["meta.skipped"] = {int32_t(skipped)};
    ck.i32["meta.nan_streak"] = {nan_streak};
    ck.f64["time.seconds"] = {seconds[0], seconds[1], seconds[2]};
    put_gaussians(ck, "g.", g);
    if (have_s1) put_gaussians(ck, "s1g.", g_s1);
    ck.f32["betas"] = betas;
    std::vector<float> pose, transl;
    for (const SmplxParams& p : params) {
      pose.insert(pose.end(), p.pose.begin(), p.pose.end());
      transl.insert(transl.end(), p.transl.begin(), p.transl.end());
    }
    ck.f32["pose"] = pose;
    ck.f32["transl"] = transl;
    if (!texture.empty()) ck.f32["texture"] = texture;
    for (const auto& [key, v] : adam.state()) ck.f32[key] = v;
    if (stage == 1) {
      ck.f32["densify.grad_accum"] = grad_accum;
      ck.f32["densify.count"] = grad_count;
    }
    ck.i32["knn.sets"] = knn_idx;
    return ck;
  }

  void load(const TrainCheckpoint& ck, const std::string& where) {
    auto geti = [&](const std::string& k) -> const std::vector<int32_t>& {
      auto it = ck.i32.find(k);
      if (it == ck.i32.end()) fail(where, k + ": missing");
      return it->second;
    };
    auto getf = [&](const std::string& k) -> const std::vector<float>& {
      auto it = ck.f32.find(k);
      if (it == ck.f32.end()) fail(where, k + ": missing");
      return it->second;
    };
    auto scalar = [&](const std::string& k) {
      const auto& v = geti(k);
      if (v.size() != 1) fail(where, k + ": expected one value");
      return v[0];
    };
    if (scalar("meta.version") != 1) fail(where, "meta.version: unsupported checkpoint version");
    if (scalar("meta.num_frames") != nf)
      fail(where, "meta.num_frames: checkpoint has " + std::to_string(scalar("meta.num_frames")) +
                      " training frames, the dataset " + std::to_string(nf));
    const int st = scalar("meta.stage"), sp = scalar("meta.step");
    if (st < 1 || st > 4 || sp < 0 || (st <= 3 && sp > stage_steps(st)))
      fail(where, "meta.stage/meta.step: stage " + std::to_string(st) + " step " + std::to_string(sp) +
                      " does not fit the configured schedule");
    if (scalar("meta.texture_size") != tex_size) fail(where, "meta.texture_size: differs from the config's s2.texture_size");
    auto read_g = [&](const std::string& pre) {
      GaussianParams x;
      x.face = geti(pre + "face");
      const size_t n = x.face.size();
      auto sized = [&](const std::string& k, size_t stride) {
        const auto& v = getf(pre + k);
        if (v.size() != n * stride) fail(where, pre + k + ": expected " + std::to_string(n * stride) + " values");
        if (!finite_all(v)) fail(where, pre + k + ": non-finite values");
        return v;
      };
      x.offset = sized("offset", 3);
      x.rotation = sized("rotation", 4);
      x.scale_logit = sized("scale_logit", 3);
      x.color_logit = sized("color_logit", 3);
      x.opacity_logit = sized("opacity_logit", 1);
      for (int32_t f : x.face)
        if (f < 0 || f >= body.num_faces) fail(where, pre + "face: face index outside the body model");
      return x;
    };
    GaussianParams ng = read_g("g.");
    const bool ns1 = ck.i32.count("s1g.face") > 0;
    GaussianParams ng1 = ns1 ? read_g("s1g.") : GaussianParams{};
    const auto& nb = getf("betas");
    if (nb.size() != betas.size()) fail(where, "betas: expected " + std::to_string(betas.size()) + " values");
    const auto& pose = getf("pose");
    const auto& transl = getf("transl");
    if (pose.size() != size_t(nf) * kNumPoseValues || transl.size() != size_t(nf) * 3)
      fail(where, "pose/transl: sizes do not match the training frames");
    std::vector<float> tex;
    if (ck.f32.count("texture")) {
      tex = getf("texture");
      if (tex.size() != size_t(tex_size) * tex_size * 3) fail(where, "texture: wrong size");
    }
    // Commit.
    stage = st;
    step = sp;
    g = std::move(ng);
    have_s1 = ns1;
    g_s1 = std::move(ng1);
    betas = nb;
    for (int i = 0; i < nf; ++i) {
      SmplxParams& p = params[size_t(i)];
      for (int q = 0; q < kNumPoseValues; ++q) p.pose[size_t(q)] = pose[size_t(i) * kNumPoseValues + size_t(q)];
      for (int q = 0; q < 3; ++q) p.transl[size_t(q)] = transl[size_t(i) * 3 + size_t(q)];
    }
    texture = std::move(tex);
    skipped = scalar("meta.skipped");
    nan_streak = scalar("meta.nan_streak");
    auto it = ck.f64.find("time.seconds");
    if (it != ck.f64.end() && it->second.size() == 3) seconds = {it->second[0], it->second[1], it->second[2]};
    if (stage <= 3) {
      begin_stage(stage);
      adam.load_state(ck.f32, where);
      if (stage == 1) {
        grad_accum = getf("densify.grad_accum");
        grad_count = getf("densify.count");
        if (grad_accum.size() != size_t(g.size()) || grad_count.size() != size_t(g.size()))
          fail(where, "densify.*: sizes do not match the Gaussians");
      }
      knn_idx = geti("knn.sets");
      if (!knn_idx.empty() && knn_idx.size() != size_t(g.size()) * cfg.s1.knn_k)
        fail(where, "knn.sets: size does not match the Gaussians");
    }
  }

  Avatar make_avatar(const GaussianParams& x) const {
    Avatar a;
    a.body = body;
    a.betas = betas;
    a.face_scale_divisor = float(cfg.face_scale_divisor);
    a.texture.width = a.texture.height = texture.empty() ? 0 : tex_size;
    a.texture.rgb = texture;
    a.gaussians = to_bound(x, float(cfg.scale_max));
    return a;
  }
};

Trainer::Trainer(const TrainConfig& config, TrainInput input) : p_(std::make_unique<Impl>(config, std::move(input))) {
  p_->setup(true);
}
Trainer::~Trainer() = default;

int Trainer::stage() const { return p_->stage; }
int Trainer::step_in_stage() const { return p_->step; }
int64_t Trainer::completed_steps() const {
  int64_t s = 0;
  for (int k = 1; k < std::min(p_->stage, 4); ++k) s += p_->stage_steps(k);
  if (p_->stage > 3) return p_->cfg.total_steps();
  return s + p_->step;
}
bool Trainer::done() const { return p_->stage > 3; }
StepReport Trainer::step() { return p_->run_step(); }
int Trainer::num_gaussians() const { return p_->g.size(); }
const TrainConfig& Trainer::config() const { return p_->cfg; }
TrainCheckpoint Trainer::save() const { return p_->save(); }
void Trainer::load(const TrainCheckpoint& ck, const std::string& where) { p_->load(ck, where); }
Avatar Trainer::avatar() const { return p_->make_avatar(p_->g); }
bool Trainer::has_stage1() const { return p_->have_s1; }
Avatar Trainer::stage1_avatar() const {
  if (!p_->have_s1) fail("trainer", "stage 1 has not finished");
  return p_->make_avatar(p_->g_s1);
}
std::vector<SmplxParams> Trainer::refined_params() const {
  std::vector<SmplxParams> out;
  for (int i = 0; i < p_->nf; ++i) out.push_back(p_->frame_params(i));
  return out;
}
std::array<double, 3> Trainer::stage_seconds() const { return p_->seconds; }
int64_t Trainer::skipped_steps() const { return p_->skipped; }
bool Trainer::lpips_active() const { return p_->lpips != nullptr; }
void Trainer::set_gradient_hook(std::function<void(int, std::vector<float>&)> hook) { p_->hook = std::move(hook); }

}  // namespace haha
