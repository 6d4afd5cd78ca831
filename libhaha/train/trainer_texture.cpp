// The texture where the video barely looked: per-texel evidence, the prior's weights and
// the fill after stage 2 (train/texture_evidence.h, texture_smooth.h, texture_fill.h).
#include <cstdio>

#include "train/mesh_coverage.h"
#include "train/texture_evidence.h"
#include "train/texture_fill.h"
#include "train/texture_smooth.h"
#include "train/trainer_impl.h"

namespace haha {

std::vector<float> Trainer::Impl::compute_texture_evidence() const {
  if (texture.empty() || frame_verts.size() != size_t(nf)) return {};
  std::vector<float> e(size_t(tex_size) * tex_size, 0.0f);
  MeshRaster r;
  std::vector<float> uv;
  for (int i = 0; i < nf; ++i) {  // every frame once: the taps of one epoch of draws
    const TrainFrame& f = in.frames[size_t(i)];
    const float* verts = frame_verts[size_t(i)].data();
    rasterize_mesh(f.camera, MeshView{verts, body.num_verts, body.faces.data(), body.num_faces}, r);
    const int np = f.camera.width * f.camera.height;
    uv.resize(2 * size_t(np));
    interpolate(np, r.tri.data(), r.bary.data(), body.ft.data(), body.vt.data(), 2, uv.data());
    accumulate_texture_evidence(f.camera, verts, body.faces.data(), r.tri.data(), uv.data(),
                                f.mask.empty() ? nullptr : f.mask.data(), tex_size, tex_size, e.data());
  }
  return e;
}

void Trainer::Impl::update_texture_evidence() {
  const size_t n = size_t(tex_size) * tex_size;
  if (tex_evidence.size() == n && tex_charts.face.size() == n) return;
  tex_evidence = compute_texture_evidence();
  tex_charts = texture_charts(body, tex_size, tex_size);
  tex_smooth_w = smooth_weights(tex_evidence, tex_charts, cfg.s2.evidence_full);
}

void Trainer::Impl::finish_texture(std::string& event) {
  if (texture.empty() || frame_verts.size() != size_t(nf)) return;
  update_texture_evidence();
  if (tex_evidence.size() != texture.size() / 3) return;
  char buf[200];
  if (!cfg.s2.fill) {
    std::snprintf(buf, sizeof buf, "texture: %.1f%% of chart texels below evidence %g (not filled)",
                  100 * evidence_share_below(tex_evidence, tex_charts, cfg.s2.evidence_full), cfg.s2.evidence_full);
  } else {
    FillOptions opt;
    opt.evidence_full = cfg.s2.evidence_full;
    opt.iterations = cfg.s2.fill_iterations;
    const FillReport f = fill_low_evidence(body, tex_charts, tex_evidence, opt, texture);
    std::snprintf(buf, sizeof buf,
                  "texture fill: %.1f%% of chart texels below evidence %g (%.1f%% unseen), %lld seam links",
                  100.0 * double(f.low_texels) / double(std::max<int64_t>(1, f.chart_texels)), cfg.s2.evidence_full,
                  100.0 * double(f.unseen_texels) / double(std::max<int64_t>(1, f.chart_texels)),
                  (long long)f.seam_links);
  }
  event += (event.empty() ? "" : "; ") + std::string(buf);
  learn_coverage(event);
}

void Trainer::Impl::learn_coverage(std::string& event) {
  if (!cfg.s2.coverage || !coverage.empty() || frame_verts.size() != size_t(nf)) return;
  std::vector<CoverageFrame> frames;
  for (int i = 0; i < nf; ++i) {
    const TrainFrame& f = in.frames[size_t(i)];
    if (!f.mask.empty()) frames.push_back({&f.camera, frame_verts[size_t(i)].data(), f.mask.data()});
  }
  if (frames.empty()) return;  // no mattes: nothing says where the person is not
  CoverageReport rep;
  coverage = learn_mesh_coverage(body.num_verts, body.faces.data(), body.num_faces, frames, kMinCoverageWeight, &rep);
  char buf[160];
  std::snprintf(buf, sizeof buf, "mesh coverage: %d of %d vertices cut (%.1f%%) by %zu mattes", rep.cut_vertices,
                rep.vertices, 100.0 * rep.cut_vertices / std::max(1, rep.vertices), frames.size());
  event += (event.empty() ? "" : "; ") + std::string(buf);
}

}  // namespace haha
