#include "app/foot_lock.h"

#include <algorithm>
#include <cmath>

namespace haha {

using V3 = Vec3<double>;

// Shifts the root (x, z) so a foot in contact keeps the place it landed on: the offset is
// carried between contacts; in double support the foot that landed first holds.
int lock_feet(const Lbs<double>& lbs, std::vector<SmplxParams>& frames, double fps, const FootLockParams& o) {
  int contacts = 0;
  const int* feet = o.joints;
  const size_t T = frames.size();
  std::vector<V3> pos[2];
  std::vector<double> verts(size_t(lbs.num_verts()) * 3), joints(size_t(kNumJoints) * 3);
  for (const SmplxParams& p : frames) {
    lbs.forward(p, verts.data(), joints.data(), nullptr);
    for (int f = 0; f < 2; ++f) pos[f].push_back(V3(joints[size_t(3 * feet[f])], joints[size_t(3 * feet[f] + 1)], joints[size_t(3 * feet[f] + 2)]));
  }
  std::vector<char> contact[2];
  for (int f = 0; f < 2; ++f) {
    double low = INFINITY;
    for (const V3& x : pos[f]) low = std::min(low, x.y);
    std::vector<char> c(T, 0);
    for (size_t t = 0; t < T; ++t) {
      const size_t a = t > 0 ? t - 1 : t, b = std::min(t + 1, T - 1);
      const double speed = b > a ? norm(pos[f][b] - pos[f][a]) * fps / double(b - a) : 0;
      c[t] = speed < o.contact_speed && pos[f][t].y - low < o.contact_height;
    }
    for (size_t t = 0; t < T;) {  // drop runs shorter than a step
      size_t e = t;
      while (e < T && c[e] == c[t]) ++e;
      if (c[t] && int(e - t) < o.min_contact_frames) std::fill(c.begin() + long(t), c.begin() + long(e), 0);
      contacts += c[t] && int(e - t) >= o.min_contact_frames;
      t = e;
    }
    contact[f] = c;
  }
  V3 offset(0, 0, 0), anchor[2];
  long landed[2] = {-1, -1};
  for (size_t t = 0; t < T; ++t) {
    for (int f = 0; f < 2; ++f) {
      if (contact[f][t] && (t == 0 || !contact[f][t - 1])) anchor[f] = pos[f][t] + offset, landed[f] = long(t);
      if (!contact[f][t]) landed[f] = -1;
    }
    const int owner = landed[0] < 0 ? (landed[1] < 0 ? -1 : 1) : (landed[1] < 0 || landed[0] <= landed[1] ? 0 : 1);
    if (owner >= 0) {
      const V3 d = anchor[owner] - pos[owner][t];
      offset = V3(d.x, 0, d.z);
    }
    frames[t].transl[0] += float(offset.x);
    frames[t].transl[2] += float(offset.z);
  }
  return contacts;
}

}  // namespace haha
