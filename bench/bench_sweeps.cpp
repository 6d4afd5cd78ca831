#include "bench/bench_sweeps.h"

#include <sched.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "body/lbs.h"
#include "core/error.h"
#include "core/parallel.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/image_codec.h"
#include "render/avatar_render.h"

namespace haha {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

void say(const std::function<void(const std::string&)>& log, const std::string& s) {
  if (log) log(s);
}

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Restores the OpenMP thread count when a sweep that changes it ends (or throws).
struct ThreadCountGuard {
  int saved = num_threads();
  ~ThreadCountGuard() { set_num_threads(saved); }
};

// Pose of `frame` with the avatar's own shape (what evaluate_variant renders).
SmplxParams avatar_pose(const Avatar& a, const SmplxParams& p0) {
  SmplxParams p = p0;
  p.betas = a.betas;
  if (!a.expression.empty()) p.expression = a.expression;
  if (p.betas.size() > size_t(a.body.num_shape)) p.betas.resize(size_t(a.body.num_shape));
  if (p.expression.size() > size_t(a.body.num_expr)) p.expression.resize(size_t(a.body.num_expr));
  return p;
}

}  // namespace

// ---- the machine ------------------------------------------------------------------------

std::string MachineInfo::line() const {
  std::string s = cpu_model + ", " + std::to_string(logical_cpus) + " logical CPU" + (logical_cpus == 1 ? "" : "s");
  if (!gpu.empty()) s += ", GPU " + gpu;
  return s;
}

MachineInfo machine_info() {
  MachineInfo m;
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  int listed = 0;
  while (std::getline(in, line)) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    while (!key.empty() && (key.back() == ' ' || key.back() == '\t')) key.pop_back();
    std::string value = line.substr(colon + 1);
    value.erase(0, value.find_first_not_of(" \t"));
    if (key == "processor") ++listed;
    if (key == "model name" && m.cpu_model.empty()) m.cpu_model = value;
  }
  if (m.cpu_model.empty()) m.cpu_model = "unknown CPU";
  // The CPUs this process may run on (a container may list more than it gets).
  cpu_set_t set;
  CPU_ZERO(&set);
  int usable = sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 0;
  if (usable <= 0) usable = listed > 0 ? listed : int(std::thread::hardware_concurrency());
  m.logical_cpus = usable;
  m.threads = num_threads();
  if (const char* w = std::getenv("OMP_WAIT_POLICY")) m.omp_wait_policy = w;
  std::ifstream la("/proc/loadavg");
  double l = -1;
  if (la >> l && std::isfinite(l) && l >= 0) m.load_average = l;
  return m;
}

// ---- shared evaluation --------------------------------------------------------------------

QualityPoint evaluate_quality(const Avatar& a, const BenchEval& ev, bool mesh, bool gaussians) {
  EvalOptions opt = ev.options;
  opt.keep_images = 0;
  const VariantEval v = evaluate_variant({"bench", &a, mesh, gaussians}, ev.frames, opt);
  QualityPoint q;
  q.gaussians = v.num_gaussians;
  q.storage_bytes = v.storage_bytes;
  q.psnr = v.psnr;
  q.ssim = v.ssim;
  q.render_ms = v.render_ms;
  return q;
}

// ---- 1 filtering ------------------------------------------------------------------------

Avatar prune_by_opacity(const Avatar& a, double threshold) {
  Avatar out;
  out.body = a.body;
  out.betas = a.betas;
  out.expression = a.expression;
  out.texture = a.texture;
  out.face_scale_divisor = a.face_scale_divisor;
  const BoundGaussians& g = a.gaussians;
  BoundGaussians& o = out.gaussians;
  for (int i = 0; i < g.size(); ++i) {
    if (!(double(g.opacity[size_t(i)]) >= threshold)) continue;
    o.face.push_back(g.face[size_t(i)]);
    o.opacity.push_back(g.opacity[size_t(i)]);
    for (int k = 0; k < 3; ++k) {
      o.offset.push_back(g.offset[3 * size_t(i) + k]);
      o.scale.push_back(g.scale[3 * size_t(i) + k]);
      o.color.push_back(g.color[3 * size_t(i) + k]);
    }
    for (int k = 0; k < 4; ++k) o.rotation.push_back(g.rotation[4 * size_t(i) + k]);
  }
  return out;
}

