// The trainer's steps on the GPU (train/trainer_device.h): each stage's step of
// trainer_stage1/2/3.cpp, line for line, on device copies of the state. Shared with the
// CPU path, not repeated here: the step loop, frame / background sampling, schedules,
// the pose-refinement groups and their Adam (host values: LBS takes the pose from the
// host), the densify / prune decisions and their execution (on the host state, at those
// steps only), the KNN neighbour sets (rebuilt on the host at the rebuild interval), the
// mesh layers of stages 2-3 (rasterised on the host once per frame, as the CPU caches
// them) and the checkpoint format.
//
// Uploaded once: frames and masks (at construction), the stage's frozen bodies and mesh
// layers (first use). Per step the host reads back the loss sums, one non-finite count,
// and in stage 1 with pose refinement the LBS backward's per-joint sums.
//
// Status: run and checked on an H100 (tests/cuda/ pass there; figures in docs/results.md).
#include <cmath>

#include "cuda/avatar_render_cuda.h"
#include "cuda/lbs_cuda.h"
#include "cuda/mesh_raster_cuda.h"
#include "cuda/cuda_base.h"
#include "train/losses_cuda.h"
#include "train/optim_cuda.h"
#include "train/texture_smooth.h"
#include "train/trainer_impl.h"
#include "train/trainer_kernels_cuda.h"

namespace haha {

using cuda::DeviceBuffer;

namespace {

SmplxView<float> view_of(const SmplxParams& p) {
  return {p.pose.data(), p.betas.data(), int(p.betas.size()), p.expression.data(), int(p.expression.size()),
          p.transl.data()};
}

// The optimiser groups whose parameters live on the device in stage s (the pose groups
// of stage 1 stay with the host Adam).
std::vector<std::string> device_groups(int s) {
  if (s == 1) return {"offset", "rotation", "scale", "color"};
  if (s == 2) return {"texture"};
  if (s == 3) return {"opacity", "color"};
  return {};
}

}  // namespace

struct Trainer::Impl::Cuda : TrainerDevice {
  Impl& t;
  cuda::LbsCuda lbs;
  cuda::AvatarBodyCuda dbody;
  cuda::AvatarRenderCudaBuffers rbuf;
  cuda::LbsCudaCache lcache;
  cuda::LossCudaScratch ls;
  cuda::AdamCuda adam;
  std::vector<std::string> groups;  // adam's groups, as named in the host Adam
  std::vector<DeviceBuffer<float>> rgb, mask;  // per training frame
  // ---- state (device copies of the host's) ----
  DeviceBuffer<int32_t> face, knn;
  DeviceBuffer<float> face_stretch;  // per body face, uploaded at first use
  DeviceBuffer<float> offset, rotation, scale_logit, color_logit, opacity_logit, grad_accum, grad_count, texture;
  DeviceBuffer<float> removal_cost;  // stage 3 with s3.prune_cost (the host's Trainer::Impl::removal_cost)
  // ---- derived / scratch ----
  std::vector<DeviceBuffer<float>> frame_verts;  // stage 3: the frozen posed bodies
  struct Mesh {
    DeviceBuffer<int32_t> tri;
    DeviceBuffer<float> uv, depth, color, mask;
    bool ready = false;
  };
  std::vector<Mesh> mesh;
  Mesh scratch_mesh;
  DeviceBuffer<float> scale, color, opacity, verts, d_verts, gt, d_image, d_alpha, sil, d_sil, rot_unit, d_rot_unit,
      d_means_extra, d_offset, d_rotation, d_scale, d_color, d_opacity, d_scale_logit, d_color_logit, d_opacity_logit,
      d_texture, tex_color;
  DeviceBuffer<int32_t> nonfinite;

  explicit Cuda(Impl& impl) : t(impl), lbs(impl.body), dbody(impl.body) { upload_frames(); }

