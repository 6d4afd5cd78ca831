#include "train/mesh_coverage.h"

#include <algorithm>

#include "body/avatar.h"
#include "core/error.h"
#include "render/mesh_raster.h"

namespace haha {

std::vector<float> learn_mesh_coverage(int num_verts, const int32_t* faces, int num_faces,
                                       const std::vector<CoverageFrame>& frames, double min_weight,
                                       CoverageReport* report) {
  std::vector<double> in(size_t(num_verts), 0.0), all(size_t(num_verts), 0.0);
  MeshRaster r;
  for (const CoverageFrame& f : frames) {
    if (!f.camera || !f.verts || !f.matte) fail("mesh coverage", "a frame without camera, vertices or matte");
    rasterize_mesh(*f.camera, MeshView{f.verts, num_verts, faces, num_faces}, r);
    const int64_t P = r.num_pixels();
    for (int64_t p = 0; p < P; ++p) {  // serial: the votes scatter into shared vertices
      const int t = r.tri[size_t(p)];
      if (t < 0) continue;
      const double m = f.matte[p];
      for (int i = 0; i < 3; ++i) {
        const size_t v = size_t(faces[3 * int64_t(t) + i]);
        const double b = r.bary[3 * size_t(p) + size_t(i)];
        in[v] += b * m;
        all[v] += b;
      }
    }
  }
  std::vector<float> c(size_t(num_verts), 1.0f);
  CoverageReport rep;
  rep.vertices = num_verts;
  for (size_t v = 0; v < c.size(); ++v) {
    if (all[v] < min_weight) {
      rep.unjudged += all[v] > 0;
      continue;
    }
    c[v] = float(std::clamp(in[v] / all[v], 0.0, 1.0));
    rep.cut_vertices += c[v] < kCoverageCutoff;
  }
  if (report) *report = rep;
  return c;
}

}  // namespace haha