std::vector<FilterPoint> sweep_prune_thresholds(const Avatar& trained, const std::vector<double>& thresholds,
                                                const BenchEval& ev) {
  std::vector<FilterPoint> out;
  for (double t : thresholds) {
    if (!std::isfinite(t)) fail("bench", "prune threshold must be finite");
    FilterPoint p;
    p.method = "prune threshold";
    p.strength = t;
    p.q = evaluate_quality(prune_by_opacity(trained, t), ev);
    out.push_back(p);
  }
  return out;
}

const char* stage3_knob_method(Stage3Knob k) {
  return k == Stage3Knob::opacity_weight ? "opacity weight" : "image cost";
}

std::vector<FilterPoint> sweep_stage3(const RetrainSetup& setup, Stage3Knob knob, const std::vector<double>& values,
                                      const BenchEval& ev, const std::function<void(const std::string&)>& log) {
  const std::string method = stage3_knob_method(knob);
  std::vector<FilterPoint> out;
  for (double w : values) {
    if (!(w >= 0) || !std::isfinite(w)) fail("bench", method + " must be finite and >= 0");
    TrainConfig c = setup.config;
    if (knob == Stage3Knob::opacity_weight) {
      c.s3.w.opacity = w;
      c.use_opacity_reg = true;
    } else {
      c.s3.prune_cost = w;
    }
    Trainer tr(c, setup.input);
    tr.load(setup.stage2, setup.checkpoint_path);
    if (tr.stage() != 3 || tr.step_in_stage() != 0)
      fail(setup.checkpoint_path, "meta.stage/meta.step: expected the start of stage 3 (a checkpoint_stage2.npz)");
    const int steps = c.s3.steps;
    const auto t0 = Clock::now();
    int next_report = steps / 4;
    while (!tr.done()) {
      const StepReport r = tr.step();
      if (steps >= 8 && r.step >= next_report && r.step < steps) {
        say(log, "    " + method + fmt(" %g: step %.0f/%.0f, %.0f Gaussians", w, r.step, steps, r.gaussians));
        next_report += steps / 4;
      }
    }
    FilterPoint p;
    p.method = method;
    p.strength = w;
    p.stage3_seconds = ms_since(t0) / 1000.0;
    p.q = evaluate_quality(tr.avatar(), ev);
    say(log, "  " + method +
                 fmt(" %g: %.0f Gaussians, PSNR %.2f dB, stage 3 %.1f s", w, p.q.gaussians, p.q.psnr, p.stage3_seconds));
    out.push_back(p);
  }
  return out;
}

// ---- 2 packing --------------------------------------------------------------------------

std::vector<uint8_t> pack_with_setting(const Avatar& a, const PackSetting& s, PackedBytes& bytes) {
  PackOptions o;
  o.lossless = s.lossless;
  if (s.gaussian_bits >= 0) {
    GaussianBits& g = o.gaussian_bits;
    g.offset = g.rotation = g.scale = g.color = g.opacity = s.gaussian_bits;
  }
  if (!s.gaussian_bits_spec.empty()) o.gaussian_bits = parse_gaussian_bits(s.gaussian_bits_spec, "--gaussian-bit-sets");
  if (!s.mesh_bits_spec.empty()) o.mesh_bits = parse_mesh_bits(s.mesh_bits_spec, "--mesh-bit-sets");
  if (s.plain_mesh) o.mesh_compression = MeshCompression::none;
  o.texture_codec = texture_codec_from_name(s.texture_codec);
  o.texture_quality = s.texture_quality;
  o.texture_size = s.texture_size;
  if (s.pose_correctives == "none") o.pose_correctives = PoseCorrectives::none;
  else if (s.pose_correctives == "dense") o.pose_correctives = PoseCorrectives::dense;
  else if (!s.pose_correctives.empty()) o.pose_corrective_codec = parse_pose_corrective_codec(s.pose_correctives, "--corrective-sets");
  PackedSizes sz;
  std::vector<uint8_t> b = pack_avatar(a, o, &sz);
  bytes.total = b.size();
  bytes.gaussians = sz.gaussians;
  bytes.texture = sz.texture + sz.texture_exact;
  bytes.mesh = sz.mesh + sz.skeleton;
  bytes.pose_correctives = sz.pose_correctives;
  return b;
}