  // The frames of the host's current level (coarse to fine changes their size).
  int frames_w = -1, frames_h = -1;
  void upload_frames() {
    if (frames_w == t.W && frames_h == t.H) return;
    rgb.clear();
    mask.clear();
    for (const TrainFrame& f : t.in.frames) {
      rgb.emplace_back(f.rgb);
      mask.emplace_back(f.mask);
    }
    frames_w = t.W;
    frames_h = t.H;
  }

  // ---- state in and out (train/trainer_device.h) ----
  void upload() override {
    const GaussianParams& g = t.g;
    face.upload(g.face);
    offset.upload(g.offset);
    rotation.upload(g.rotation);
    scale_logit.upload(g.scale_logit);
    color_logit.upload(g.color_logit);
    opacity_logit.upload(g.opacity_logit);
    if (t.stage == 1) {
      grad_accum.upload(t.grad_accum);
      grad_count.upload(t.grad_count);
    }
    if (t.stage == 3 && t.pruning_by_cost()) removal_cost.upload(t.removal_cost);
    if (!t.texture.empty()) texture.upload(t.texture);
    knn.upload(t.knn_idx);
    adam = cuda::AdamCuda(t.adam.config());
    groups = device_groups(t.stage);
    for (const std::string& name : groups) {
      const int h = t.adam.group(name);
      const int d = adam.add_group(name, t.adam.size(h), t.adam.lr(h), t.adam.stride(h));
      adam.load(d, t.adam.first_moment(h), t.adam.second_moment(h), t.adam.steps(h));
    }
  }

  void download() override {
    GaussianParams& g = t.g;  // faces change on the host only (densify / prune)
    g.offset = offset.to_host();
    g.rotation = rotation.to_host();
    g.scale_logit = scale_logit.to_host();
    g.color_logit = color_logit.to_host();
    g.opacity_logit = opacity_logit.to_host();
    if (t.stage == 1) {
      t.grad_accum = grad_accum.to_host();
      t.grad_count = grad_count.to_host();
    }
    if (t.stage == 3 && t.pruning_by_cost()) t.removal_cost = removal_cost.to_host();
    if (t.stage == 2) t.texture = texture.to_host();
    for (const std::string& name : groups) {
      const int d = adam.group(name);
      t.adam.set_state(t.adam.group(name), adam.first_moment(d), adam.second_moment(d), adam.steps(d));
    }
  }

  void begin_stage(int s) override {
    upload();
    upload_frames();
    frame_verts.clear();
    if (s == 3)
      for (const std::vector<float>& v : t.frame_verts) frame_verts.emplace_back(v);
    mesh.clear();
    mesh.resize(t.cache_all ? size_t(t.nf) : 0);
  }

  bool step(LossTerms& terms, std::string& event) override {
    t.host_stale = true;  // even a skipped step has added to the densification statistics
    return t.stage == 1 ? step1(terms, event) : t.stage == 2 ? step2(terms) : step3(terms, event);
  }

  // ---- helpers ----
  // Mesh data of frame fi for the current stage: the host's (Impl::mesh_of), uploaded once.
  Mesh& mesh_of(int fi) {
    Mesh& m = t.cache_all ? mesh[size_t(fi)] : scratch_mesh;
    if (t.cache_all && m.ready) return m;
    const MeshCache& h = t.mesh_of(fi);
    if (t.stage == 2) {
      m.tri.upload(h.tri);
      m.uv.upload(h.uv);
    } else {
      m.depth.upload(h.depth);
      m.color.upload(h.color);
    }
    m.mask.upload(h.mask);
    m.ready = true;
    return m;
  }

  // image_loss (train/image_loss.h) without LPIPS, on the device.
  void image_loss(const float* render, const float* gt_img, const float* weights, const LossWeights& w, float* grad,
                  float scale_, LossTerms& terms) {
    double total = 0;
    if (w.l2 > 0) {
      const double v = cuda::l2_loss_cuda(render, gt_img, t.H, t.W, ls, weights, grad, float(w.l2 * scale_));
      terms.l2 += scale_ * v;
      total += w.l2 * v;
    }
    if (w.ssim > 0) {
      const double v = cuda::ssim_loss_cuda(render, gt_img, t.H, t.W, ls, weights, grad, float(w.ssim * scale_));
      terms.ssim += scale_ * v;
      total += w.ssim * v;
    }
    if (w.sobel > 0) {
      const double v = cuda::edge_loss_cuda(render, gt_img, t.H, t.W, ls, weights, grad, float(w.sobel * scale_));
      terms.sobel += scale_ * v;
      total += w.sobel * v;
    }
    terms.total += scale_ * total;
  }

