#include "format/canonical_faces.h"

#include <algorithm>
#include <array>

namespace haha {

CanonicalFaces canonical_faces(const int32_t* faces, int num_faces) {
  const size_t F = size_t(num_faces);
  CanonicalFaces c;
  c.rotation.resize(F);
  std::vector<std::array<int32_t, 3>> key(F);
  for (size_t f = 0; f < F; ++f) {
    const int32_t* v = faces + f * 3;
    int best = 0;
    for (int r = 1; r < 3; ++r) {
      const std::array<int32_t, 3> a{v[r], v[(r + 1) % 3], v[(r + 2) % 3]};
      const std::array<int32_t, 3> b{v[best], v[(best + 1) % 3], v[(best + 2) % 3]};
      if (a < b) best = r;  // a repeated vertex makes "smallest first" ambiguous; this is not
    }
    c.rotation[f] = uint8_t(best);
    key[f] = {v[best], v[(best + 1) % 3], v[(best + 2) % 3]};
  }
  c.order.resize(F);
  for (size_t f = 0; f < F; ++f) c.order[f] = int32_t(f);
  std::stable_sort(c.order.begin(), c.order.end(), [&](int32_t a, int32_t b) { return key[size_t(a)] < key[size_t(b)]; });
  return c;
}

}  // namespace haha