std::vector<PackSetting> default_pack_settings(int tex, std::string default_codec, int default_quality) {
  const PackOptions defaults;
  if (default_codec.empty()) default_codec = texture_extension(defaults.texture_codec);
  if (default_quality <= 0) default_quality = default_texture_quality(tex);
  std::vector<PackSetting> s;
  PackSetting ref;
  ref.name = "lossless float32";
  ref.group = "reference";
  ref.lossless = true;
  ref.texture_codec = "png";
  s.push_back(ref);
  for (int b : {4, 6, 8, 10, 12, 14, 16}) {
    PackSetting p;
    p.name = "Gaussians " + std::to_string(b) + " bit";
    p.group = "gaussian bits";
    p.gaussian_bits = b;
    p.texture_codec = "png";  // lossless 8-bit: the Gaussians' cost alone
    s.push_back(p);
  }
  auto tex_setting = [&](const std::string& codec, int q, int size) {
    PackSetting p;
    p.group = "texture";
    p.texture_codec = codec;
    p.texture_quality = q;
    p.texture_size = size == tex ? 0 : size;
    p.name = codec + (codec == "png" ? "" : " q" + std::to_string(q)) + " " + std::to_string(size) + "px";
    if (codec == default_codec && (codec == "png" || q == default_quality) && size == tex) p.name += " (default)";
    return p;
  };
  s.push_back(tex_setting("png", 95, tex));
  for (const char* codec : {"jpg", "webp"})
    for (int q : {95, 90, 85, 75}) s.push_back(tex_setting(codec, q, tex));
  for (int size = tex / 2; size >= 32 && size >= tex / 8; size /= 2)
    s.push_back(tex_setting(default_codec, default_quality, size));
  // The file for engines and tools without Draco: the default otherwise.
  PackSetting plain = tex_setting(default_codec, default_quality, tex);
  plain.name = "no Draco";
  plain.group = "mesh --mesh-compression none";
  plain.plain_mesh = true;
  s.push_back(plain);
  return s;
}

std::vector<PackPoint> sweep_packing(const Avatar& original, const std::vector<PackSetting>& settings,
                                     const BenchEval& ev, const std::function<void(const std::string&)>& log) {
  if (ev.frames.empty()) fail("bench", "packing sweep needs at least one frame");
  // Same poses for every avatar: no test-time optimisation here.
  EvalOptions opt = ev.options;
  opt.tto_steps = 0;
  opt.keep_images = int(ev.frames.size());
  const VariantEval ref = evaluate_variant({"original", &original, true, true}, ev.frames, opt);
  std::vector<PackPoint> out;
  for (const PackSetting& s : settings) {
    PackPoint p;
    p.setting = s;
    std::vector<uint8_t> bytes;
    auto t0 = Clock::now();
    bytes = pack_with_setting(original, s, p.bytes);
    p.pack_ms = ms_since(t0);
    // Decoding is what a loader pays: fastest of three (the first run also pays for page
    // faults and allocator growth).
    double best_decode = INFINITY;
    Avatar un;
    for (int rep = 0; rep < 3; ++rep) {
      t0 = Clock::now();
      un = unpack_avatar(bytes.data(), bytes.size(), "bench").avatar;
      best_decode = std::min(best_decode, ms_since(t0));
    }
    p.decode_ms = best_decode;
    // Render it as the loader does with --model: the original body's pose correctives
    // when the file has none (except for an explicit "none" setting, which measures a
    // loader without the body model); a baked rest shape takes no betas.
    if (un.body.posedirs.empty() && un.body.num_verts == original.body.num_verts && s.pose_correctives != "none")
      un.body.posedirs = original.body.posedirs;
    if (un.betas.size() > size_t(un.body.num_shape)) un.betas.resize(size_t(un.body.num_shape));
    if (un.expression.size() > size_t(un.body.num_expr)) un.expression.resize(size_t(un.body.num_expr));
    const VariantEval v = evaluate_variant({s.name, &un, true, true}, ev.frames, opt);
    double se = 0;
    size_t n = 0;
    for (size_t f = 0; f < v.frames.size(); ++f) {
      const std::vector<float>& a = v.frames[f].image;
      const std::vector<float>& b = ref.frames[f].image;
      if (a.size() != b.size()) fail("bench", s.name + ": unpacked render differs in size");
      for (size_t i = 0; i < a.size(); ++i) se += (double(a[i]) - double(b[i])) * (double(a[i]) - double(b[i]));
      n += a.size();
    }
    p.identical = se == 0.0;
    p.psnr_vs_original = p.identical ? kPsnrCap : std::min(kPsnrCap, 10.0 * std::log10(double(n) / se));
    p.psnr = v.psnr;
    p.ssim = v.ssim;
    p.psnr_cost = ref.psnr - v.psnr;
    say(log, "  " + s.name + fmt(": %.0f bytes, %.2f dB vs original, decode %.1f ms", double(p.bytes.total),
                                 p.psnr_vs_original, p.decode_ms));
    out.push_back(p);
  }
  return out;
}