  void ground_truth(int fi, const float bg[3]) {
    gt.resize(3 * size_t(t.P));
    cuda::composite_ground_truth_cuda(rgb[size_t(fi)].data(), mask[size_t(fi)].data(), t.P, t.in.premultiplied, bg,
                                      gt.data());
  }

  // The KNN sets over the posed centres `means` (device), found on the host.
  void rebuild_knn(const DeviceBuffer<float>& means) {
    const std::vector<float> h = means.to_host();
    t.update_knn(h.data());
    knn.upload(t.knn_idx);
  }

  // Calls the test hook with a device gradient (copied out and back).
  void run_hook(int s, DeviceBuffer<float>& grad) {
    if (!t.hook) return;
    std::vector<float> h = grad.to_host();
    t.hook(s, h);
    grad.upload(h);
  }

  bool all_finite(std::initializer_list<const DeviceBuffer<float>*> bufs) {
    nonfinite.assign_zero(1);
    for (const DeviceBuffer<float>* b : bufs) cuda::count_nonfinite_cuda(b->data(), int64_t(b->size()), nonfinite.data());
    return cuda::nonfinite_count(nonfinite) == 0;
  }

  GaussianSetView gaussian_view(int n) const {
    GaussianSetView v;
    v.count = n;
    v.face = face.data();
    v.offset = offset.data();
    v.rotation = rotation.data();
    v.scale = scale.data();
    v.color = color.data();
    v.opacity = opacity.data();
    return v;
  }

  void activate(int n) {
    scale.resize(3 * size_t(n));
    color.resize(3 * size_t(n));
    opacity.resize(size_t(n));
    cuda::activate_cuda(scale_logit.data(), color_logit.data(), opacity_logit.data(), n, float(t.cfg.scale_max),
                        scale.data(), color.data(), opacity.data());
  }

  // ---- stage 1 (trainer_stage1.cpp) ----
  const float* knn_term(const LossWeights& w, bool need_knn, LossTerms& terms) {
    const int n = t.g.size();
    if (need_knn) rebuild_knn(rbuf.means);
    d_means_extra.assign_zero(3 * size_t(n));
    rot_unit.resize(4 * size_t(n));
    d_rot_unit.assign_zero(4 * size_t(n));
    cuda::normalize_quats_cuda(rotation.data(), n, rot_unit.data());
    KnnRegInputs<float> ki;
    ki.n = n;
    ki.position = rbuf.means.data();
    ki.rotation = rot_unit.data();
    ki.scale = scale.data();
    ki.color = color.data();
    KnnRegGrads<float> kg;
    kg.position = d_means_extra.data();
    kg.rotation = d_rot_unit.data();
    kg.scale = d_scale.data();
    kg.color = d_color.data();
    const double v = cuda::knn_reg_cuda(ki, knn.data(), t.cfg.s1.knn_k, KnnRegWeights{}, &kg, float(w.knn));
    terms.knn += v;
    terms.total += w.knn * v;
    return d_means_extra.data();
  }

