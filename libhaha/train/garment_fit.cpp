#include "train/garment_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "body/lbs.h"
#include "core/error.h"
#include "train/silhouette_fit.h"

namespace haha {

namespace {

// Levels down the leg, t from 0 (hip joint) to 1 (ankle joint): the crotch is near t = 0.12
// on SMPL-X and the procedural body, the knee at 0.5.
constexpr double kTopLevel = 0.15, kLevelStep = 0.05;
constexpr int kLevels = 17;  // 0.15 .. 0.95
constexpr double kBand = 0.02;  // rest-height half band of a level's leg vertices (metres)

double level_t(int k) { return kTopLevel + kLevelStep * k; }

// Vertices of each leg (weight on its hip, knee, ankle and foot >= 0.5).
void leg_vertices(const BodyModel& body, std::vector<int>& left, std::vector<int>& right) {
  for (int v = 0; v < body.num_verts; ++v) {
    const float* w = &body.weights[size_t(v) * kNumJoints];
    if (w[1] + w[4] + w[7] + w[10] >= 0.5f) left.push_back(v);
    if (w[2] + w[5] + w[8] + w[11] >= 0.5f) right.push_back(v);
  }
}

struct LevelSets {
  std::vector<std::vector<int>> left, right;  // per level, the leg's vertices in its band
};

LevelSets level_sets(const BodyModel& body, const std::vector<float>& rest, const std::vector<float>& joints) {
  std::vector<int> L, R;
  leg_vertices(body, L, R);
  const double y_hip = 0.5 * (joints[3 * 1 + 1] + joints[3 * 2 + 1]);
  const double y_ankle = 0.5 * (joints[3 * 7 + 1] + joints[3 * 8 + 1]);
  LevelSets s;
  s.left.resize(kLevels);
  s.right.resize(kLevels);
  for (int k = 0; k < kLevels; ++k) {
    const double y = y_hip + level_t(k) * (y_ankle - y_hip);
    for (int v : L)
      if (std::abs(rest[3 * size_t(v) + 1] - y) <= kBand) s.left[size_t(k)].push_back(v);
    for (int v : R)
      if (std::abs(rest[3 * size_t(v) + 1] - y) <= kBand) s.right[size_t(k)].push_back(v);
  }
  return s;
}

Vec3<float> mean_of(const std::vector<float>& verts, const std::vector<int>& ids) {
  double a[3] = {0, 0, 0};
  for (int v : ids)
    for (int c = 0; c < 3; ++c) a[c] += verts[3 * size_t(v) + c];
  const double n = double(std::max<size_t>(1, ids.size()));
  return {float(a[0] / n), float(a[1] / n), float(a[2] / n)};
}

// Adds one frame's between-legs pixels (seen, in the mask) per level.
void measure_frame(const TrainFrame& f, const std::vector<float>& verts, const std::vector<float>& coverage,
                   const LevelSets& sets, std::vector<long>& seen, std::vector<long>& inside) {
  const Camera& cam = f.camera;
  const int W = cam.width, H = cam.height;
  for (int k = 0; k < kLevels; ++k) {
    if (sets.left[size_t(k)].empty() || sets.right[size_t(k)].empty()) continue;
    const Vec3<float> a = cam.to_camera(mean_of(verts, sets.left[size_t(k)]));
    const Vec3<float> b = cam.to_camera(mean_of(verts, sets.right[size_t(k)]));
    if (a.z <= 0 || b.z <= 0) continue;
    const Vec2<float> pa = cam.project(a), pb = cam.project(b);
    const double len = std::hypot(double(pb.x - pa.x), double(pb.y - pa.y));
    const int n = int(std::ceil(len));
    for (int i = 0; i <= n; ++i) {
      const double s = n == 0 ? 0.5 : double(i) / n;
      if (s < 0.25 || s > 0.75) continue;  // the middle half: loose trousers stay near their leg
      const int x = int(std::floor(pa.x + s * (pb.x - pa.x))), y = int(std::floor(pa.y + s * (pb.y - pa.y)));
      if (x < 0 || y < 0 || x >= W || y >= H) continue;
      const size_t p = size_t(y) * W + size_t(x);
      if (coverage[3 * p] >= 0.5f) continue;  // the body covers it
      ++seen[size_t(k)];
      if (f.mask[p] >= 0.5f) ++inside[size_t(k)];
    }
  }
}

// The fill per level over (at most max_frames of) the frames.
void measure(const BodyModel& body, const Lbs<float>& lbs, const std::vector<TrainFrame>& frames,
             const std::vector<float>& betas, const LevelSets& sets, int max_frames, GarmentDecision& d) {
  std::vector<long> seen(kLevels, 0), inside(kLevels, 0);
  BodySilhouette sil(body);
  std::vector<float> verts(3 * size_t(body.num_verts));
  const int n = int(frames.size()), m = std::min(n, max_frames);
  for (int i = 0; i < m; ++i) {
    const TrainFrame& f = frames[size_t(m == 1 ? 0 : (int64_t(i) * (n - 1)) / (m - 1))];
    if (f.mask.size() != size_t(f.camera.width) * f.camera.height) fail(f.name, "garment: the frame has no mask");
    SmplxParams p = f.params;
    p.betas = betas;
    lbs.forward(p, verts.data(), nullptr, nullptr);
    measure_frame(f, verts, sil.render(f.camera, verts.data()), sets, seen, inside);
  }
  for (int k = 0; k < kLevels; ++k) {
    d.t.push_back(level_t(k));
    d.pixels.push_back(seen[size_t(k)]);
    d.fill.push_back(seen[size_t(k)] >= 10 ? double(inside[size_t(k)]) / double(seen[size_t(k)]) : NAN);
  }
}

// The lowest filled level of the run of filled levels from the top (levels with too few
// pixels to judge are passed over); -1 when the top is not filled.
int hem_level(const GarmentDecision& d, double fill) {
  int hem = -1;
  for (int k = 0; k < kLevels; ++k) {
    if (std::isnan(d.fill[size_t(k)])) continue;
    if (d.fill[size_t(k)] < fill) break;
    hem = k;
  }
  return hem;
}

// Where the fill first falls below `value` down the leg, between the two levels it falls
// between (linearly); NaN when it never does.
double fill_crossing(const GarmentDecision& d, double value) {
  double prev_t = NAN, prev_f = NAN;
  for (int k = 0; k < kLevels; ++k) {
    const double f = d.fill[size_t(k)];
    if (std::isnan(f)) continue;
    if (f < value) return std::isnan(prev_f) ? level_t(k) : prev_t + (prev_f - value) / (prev_f - f) * (level_t(k) - prev_t);
    prev_t = level_t(k), prev_f = f;
  }
  return NAN;
}

}  // namespace

GarmentDecision decide_garment(const BodyModel& body, const std::vector<TrainFrame>& frames, const Stage0Config::Garment& opt) {
  GarmentDecision d;
  d.mode = opt.mode;
  if (opt.mode != "auto" && opt.mode != "skirt" && opt.mode != "none")
    fail("s0.garment.mode", "must be auto, skirt or none, got '" + opt.mode + "'");
  if (opt.mode == "none" || frames.empty()) {
    d.why = frames.empty() ? "no garment: no frames to measure" : "no garment: s0.garment.mode=none";
    return d;
  }
  const std::vector<float> betas = video_betas(frames, body.num_shape);
  Lbs<float> lbs(body);
  SmplxParams rest_p;
  rest_p.betas = betas;
  std::vector<float> rest(3 * size_t(body.num_verts)), joints(3 * size_t(kNumJoints));
  lbs.forward(rest_p, rest.data(), joints.data(), nullptr);
  const LevelSets sets = level_sets(body, rest, joints);
  measure(body, lbs, frames, betas, sets, opt.max_frames, d);

  int hem = hem_level(d, opt.fill);
  char why[240];
  if (hem < 2 && opt.mode == "auto") {  // less than 10 cm of leg covered: shorts or trousers
    if (hem < 0)
      std::snprintf(why, sizeof why, "no garment: the space between the legs is background (fill %.2f at the top, %.2f needed)",
                    std::isnan(d.fill[0]) ? 0.0 : d.fill[0], opt.fill);
    else  // filled at the top, but only as far as a crotch reaches
      std::snprintf(why, sizeof why,
                    "no garment: the masks fill the space between the legs only to t = %.2f down the leg (a crotch; a hem "
                    "reaches t = %.2f or lower)",
                    level_t(hem) + 0.5 * kLevelStep, level_t(2));
    d.why = why;
    return d;
  }
  // A hem is a level edge: the fill drops from full to none within a few centimetres. Loose
  // trousers fill the top too, but their crotch is an inverted V: the fill fades as the legs
  // part. (A garment to the ankles never drops: no edge to measure.)
  const double edge = fill_crossing(d, 0.2) - fill_crossing(d, 0.8);
  if (hem >= 2 && opt.mode == "auto" && edge > opt.max_edge) {
    std::snprintf(why, sizeof why,
                  "no garment: the fill between the legs fades over %.2f of the leg (a crotch, not a hem; %.2f at most)", edge,
                  opt.max_edge);
    d.why = why;
    return d;
  }
  const bool forced = hem < 2;
  if (forced) hem = 7;  // skirt asked for, none seen: to the knee (t = 0.5)
  const double y_hip = 0.5 * (joints[3 * 1 + 1] + joints[3 * 2 + 1]);
  const double y_ankle = 0.5 * (joints[3 * 7 + 1] + joints[3 * 8 + 1]);
  GarmentShape shape;
  shape.y_top = 0.5 * (joints[1] + joints[3 * 3 + 1]);  // halfway from the pelvis joint to spine1: the waist
  shape.y_hem = y_hip + std::min(1.0, level_t(hem) + 0.5 * kLevelStep) * (y_ankle - y_hip);
  shape.rings = opt.rings;
  shape.columns = opt.columns;
  shape.chart = float(opt.chart);
  shape.legs = opt.legs;
  d.y_top = shape.y_top;
  d.y_hem = shape.y_hem;
  d.garment = build_garment(body, rest, joints, shape);
  d.made = true;
  char edge_note[64] = "";
  if (!forced && std::isfinite(edge)) std::snprintf(edge_note, sizeof edge_note, ", its edge %.2f of the leg", edge);
  std::snprintf(why, sizeof why, "%s: waist at %.3f m, hem at %.3f m (t = %.2f down the leg%s), %d vertices",
                forced ? "garment forced by s0.garment.mode=skirt (none seen)" : "garment: the masks fill the space between the legs",
                d.y_top, d.y_hem, level_t(hem) + 0.5 * kLevelStep, edge_note, d.garment.num_verts());
  d.why = why;
  return d;
}

}  // namespace haha
