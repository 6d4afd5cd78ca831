// Face points seen from behind (fit/fit_video_facing.h).
#include "fit/fit_video_facing.h"

#include <algorithm>

#include "io/keypoints_json.h"

namespace haha {

std::vector<double> face_point_factors(const std::vector<FitVideoPoint>& points, const std::vector<Vec3d>& cam) {
  namespace bp = blazepose;
  std::vector<double> f(points.size(), 1.0);
  int nose = -1, lear = -1, rear = -1;
  for (size_t k = 0; k < points.size(); ++k) {
    if (points[k].blazepose == bp::nose) nose = int(k);
    if (points[k].blazepose == bp::left_ear) lear = int(k);
    if (points[k].blazepose == bp::right_ear) rear = int(k);
  }
  if (nose < 0 || lear < 0 || rear < 0 || cam.size() != points.size()) return f;
  const Vec3d n = cam[size_t(nose)], forward = n - 0.5 * (cam[size_t(lear)] + cam[size_t(rear)]);
  const double lf = norm(forward), ln = norm(n);
  if (!(lf > 0) || !(ln > 0)) return f;
  const double c = dot(forward / lf, -1.0 * n / ln);
  const double factor = std::clamp(0.5 + 0.5 * c / kFaceFacingBand, 0.0, 1.0);
  for (size_t k = 0; k < points.size(); ++k) {
    const int b = points[k].blazepose;
    if ((b >= bp::nose && b <= bp::right_eye_outer) || b == bp::mouth_left || b == bp::mouth_right) f[k] = factor;
  }
  return f;
}

}  // namespace haha
