// Frame selection of the video fit (fit/fit_video_frames.h).
#include "fit/fit_video_frames.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace haha {

namespace {

namespace bp = blazepose;
constexpr int kCore[] = {bp::left_shoulder, bp::right_shoulder, bp::left_elbow, bp::right_elbow,
                         bp::left_wrist,    bp::right_wrist,    bp::left_hip,   bp::right_hip,
                         bp::left_knee,     bp::right_knee,     bp::left_ankle, bp::right_ankle};

bool inside(const KeypointsFrame& k, const Keypoint2& p) {
  return p.x >= 0 && p.y >= 0 && p.x <= k.width && p.y <= k.height;
}

std::string fmt(const char* f, double a, double b = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

// Why frame k cannot be fitted, or "".
std::string screen(const KeypointsFrame& k, const FitVideoOptions& opt) {
  if (k.people == 0 || !k.has_person()) return "nobody in the frame";
  if (k.score < opt.min_score) return fmt("low detection score (%.2f)", k.score);
  int seen = 0, outside = 0;
  for (int i : kCore) {
    const Keypoint2& p = k.body[size_t(i)];
    if (!inside(k, p)) ++outside;
    else if (p.score >= opt.min_visibility) ++seen;
  }
  auto seen_at = [&](int i) { return inside(k, k.body[size_t(i)]) && k.body[size_t(i)].score >= opt.min_visibility; };
  // A shoulder and a hip (a side view hides the far ones).
  const bool torso = (seen_at(bp::left_shoulder) || seen_at(bp::right_shoulder)) && (seen_at(bp::left_hip) || seen_at(bp::right_hip));
  const int n = int(std::size(kCore));
  if (seen >= opt.min_seen_fraction * n && torso) return "";
  if (outside > n - seen - outside) return fmt("person cut off (%.0f of %.0f body points outside the frame)", outside, n);
  if (!torso) return "torso not visible";
  return fmt("most body points not visible (%.0f of %.0f seen)", seen, n);
}

}  // namespace

Torso2D torso_2d(const KeypointsFrame& k) {
  auto P = [&](int i) { return k.body[size_t(i)]; };
  const double sx = 0.5 * (P(bp::left_shoulder).x + P(bp::right_shoulder).x), sy = 0.5 * (P(bp::left_shoulder).y + P(bp::right_shoulder).y);
  const double hx = 0.5 * (P(bp::left_hip).x + P(bp::right_hip).x), hy = 0.5 * (P(bp::left_hip).y + P(bp::right_hip).y);
  auto dist = [](double ax, double ay, double bx, double by) { return std::hypot(ax - bx, ay - by); };
  Torso2D t;
  t.x = 0.5 * (sx + hx);
  t.y = 0.5 * (sy + hy);
  t.size = std::max({1.0, dist(sx, sy, hx, hy),
                     dist(P(bp::left_shoulder).x, P(bp::left_shoulder).y, P(bp::right_shoulder).x, P(bp::right_shoulder).y),
                     dist(P(bp::left_hip).x, P(bp::left_hip).y, P(bp::right_hip).x, P(bp::right_hip).y)});
  return t;
}

FitVideoSelection select_video_frames(const std::vector<FitVideoInputFrame>& frames,
                                      const std::vector<FitVideoPoint>& points, const FitVideoOptions& opt) {
  FitVideoSelection s;
  const int n = int(frames.size());
  s.reason.resize(size_t(n));
  for (int i = 0; i < n; ++i) s.reason[size_t(i)] = screen(frames[size_t(i)].keypoints, opt);
  // Scene cuts: against the previous input frame that has a person in view.
  for (int i = 1; i < n; ++i) {
    if (!s.reason[size_t(i)].empty() || !s.reason[size_t(i - 1)].empty()) continue;
    const Torso2D a = torso_2d(frames[size_t(i - 1)].keypoints), b = torso_2d(frames[size_t(i)].keypoints);
    const double jump = std::hypot(a.x - b.x, a.y - b.y) / std::max(a.size, b.size);
    const double scale = std::max(a.size, b.size) / std::min(a.size, b.size);
    if (jump > opt.cut_jump || scale > opt.cut_scale)
      s.reason[size_t(i)] = fmt("scene cut (torso moved %.1f torso lengths, size changed x%.2f)", jump, scale);
  }
  for (int i = 0; i < n; ++i) {
    if (!s.reason[size_t(i)].empty()) continue;
    const KeypointsFrame& k = frames[size_t(i)].keypoints;
    FitVideoTargets t;
    for (const FitVideoPoint& p : points) {
      const Keypoint2& q = k.body[size_t(p.blazepose)];
      t.x.push_back(q.x);
      t.y.push_back(q.y);
      t.vis.push_back(inside(k, q) ? q.score : 0.0);
      if (!k.body_world.empty())
        for (int c = 0; c < 3; ++c) t.world.push_back(k.body_world[size_t(p.blazepose)][size_t(c)]);
    }
    t.linked = !s.kept.empty() && s.kept.back() == i - 1;
    t.dt = opt.frame_interval_s;
    s.kept.push_back(i);
    s.targets.push_back(std::move(t));
  }
  return s;
}

}  // namespace haha
