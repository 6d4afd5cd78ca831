#include "train/outline_band.h"

#include "core/error.h"

namespace haha {

std::vector<float> outline_band(const float* mask, int H, int W, int radius) {
  if (H < 0 || W < 0 || radius < 0) fail("outline_band", "negative size or radius");
  const size_t P = size_t(H) * size_t(W);
  std::vector<float> band(P, 0.0f);
  auto inside = [&](int r, int c) { return mask[size_t(r) * W + c] > 0.5f; };
  std::vector<char> edge(P, 0);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const bool in = inside(r, c);
      edge[size_t(r) * W + c] = (r > 0 && inside(r - 1, c) != in) || (r + 1 < H && inside(r + 1, c) != in) ||
                                (c > 0 && inside(r, c - 1) != in) || (c + 1 < W && inside(r, c + 1) != in);
    }
  const int r2 = radius * radius;
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      if (!edge[size_t(r) * W + c]) continue;
      for (int dr = -radius; dr <= radius; ++dr)
        for (int dc = -radius; dc <= radius; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if (rr < 0 || rr >= H || cc < 0 || cc >= W || dr * dr + dc * dc > r2) continue;
          band[size_t(rr) * W + cc] = 1.0f;
        }
    }
  return band;
}

}  // namespace haha