  bool step1(LossTerms& terms, std::string& event) {
    const TrainConfig& cfg = t.cfg;
    const int n = t.g.size(), B = cfg.batch, P = t.P, V = t.body.num_verts;
    const LossWeights w = t.effective(1);
    activate(n);
    d_offset.assign_zero(3 * size_t(n));
    d_rotation.assign_zero(4 * size_t(n));
    d_scale.assign_zero(3 * size_t(n));
    d_color.assign_zero(3 * size_t(n));
    t.d_betas.assign(t.betas.size(), 0.0f);
    std::fill(t.frame_touched.begin(), t.frame_touched.end(), 0);
    const float inv_b = 1.0f / float(B);
    const bool need_knn = w.knn > 0 && n > 1 &&
                          (t.knn_idx.size() != size_t(n) * cfg.s1.knn_k || t.step % cfg.s1.knn_every == 0);
    const GaussianSetView gv = gaussian_view(n);
    verts.resize(3 * size_t(V));
    for (int b = 0; b < B; ++b) {
      const int64_t k = int64_t(t.step) * B + b;
      const int fi = t.frame_of(1, k);
      float bg[3];
      t.background(1, k, bg);
      const SmplxParams fp = t.frame_params(fi);
      lbs.forward(view_of(fp), verts.data(), nullptr, cfg.s1.refine_pose ? &lcache : nullptr);
      AvatarRenderRequest req;
      req.camera = &t.in.frames[size_t(fi)].camera;
      req.body = &dbody.topology;
      req.verts = verts.data();
      req.face_scale_divisor = float(cfg.face_scale_divisor);
      req.gaussians = &gv;
      for (int c = 0; c < 3; ++c) req.background[c] = bg[c];
      cuda::render_avatar_cuda(req, rbuf);
      ground_truth(fi, bg);
      d_image.assign_zero(3 * size_t(P));
      image_loss(rbuf.image.data(), gt.data(), nullptr, w, d_image.data(), inv_b, terms);
      const float* d_alpha_ptr = nullptr;
      if (w.dice > 0) {
        d_alpha.assign_zero(size_t(P));
        const double v = cuda::dice_loss_cuda(rbuf.alpha.data(), mask[size_t(fi)].data(), P, ls, d_alpha.data(),
                                              float(w.dice * inv_b));
        terms.dice += v * inv_b;
        terms.total += w.dice * v * inv_b;
        d_alpha_ptr = d_alpha.data();
      }
      const float* d_means_ptr = b == 0 && w.knn > 0 && n > 1 ? knn_term(w, need_knn, terms) : nullptr;
      d_verts.assign_zero(3 * size_t(V));
      AvatarRenderGrads gr;
      gr.verts = cfg.s1.refine_pose ? d_verts.data() : nullptr;
      gr.offset = d_offset.data();
      gr.rotation = d_rotation.data();
      gr.scale = d_scale.data();
      gr.color = d_color.data();
      gr.means2d_norm_accum = grad_accum.data();
      gr.means2d_norm_scale[0] = 0.5f * float(t.W) * float(B);
      gr.means2d_norm_scale[1] = 0.5f * float(t.H) * float(B);
      cuda::render_avatar_backward_cuda(req, rbuf, d_image.data(), d_alpha_ptr, d_means_ptr, gr);
      cuda::count_visible_cuda(rbuf.raster.radii.data(), n, grad_count.data());
      if (cfg.s1.refine_pose) {
        SmplxGrad<float> sg = t.lbs.make_grad(fp);
        lbs.backward(view_of(fp), lcache, d_verts.data(), nullptr, sg);
        t.add_pose_grad(fi, sg);
      }
    }
    if (w.stretch > 0) {  // once per batch, on the parameters
      if (face_stretch.empty()) face_stretch.upload(t.face_stretch);
      const double v = cuda::stretch_reg_cuda(face.data(), face_stretch.data(), offset.data(), scale.data(), n, ls,
                                              d_offset.data(), d_scale.data(), float(w.stretch));
      terms.stretch += v;
      terms.total += w.stretch * v;
    }
    if (w.knn > 0 && n > 1) cuda::normalize_quats_backward_add_cuda(rotation.data(), d_rot_unit.data(), n, d_rotation.data());
    d_scale_logit.resize(3 * size_t(n));
    d_color_logit.resize(3 * size_t(n));
    cuda::activation_backward_cuda(scale.data(), color.data(), opacity.data(), float(cfg.scale_max), n, d_scale.data(),
                                   d_color.data(), nullptr, d_scale_logit.data(), d_color_logit.data(), nullptr);
    run_hook(1, d_offset);
    const bool ok = std::isfinite(terms.total) && all_finite({&d_offset, &d_rotation, &d_scale_logit, &d_color_logit}) &&
                    t.pose_grads_finite();
    if (!ok) return false;
    const LogLinearLr sched{cfg.s1.lr_offset_init, cfg.s1.lr_offset_final, cfg.s1.steps};
    adam.set_lr(adam.group("offset"), sched(t.step));
    adam.step(adam.group("offset"), offset.data(), d_offset.data());
    adam.step(adam.group("rotation"), rotation.data(), d_rotation.data());
    adam.step(adam.group("scale"), scale_logit.data(), d_scale_logit.data());
    adam.step(adam.group("color"), color_logit.data(), d_color_logit.data());
    t.update_pose();
    t.after_update(1, event);
    return true;
  }

