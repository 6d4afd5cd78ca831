#include "format/gaussian_lod.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/error.h"
#include "format/avatar_loader.h"

namespace haha {

namespace {

// A camera looking at the rest body from the front (+Z) or the back, framing its height.
Camera view_of(const std::vector<float>& verts, bool back) {
  Vec3f lo(INFINITY, INFINITY, INFINITY), hi(-INFINITY, -INFINITY, -INFINITY);
  for (size_t i = 0; i < verts.size(); i += 3)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], verts[i + k]), hi[k] = std::max(hi[k], verts[i + k]);
  const Vec3f centre = (lo + hi) * 0.5f;
  const float height = std::max(hi.y - lo.y, hi.x - lo.x);
  Camera c;
  c.width = c.height = kLodViewSize;
  c.fx = c.fy = 1.2f * kLodViewSize;
  c.cx = c.cy = 0.5f * kLodViewSize;
  c.R = Mat3f::identity();
  c.R.a[1][1] = -1;  // image y down
  c.R.a[2][2] = -1;  // looking along -Z from the front
  if (back) c.R.a[0][0] = -1, c.R.a[2][2] = 1;
  const float distance = 1.2f * 1.1f * height + (hi.z - lo.z);
  const Vec3f rc = c.R * centre;
  c.t = Vec3f(-rc.x, -rc.y, -rc.z + distance);
  return c;
}

Avatar subset(const Avatar& a, const std::vector<int32_t>& order, int n) {
  Avatar s;
  s.body = a.body;
  s.betas = a.betas;
  s.expression = a.expression;
  s.texture = a.texture;
  s.face_scale_divisor = a.face_scale_divisor;
  s.depth_margin = a.depth_margin;
  s.mesh_coverage = a.mesh_coverage;
  const BoundGaussians& g = a.gaussians;
  s.gaussians.resize(n);
  for (int i = 0; i < n; ++i) {
    const size_t o = size_t(order[size_t(i)]);
    s.gaussians.face[size_t(i)] = g.face[o];
    s.gaussians.opacity[size_t(i)] = g.opacity[o];
    for (int k = 0; k < 3; ++k) {
      s.gaussians.offset[size_t(i) * 3 + k] = g.offset[o * 3 + k];
      s.gaussians.scale[size_t(i) * 3 + k] = g.scale[o * 3 + k];
      s.gaussians.color[size_t(i) * 3 + k] = g.color[o * 3 + k];
    }
    for (int k = 0; k < 4; ++k) s.gaussians.rotation[size_t(i) * 4 + k] = g.rotation[o * 4 + k];
  }
  return s;
}

}  // namespace

LodPlan plan_lod(const Avatar& a, int tiers) {
  if (tiers < 1 || tiers > kMaxLodTiers) fail("--lod", "tiers must be in [1, " + std::to_string(kMaxLodTiers) + "]");
  const int N = a.gaussians.size();
  LodPlan plan;
  plan.order.resize(size_t(N));
  std::iota(plan.order.begin(), plan.order.end(), 0);
  const AvatarLoader full(a);
  PosedAvatar rest;
  full.repose(SmplxParams{}, rest);
  std::vector<double> rank_key(static_cast<size_t>(N));  // opacity x footprint
  for (int i = 0; i < N; ++i) {
    float s[3] = {rest.scales[size_t(i) * 3], rest.scales[size_t(i) * 3 + 1], rest.scales[size_t(i) * 3 + 2]};
    std::sort(s, s + 3);
    rank_key[size_t(i)] = double(a.gaussians.opacity[size_t(i)]) * s[1] * s[2];
  }
  std::stable_sort(plan.order.begin(), plan.order.end(),
                   [&](int32_t x, int32_t y) { return rank_key[size_t(x)] > rank_key[size_t(y)]; });
  // Prefix sizes N / 2^(T-1-t), each at least one more than the previous.
  int prev = 0;
  for (int t = 0; t < tiers; ++t) {
    const int prefix = t == tiers - 1 ? N : int(std::ceil(double(N) / std::pow(2.0, tiers - 1 - t)));
    if (prefix <= prev) continue;
    plan.counts.push_back(prefix - prev);
    prev = prefix;
  }
  if (N == 0) plan.counts.clear();
  // Each prefix against the full avatar, front and back.
  const Camera views[2] = {view_of(rest.verts, false), view_of(rest.verts, true)};
  std::vector<std::vector<float>> reference(2);
  AvatarRenderScratch scratch;
  for (int v = 0; v < 2; ++v) full.render(views[v], rest, reference[size_t(v)], {}, scratch);
  int prefix = 0;
  for (size_t t = 0; t < plan.counts.size(); ++t) {
    prefix += plan.counts[t];
    if (prefix == N) {
      plan.psnr.push_back(INFINITY);
      continue;
    }
    const AvatarLoader part(subset(a, plan.order, prefix));
    PosedAvatar posed;
    part.repose(SmplxParams{}, posed);
    double se = 0;
    size_t n = 0;
    for (int v = 0; v < 2; ++v) {
      std::vector<float> img;
      part.render(views[v], posed, img, {}, scratch);
      for (size_t i = 0; i < img.size(); ++i) se += (double(img[i]) - reference[size_t(v)][i]) * (double(img[i]) - reference[size_t(v)][i]);
      n += img.size();
    }
    plan.psnr.push_back(se == 0 ? INFINITY : 10.0 * std::log10(double(n) / se));
  }
  return plan;
}

}  // namespace haha