// ---- 3 render speed ---------------------------------------------------------------------

Camera scaled_camera(const Camera& cam, int side) {
  if (side <= 0 || cam.width <= 0 || cam.height <= 0) fail("bench", "camera and image side must be positive");
  const double s = double(side) / double(std::max(cam.width, cam.height));
  Camera c = cam;
  c.width = std::max(1, int(std::lround(cam.width * s)));
  c.height = std::max(1, int(std::lround(cam.height * s)));
  c.fx = float(cam.fx * double(c.width) / cam.width);
  c.cx = float(cam.cx * double(c.width) / cam.width);
  c.fy = float(cam.fy * double(c.height) / cam.height);
  c.cy = float(cam.cy * double(c.height) / cam.height);
  return c;
}

Avatar subsample_gaussians(const Avatar& a, double fraction) {
  if (!(fraction > 0 && fraction <= 1)) fail("bench", "Gaussian fraction must be in (0, 1]");
  Avatar out = a;
  const int n = a.gaussians.size();
  const int keep = std::max(1, int(std::lround(fraction * n)));
  if (keep >= n) return out;
  BoundGaussians& o = out.gaussians;
  o.resize(keep);
  const BoundGaussians& g = a.gaussians;
  for (int j = 0; j < keep; ++j) {
    const size_t i = size_t((int64_t(j) * n) / keep);  // evenly spread over the (face-ordered) list
    o.face[size_t(j)] = g.face[i];
    o.opacity[size_t(j)] = g.opacity[i];
    for (int k = 0; k < 3; ++k) {
      o.offset[3 * size_t(j) + k] = g.offset[3 * i + k];
      o.scale[3 * size_t(j) + k] = g.scale[3 * i + k];
      o.color[3 * size_t(j) + k] = g.color[3 * i + k];
    }
    for (int k = 0; k < 4; ++k) o.rotation[4 * size_t(j) + k] = g.rotation[4 * i + k];
  }
  return out;
}