  // ---- stage 2 (trainer_stage2.cpp) ----
  bool step2(LossTerms& terms) {
    const TrainConfig& cfg = t.cfg;
    const int B = cfg.batch, P = t.P, S = t.tex_size;
    const LossWeights w = t.effective(2);
    const float inv_b = 1.0f / float(B);
    d_texture.assign_zero(texture.size());
    const TextureView tv{S, S, 3, texture.data()};
    const float black[3] = {0, 0, 0};
    for (int b = 0; b < B; ++b) {
      const int64_t k = int64_t(t.step) * B + b;
      const int fi = t.frame_of(2, k);
      Mesh& m = mesh_of(fi);
      tex_color.resize(3 * size_t(P));
      cuda::sample_texture_cuda(tv, P, m.tri.data(), m.uv.data(), tex_color.data());
      ground_truth(fi, black);
      d_image.assign_zero(3 * size_t(P));
      image_loss(tex_color.data(), gt.data(), mask[size_t(fi)].data(), w, d_image.data(), inv_b, terms);
      cuda::sample_texture_backward_cuda(tv, P, m.tri.data(), m.uv.data(), d_image.data(), d_texture.data(), nullptr);
    }
    if (w.tv > 0) {
      const double v = cuda::texture_tv_loss_cuda(texture.data(), S, S, 3, ls, d_texture.data(), float(w.tv));
      terms.tv += v;
      terms.total += w.tv * v;
    }
    if (cfg.s2.smooth > 0) {  // the evidence-weighted prior, on the host (train/texture_smooth.h): two copies a step
      t.update_texture_evidence();
      const std::vector<float> h = texture.to_host();
      std::vector<float> g = d_texture.to_host();
      const double v = texture_smooth_loss(h.data(), t.tex_smooth_w.data(), S, S, 3, g.data(), float(cfg.s2.smooth));
      d_texture.upload(g);
      terms.total += cfg.s2.smooth * v;
    }
    run_hook(2, d_texture);
    if (!std::isfinite(terms.total) || !all_finite({&d_texture})) return false;
    adam.set_lr(adam.group("texture"), t.texture_lr());
    adam.step(adam.group("texture"), texture.data(), d_texture.data());
    cuda::clamp01_cuda(texture.data(), int64_t(texture.size()));
    return true;
  }

