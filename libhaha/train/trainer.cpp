#include "train/trainer.h"

#include <chrono>
#include <cstdio>
#include <limits>
#include <numeric>

#include "train/trainer_impl.h"

namespace haha {

std::vector<float> video_betas(const std::vector<TrainFrame>& frames, int num_shape) {
  size_t nb = 0;
  for (const TrainFrame& f : frames) nb = std::max(nb, f.params.betas.size());
  if (nb == 0) nb = size_t(std::min(10, num_shape));
  nb = std::min(nb, size_t(num_shape));
  std::vector<float> betas(nb, 0.0f);
  const float n = float(frames.size());
  for (const TrainFrame& f : frames)
    for (size_t k = 0; k < std::min(nb, f.params.betas.size()); ++k) betas[k] += f.params.betas[k] / n;
  return betas;
}

namespace {

// One frame of the training input: size, camera, buffers, parameters; `w` names it in errors.
void validate_train_frame(const TrainFrame& f, const std::string& w, int W, int H) {
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
  for (size_t i = 0; i < in.frames.size(); ++i) validate_train_frame(in.frames[i], frame_label(in.frames[i], i), W, H);
  for (size_t i = 0; i < in.validation.size(); ++i)
    validate_train_frame(in.validation[i],
                         in.validation[i].name.empty() ? "validation frame " + std::to_string(i) : in.validation[i].name, W, H);
}


Trainer::Trainer(const TrainConfig& config, TrainInput input, Device device)
    : p_(std::make_unique<Impl>(config, std::move(input))) {
  p_->setup(true);
  p_->device_kind = device;
  if (device == Device::cuda) {
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
    p_->dev = Impl::make_cuda(*p_);
    if (p_->stage <= 3) p_->dev->begin_stage(p_->stage);
#else
    fail("cuda", "this build has no CUDA backend (configure with nvcc on PATH and HAHA_WITH_CUDA=ON)");
#endif
  }
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
Device Trainer::device() const { return p_->device_kind; }
TrainCheckpoint Trainer::save() const {
  p_->sync_host();  // the checkpoint format is the host's on every device
  return p_->save();
}
void Trainer::load(const TrainCheckpoint& ck, const std::string& where) {
  p_->load(ck, where);
  if (p_->dev) {
    p_->host_stale = false;  // the restored state is the truth, whatever the device held
    if (p_->stage <= 3) {
      p_->dev->begin_stage(p_->stage);
      p_->host_stale = true;  // equal now; reading the state back from the device checks the round trip
    }
  }
}
Avatar Trainer::avatar() const {
  p_->sync_host();
  return p_->make_avatar(p_->g);
}
bool Trainer::has_stage1() const { return p_->have_s1; }
Avatar Trainer::stage1_avatar() const {
  if (!p_->have_s1) fail("trainer", "stage 1 has not finished");
  p_->sync_host();
  return p_->make_avatar(p_->g_s1);
}
std::vector<SmplxParams> Trainer::refined_params() const {
  std::vector<SmplxParams> out;
  for (int i = 0; i < p_->nf; ++i) out.push_back(p_->frame_params(i));
  return out;
}
std::vector<SmplxParams> Trainer::validation_params() const {
  std::vector<SmplxParams> out;
  for (const TrainFrame& f : p_->in.validation) {
    out.push_back(f.params);
    out.back().betas = p_->betas;
  }
  return out;
}
std::vector<float> Trainer::densify_statistic() const {
  p_->sync_host();
  std::vector<float> s(p_->grad_accum.size(), 0.0f);
  for (size_t i = 0; i < s.size(); ++i)
    if (p_->grad_count[i] > 0) s[i] = p_->grad_accum[i] / p_->grad_count[i];
  return s;
}
std::vector<float> Trainer::texture_evidence() const {
  p_->sync_host();
  if (p_->tex_evidence.size() == size_t(p_->tex_size) * size_t(p_->tex_size) && !p_->texture.empty())
    return p_->tex_evidence;
  return p_->compute_texture_evidence();
}
std::array<double, 3> Trainer::stage_seconds() const { return p_->seconds; }
int64_t Trainer::skipped_steps() const { return p_->skipped; }
std::vector<FilterStopPoint> Trainer::filter_points() const { return p_->stop.points(); }
int Trainer::filter_choice() const { return p_->validating() ? p_->stop.chosen() : -1; }
bool Trainer::lpips_active() const { return p_->lpips != nullptr; }
void Trainer::set_gradient_hook(std::function<void(int, std::vector<float>&)> hook) { p_->hook = std::move(hook); }
void Trainer::set_pose_gradient_hook(std::function<void(const std::string&, const std::vector<float>&)> hook) {
  p_->pose_hook = std::move(hook);
}

}  // namespace haha