namespace {

// LBS + render of one frame on the CPU, timed `repeats` times after one warm-up.
RenderTiming time_cpu(const Avatar& a, const Camera& cam, const SmplxParams& pose0, int threads, int repeats, bool mesh,
                      bool gaussians) {
  set_num_threads(threads);
  const SmplxParams p = avatar_pose(a, pose0);
  Lbs<float> lbs(a.body);
  std::vector<float> verts(3 * size_t(a.body.num_verts));
  const AvatarViews views(a);
  const AvatarRenderRequest req = avatar_request(a, views, cam, verts.data(), mesh, gaussians && a.gaussians.size() > 0);
  AvatarRenderBuffers buf;
  auto once = [&] {
    const auto t0 = Clock::now();
    lbs.forward(p, verts.data(), nullptr, nullptr);
    render_avatar(req, buf);
    return ms_since(t0);
  };
  const double warm = once();
  const int reps = warm > 1000 ? std::min(repeats, 2) : repeats;
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) t.push_back(once());
  RenderTiming rt;
  rt.device = "cpu";
  rt.threads = threads;
  rt.resolution = std::max(cam.width, cam.height);
  rt.gaussians = gaussians ? a.gaussians.size() : 0;
  rt.mesh = mesh;
  rt.ms_median = median(t);
  rt.ms_min = *std::min_element(t.begin(), t.end());
  rt.repeats = reps;
  return rt;
}

}  // namespace

std::vector<RenderTiming> sweep_render_speed(const Avatar& filtered, const Avatar& full, const TrainFrame& frame,
                                             const RenderSweepOptions& opt,
                                             const std::function<void(const std::string&)>& log) {
  if (opt.repeats < 1) fail("bench", "render repeats must be >= 1");
  ThreadCountGuard guard;
  std::vector<RenderTiming> out;
  std::string sweep = "resolution";
  auto add = [&](RenderTiming t) {
    t.sweep = sweep;
    out.push_back(t);
    say(log, "  " + t.device + (t.device == "cpu" ? " " + std::to_string(t.threads) + " thread(s)" : std::string()) +
                 fmt(": %.0f px, %.0f Gaussians", t.resolution, t.gaussians) + (t.mesh ? " + mesh" : "") +
                 fmt(": %.2f ms", t.ms_median));
  };
  auto gpu_point = [&](const Avatar& a, const Camera& cam, bool mesh) {
    RenderTiming t;
    t.device = "cuda";
    t.resolution = std::max(cam.width, cam.height);
    t.gaussians = a.gaussians.size();
    t.mesh = mesh;
    t.repeats = opt.repeats;
    t.ms_median = t.ms_min = gpu_render_ms(a, cam, avatar_pose(a, frame.params), opt.repeats);
    add(t);
  };
  // Resolution: the HAHA avatar, and the mesh alone.
  for (int res : opt.resolutions) {
    const Camera cam = scaled_camera(frame.camera, res);
    for (int th : opt.threads) {
      add(time_cpu(filtered, cam, frame.params, th, opt.repeats, true, true));
      add(time_cpu(filtered, cam, frame.params, th, opt.repeats, true, false));
    }
    if (opt.gpu) gpu_point(filtered, cam, true);
  }
  // Gaussian count: subsets of the full avatar and the filtered avatar, with the mesh,
  // and the mesh alone.
  sweep = "gaussians";
  const Camera cam = scaled_camera(frame.camera, opt.count_resolution);
  std::vector<Avatar> sets;
  for (double f : opt.gaussian_fractions) sets.push_back(subsample_gaussians(full, f));
  sets.push_back(filtered);
  for (const Avatar& a : sets)
    for (int th : opt.threads) add(time_cpu(a, cam, frame.params, th, opt.repeats, true, true));
  for (int th : opt.threads) add(time_cpu(filtered, cam, frame.params, th, opt.repeats, true, false));
  if (opt.gpu)
    for (const Avatar& a : sets) gpu_point(a, cam, true);
  return out;
}

// ---- 4 training -------------------------------------------------------------------------

std::vector<StageRow> stage_table(const Avatar& filtered, const Avatar& stage1, const std::array<double, 3>& stage_seconds,
                                  const BenchEval& ev) {
  std::vector<StageRow> out;
  for (const EvalVariant& v : paper_variants(filtered, stage1)) {
    StageRow row;
    row.name = v.name;
    row.q = evaluate_quality(*v.avatar, ev, v.mesh, v.gaussians);
    out.push_back(row);
  }
  for (size_t i = 0; i < out.size(); ++i) out[i].train_seconds = variant_train_seconds(stage_seconds, i);
  return out;
}

}  // namespace haha