  // ---- stage 3 (trainer_stage3.cpp) ----
  bool step3(LossTerms& terms, std::string& event) {
    const TrainConfig& cfg = t.cfg;
    const int n = t.g.size(), B = cfg.batch, P = t.P;
    const LossWeights w = t.effective(3);
    const float inv_b = 1.0f / float(B);
    activate(n);
    d_color.assign_zero(3 * size_t(n));
    d_opacity.assign_zero(size_t(n));
    const GaussianSetView gv = gaussian_view(n);
    for (int b = 0; b < B; ++b) {
      const int64_t k = int64_t(t.step) * B + b;
      const int fi = t.frame_of(3, k);
      float bg[3];
      t.background(3, k, bg);
      Mesh& m = mesh_of(fi);
      const MeshLayerView layer{m.depth.data(), m.color.data(), m.mask.data()};
      AvatarRenderRequest req;
      req.camera = &t.in.frames[size_t(fi)].camera;
      req.body = &dbody.topology;
      req.verts = frame_verts[size_t(fi)].data();
      req.face_scale_divisor = float(cfg.face_scale_divisor);
      req.gaussians = &gv;
      req.mesh_layer = &layer;
      req.depth_margin = float(cfg.s3.depth_margin);
      for (int c = 0; c < 3; ++c) req.background[c] = bg[c];
      cuda::render_avatar_cuda(req, rbuf);
      ground_truth(fi, bg);
      d_image.assign_zero(3 * size_t(P));
      image_loss(rbuf.image.data(), gt.data(), nullptr, w, d_image.data(), inv_b, terms);
      const float* d_alpha_ptr = nullptr;
      if (w.dice > 0) {
        sil.resize(size_t(P));
        d_sil.assign_zero(size_t(P));
        cuda::silhouette_union_cuda(m.mask.data(), rbuf.alpha.data(), P, sil.data());
        const double v =
            cuda::dice_loss_cuda(sil.data(), mask[size_t(fi)].data(), P, ls, d_sil.data(), float(w.dice * inv_b));
        terms.dice += v * inv_b;
        terms.total += w.dice * v * inv_b;
        d_alpha.resize(size_t(P));
        cuda::silhouette_union_backward_cuda(m.mask.data(), d_sil.data(), P, d_alpha.data());
        d_alpha_ptr = d_alpha.data();
      }
      if (b == 0 && w.knn > 0 && n > 1) {
        if (t.knn_idx.size() != size_t(n) * cfg.s1.knn_k) rebuild_knn(rbuf.means);
        KnnRegInputs<float> ki;
        ki.n = n;
        ki.opacity = opacity.data();
        ki.color = color.data();
        KnnRegGrads<float> kg;
        kg.opacity = d_opacity.data();
        kg.color = d_color.data();
        const double v = cuda::knn_reg_cuda(ki, knn.data(), cfg.s1.knn_k, KnnRegWeights{}, &kg, float(w.knn));
        terms.knn += v;
        terms.total += w.knn * v;
      }
      AvatarRenderGrads gr;
      gr.color = d_color.data();
      gr.opacity = d_opacity.data();
      if (t.pruning_by_cost()) {
        gr.removal_cost = removal_cost.data();
        t.removal_frames += 1;
      }
      cuda::render_avatar_backward_cuda(req, rbuf, d_image.data(), d_alpha_ptr, nullptr, gr);
    }
    if (w.opacity > 0 && n > 0) {
      const double v = cuda::opacity_reg_cuda(opacity.data(), n, cfg.s3.opacity_mode, ls, d_opacity.data(), float(w.opacity));
      terms.opacity += v;
      terms.total += w.opacity * v;
    }
    d_color_logit.resize(3 * size_t(n));
    d_opacity_logit.resize(size_t(n));
    cuda::activation_backward_cuda(scale.data(), color.data(), opacity.data(), float(cfg.scale_max), n, nullptr,
                                   d_color.data(), d_opacity.data(), nullptr, d_color_logit.data(),
                                   d_opacity_logit.data());
    run_hook(3, d_opacity_logit);
    if (!std::isfinite(terms.total) || !all_finite({&d_opacity_logit, &d_color_logit})) return false;
    adam.step(adam.group("opacity"), opacity_logit.data(), d_opacity_logit.data());
    adam.step(adam.group("color"), color_logit.data(), d_color_logit.data());
    t.after_update(3, event);
    return true;
  }
};

std::unique_ptr<TrainerDevice> Trainer::Impl::make_cuda(Impl& t) {
  if (!cuda::cuda_available()) fail("cuda", "no usable GPU: " + cuda::device_description());
  if (t.lpips)
    fail("cuda", "the LPIPS loss has no CUDA path yet (train without --lpips-weights, or with --device cpu)");
  return std::make_unique<Cuda>(t);
}

}  // namespace haha
