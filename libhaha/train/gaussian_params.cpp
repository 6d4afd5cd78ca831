#include "train/gaussian_params.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/error.h"
#include "core/parallel.h"

namespace haha {

void GaussianParams::resize(int n) {
  face.resize(size_t(n));
  offset.resize(3 * size_t(n));
  rotation.resize(4 * size_t(n));
  scale_logit.resize(3 * size_t(n));
  color_logit.resize(3 * size_t(n));
  opacity_logit.resize(size_t(n));
}

GaussianParams init_one_per_face(int num_faces, float scale, float color, float opacity, float scale_max) {
  GaussianParams g;
  g.resize(num_faces);
  const float ls = logit(scale / scale_max), lc = logit(color), lo = logit(opacity);
  for (int i = 0; i < num_faces; ++i) {
    g.face[size_t(i)] = i;
    for (int k = 0; k < 3; ++k) {
      g.offset[3 * size_t(i) + k] = 0.0f;
      g.scale_logit[3 * size_t(i) + k] = ls;
      g.color_logit[3 * size_t(i) + k] = lc;
    }
    g.rotation[4 * size_t(i)] = 1.0f;
    g.rotation[4 * size_t(i) + 1] = g.rotation[4 * size_t(i) + 2] = g.rotation[4 * size_t(i) + 3] = 0.0f;
    g.opacity_logit[size_t(i)] = lo;
  }
  return g;
}

void activate(const GaussianParams& g, float scale_max, ActivatedGaussians& out) {
  const int n = g.size();
  out.scale.resize(3 * size_t(n));
  out.color.resize(3 * size_t(n));
  out.opacity.resize(size_t(n));
  parallel_for(n, [&](int64_t i) {
    for (int k = 0; k < 3; ++k) {
      out.scale[3 * i + k] = scaled_sigmoid(g.scale_logit[3 * i + k], scale_max);
      out.color[3 * i + k] = sigmoid(g.color_logit[3 * i + k]);
    }
    out.opacity[i] = sigmoid(g.opacity_logit[i]);
  });
}

void activation_backward(const ActivatedGaussians& act, float scale_max, int n, const float* d_scale,
                         const float* d_color, const float* d_opacity, float* d_scale_logit, float* d_color_logit,
                         float* d_opacity_logit) {
  parallel_for(n, [&](int64_t i) {
    for (int k = 0; k < 3; ++k) {
      if (d_scale && d_scale_logit)
        d_scale_logit[3 * i + k] = d_scale[3 * i + k] * scaled_sigmoid_grad_from_output(act.scale[3 * i + k], scale_max);
      if (d_color && d_color_logit)
        d_color_logit[3 * i + k] = d_color[3 * i + k] * scaled_sigmoid_grad_from_output(act.color[3 * i + k], 1.0f);
    }
    if (d_opacity && d_opacity_logit)
      d_opacity_logit[i] = d_opacity[i] * scaled_sigmoid_grad_from_output(act.opacity[i], 1.0f);
  });
}

BoundGaussians to_bound(const GaussianParams& g, float scale_max) {
  BoundGaussians b;
  const int n = g.size();
  b.resize(n);
  for (int i = 0; i < n; ++i) {
    b.face[size_t(i)] = g.face[size_t(i)];
    const float* r = &g.rotation[4 * size_t(i)];
    const double len = std::sqrt(double(r[0]) * r[0] + double(r[1]) * r[1] + double(r[2]) * r[2] + double(r[3]) * r[3]);
    for (int k = 0; k < 4; ++k)
      b.rotation[4 * size_t(i) + k] = len > 1e-20 ? float(r[k] / len) : (k == 0 ? 1.0f : 0.0f);
    for (int k = 0; k < 3; ++k) {
      b.offset[3 * size_t(i) + k] = g.offset[3 * size_t(i) + k];
      b.scale[3 * size_t(i) + k] = scaled_sigmoid(g.scale_logit[3 * size_t(i) + k], scale_max);
      b.color[3 * size_t(i) + k] = sigmoid(g.color_logit[3 * size_t(i) + k]);
    }
    b.opacity[size_t(i)] = sigmoid(g.opacity_logit[size_t(i)]);
  }
  return b;
}

GaussianParams from_bound(const BoundGaussians& b, float scale_max) {
  GaussianParams g;
  const int n = b.size();
  g.resize(n);
  for (int i = 0; i < n; ++i) {
    g.face[size_t(i)] = b.face[size_t(i)];
    for (int k = 0; k < 4; ++k) g.rotation[4 * size_t(i) + k] = b.rotation[4 * size_t(i) + k];
    for (int k = 0; k < 3; ++k) {
      g.offset[3 * size_t(i) + k] = b.offset[3 * size_t(i) + k];
      g.scale_logit[3 * size_t(i) + k] = logit(b.scale[3 * size_t(i) + k] / scale_max);
      g.color_logit[3 * size_t(i) + k] = logit(b.color[3 * size_t(i) + k]);
    }
    g.opacity_logit[size_t(i)] = logit(b.opacity[size_t(i)]);
  }
  return g;
}

namespace {

template <class V>
void gather(V& v, const std::vector<int64_t>& idx, int stride) {
  V out(idx.size() * size_t(stride));
  for (size_t e = 0; e < idx.size(); ++e)
    for (int k = 0; k < stride; ++k) out[e * stride + k] = v[size_t(idx[e]) * stride + k];
  v.swap(out);
}

}  // namespace

void select(GaussianParams& g, const std::vector<int64_t>& keep) {
  const int64_t n = g.size();
  for (int64_t i : keep)
    if (i < 0 || i >= n) fail("select", "index " + std::to_string(i) + " outside [0, " + std::to_string(n) + ")");
  gather(g.face, keep, 1);
  gather(g.offset, keep, 3);
  gather(g.rotation, keep, 4);
  gather(g.scale_logit, keep, 3);
  gather(g.color_logit, keep, 3);
  gather(g.opacity_logit, keep, 1);
}

std::vector<int64_t> indices_where(const std::vector<uint8_t>& keep) {
  std::vector<int64_t> out;
  for (size_t i = 0; i < keep.size(); ++i)
    if (keep[i]) out.push_back(int64_t(i));
  return out;
}

DensifyPlan plan_densify(const GaussianParams& g, float scale_max, const std::vector<float>& grad_accum,
                         const std::vector<float>& count, double threshold, double clone_scale, int max_count) {
  const int n = g.size();
  if (int(grad_accum.size()) != n || int(count.size()) != n)
    fail("densify", "statistics hold " + std::to_string(grad_accum.size()) + " values for " + std::to_string(n) +
                        " Gaussians");
  std::vector<std::pair<float, int64_t>> cand;  // (-avg, index): sorts largest avg first
  for (int i = 0; i < n; ++i) {
    if (!(count[size_t(i)] > 0)) continue;
    const float avg = grad_accum[size_t(i)] / count[size_t(i)];
    if (avg >= threshold) cand.emplace_back(-avg, int64_t(i));
  }
  std::sort(cand.begin(), cand.end());
  DensifyPlan plan;
  int64_t total = n;
  for (const auto& [neg, i] : cand) {
    if (total + 1 > max_count) break;  // clone and split both add one Gaussian
    float smax = 0;
    for (int k = 0; k < 3; ++k) smax = std::max(smax, scaled_sigmoid(g.scale_logit[3 * size_t(i) + k], scale_max));
    (smax <= clone_scale ? plan.clone : plan.split).push_back(i);
    ++total;
  }
  std::sort(plan.clone.begin(), plan.clone.end());
  std::sort(plan.split.begin(), plan.split.end());
  return plan;
}

uint64_t hash64(uint64_t seed, uint64_t stream, uint64_t index) {
  auto mix = [](uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  return mix(mix(mix(seed) ^ stream) ^ index);
}

double uniform01(uint64_t seed, uint64_t stream, uint64_t index) {
  return double(hash64(seed, stream, index) >> 11) * (1.0 / 9007199254740992.0);
}

double normal01(uint64_t seed, uint64_t stream, uint64_t index) {
  const double u1 = uniform01(seed, stream, 2 * index), u2 = uniform01(seed, stream, 2 * index + 1);
  return std::sqrt(-2.0 * std::log(1.0 - u1)) * std::cos(6.283185307179586 * u2);
}

int epoch_draw(uint64_t seed, uint64_t stream, int n, int64_t k) {
  const int64_t epoch = k / n, pos = k % n;
  std::vector<int> perm(static_cast<size_t>(n));
  std::iota(perm.begin(), perm.end(), 0);
  for (int i = n - 1; i > 0; --i) {
    const int j = int(uniform01(seed, stream, uint64_t(epoch) * uint64_t(n) + uint64_t(i)) * (i + 1));
    std::swap(perm[size_t(i)], perm[size_t(std::min(j, i))]);
  }
  return perm[size_t(pos)];
}

DensifyResult apply_densify(GaussianParams& g, const DensifyPlan& plan, float scale_max, double split_std,
                            double split_div, uint64_t seed) {
  const int64_t n = g.size();
  std::vector<uint8_t> keep(size_t(n), 1);
  for (int64_t i : plan.split) keep[size_t(i)] = 0;
  DensifyResult r;
  r.adam_source = indices_where(keep);
  std::vector<int64_t> src = r.adam_source;
  for (int64_t i : plan.clone) src.push_back(i);
  for (int64_t i : plan.split) src.push_back(i), src.push_back(i);
  r.adam_source.resize(src.size(), -1);
  r.cloned = int(plan.clone.size());
  r.split = int(plan.split.size());
  select(g, src);
  // Move and shrink the split children (the last 2 * split entries).
  const size_t first = src.size() - 2 * plan.split.size();
  for (size_t e = first; e < src.size(); ++e) {
    const uint64_t parent = uint64_t(src[e]), child = uint64_t(e - first) & 1u;
    float* mu = &g.offset[3 * e];
    float* sl = &g.scale_logit[3 * e];
    const float* q = &g.rotation[4 * e];
    const double qn = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
    const Quat<double> qu = qn > 1e-20 ? Quat<double>(q[0] / qn, q[1] / qn, q[2] / qn, q[3] / qn) : Quat<double>();
    const Mat3<double> R = quat_to_mat(qu);
    Vec3<double> z;
    for (int k = 0; k < 3; ++k)
      z[k] = split_std * double(scaled_sigmoid(sl[k], scale_max)) * normal01(seed, parent, 3 * child + uint64_t(k));
    Vec3<double> d = R * z;
    d.y = std::fabs(d.y);  // face-frame y = the face normal: children go outward
    for (int k = 0; k < 3; ++k) {
      mu[k] = float(double(mu[k]) + d[k]);
      const double s = double(scaled_sigmoid(sl[k], scale_max)) / split_div;
      sl[k] = float(logit(s / double(scale_max)));
    }
  }
  return r;
}

}  // namespace haha
