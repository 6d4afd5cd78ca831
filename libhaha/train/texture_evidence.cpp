#include "train/texture_evidence.h"

#include <cmath>

#include "core/math.h"
#include "render/texture.h"

namespace haha {

void accumulate_texture_evidence(const Camera& cam, const float* posed_verts, const int32_t* faces,
                                 const int32_t* tri, const float* uv, const float* mask, int tex_width,
                                 int tex_height, float* evidence) {
  const int W = cam.width, H = cam.height;
  auto cam_vert = [&](int32_t v) {
    return cam.to_camera(Vec3<float>(posed_verts[3 * size_t(v)], posed_verts[3 * size_t(v) + 1],
                                     posed_verts[3 * size_t(v) + 2]));
  };
  // Sequential: a frame of a few thousand covered pixels costs microseconds, and a fixed
  // order keeps the sums bit-identical across thread counts.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int64_t p = int64_t(y) * W + x;
      const int32_t f = tri[p];
      if (f < 0) continue;
      const float m = mask ? mask[p] : 1.0f;
      if (!(m > 0)) continue;
      const Vec3<float> a = cam_vert(faces[3 * size_t(f)]), b = cam_vert(faces[3 * size_t(f) + 1]),
                        c = cam_vert(faces[3 * size_t(f) + 2]);
      const Vec3<float> n = cross(b - a, c - a);
      const Vec3<float> ray((float(x) + 0.5f - cam.cx) / cam.fx, (float(y) + 0.5f - cam.cy) / cam.fy, 1.0f);
      const float nn = norm(n) * norm(ray);
      if (!(nn > 0)) continue;  // degenerate face: seen at no angle
      const float w = m * std::abs(dot(n, ray)) / nn;
      const BilinearTap<float> t = bilinear_tap(tex_width, tex_height, uv[2 * p], uv[2 * p + 1]);
      evidence[t.i00] += w * (1 - t.fx) * (1 - t.fy);
      evidence[t.i01] += w * t.fx * (1 - t.fy);
      evidence[t.i10] += w * (1 - t.fx) * t.fy;
      evidence[t.i11] += w * t.fx * t.fy;
    }
}

double evidence_share_below(const std::vector<float>& evidence, const TextureCharts& charts, double threshold) {
  int64_t n = 0, below = 0;
  for (size_t t = 0; t < charts.face.size() && t < evidence.size(); ++t)
    if (charts.face[t] >= 0) {
      ++n;
      below += double(evidence[t]) < threshold;
    }
  return n ? double(below) / double(n) : 0.0;
}

}  // namespace haha
