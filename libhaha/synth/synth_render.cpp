// Posing and rendering the synthetic subject (ground truth: the clothed geometry itself).
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "render/texture.h"
#include "synth/synth_internal.h"
#include "synth/synth_subject.h"

namespace haha {

namespace synth {

V3 view_shade(V3 c, V3 n, V3 v, double s) {
  if (!(s > 0)) return c;
  if (dot(n, v) < 0) n = -1.0 * n;
  static const V3 light = unit(V3(0.35, 0.75, 0.55));  // above, in front, to the subject's left
  const double nv = clamp(dot(n, v), 0.0, 1.0);
  const double rim = std::pow(1 - nv, 3);
  const double spec = std::pow(std::max(0.0, dot(n, unit(light + v))), 24);
  V3 out = (1 + s * (0.6 * rim - 0.15)) * c + V3(1, 1, 1) * (0.35 * s * spec);
  for (int k = 0; k < 3; ++k) out[k] = clamp(out[k], 0.0, 1.0);
  return out;
}

}  // namespace synth

namespace {

unsigned part_of(const SynthMesh& m) { return m.part; }

}  // namespace

double default_view_shading(int subject) { return subject == 2 ? 0.5 : 0.0; }

void SynthRenderer::set_view_shading(double strength) {
  if (!(strength >= 0 && strength <= 2)) fail("--view-shading", "must be in [0, 2]");
  view_shading_ = strength;
}

SynthRenderer::SynthRenderer(const BodyModel& body, const SynthSubject& subject)
    : body_(body), subject_(subject), lbs_(body) {
  if (subject.body_texture.empty() || subject.body_texture.channels != 3)
    fail("synthetic subject", "body texture missing");
  if (subject.rest_verts.size() != size_t(body.num_verts) * 3)
    fail("synthetic subject", "was built for a different body model");
  for (const SynthMesh& m : subject.meshes)
    if (m.texture == 1 && (subject.garment_texture.empty() || subject.garment_texture.channels != 3))
      fail("synthetic subject", "garment texture missing");
}

void SynthRenderer::pose(const SmplxParams& p, unsigned parts, std::vector<float>& verts) {
  const int Vb = body_.num_verts;
  size_t total = (parts & kSynthBody) ? size_t(Vb) : 0;
  for (const SynthMesh& m : subject_.meshes)
    if (parts & part_of(m)) total += size_t(m.num_verts());
  verts.resize(3 * total);

  // The body pass also yields the joint transforms the garments are skinned with.
  SmplxParams q = p;
  if (q.betas.empty()) q.betas = subject_.betas;
  float* body_out = verts.data();
  if (!(parts & kSynthBody)) {
    verts_.resize(size_t(Vb) * 3);
    body_out = verts_.data();
  }
  lbs_.forward(q, body_out, nullptr, &cache_);
  const std::vector<Rigid<float>>& A = cache_.skinning;
  const Vec3f tr(q.transl[0], q.transl[1], q.transl[2]);

  size_t off = (parts & kSynthBody) ? size_t(Vb) : 0;
  for (const SynthMesh& m : subject_.meshes) {
    if (!(parts & part_of(m))) continue;
    float* out = verts.data() + 3 * off;
    parallel_for(m.num_verts(), [&](int64_t v) {
      const Vec3f x = Vec3f::load(&m.rest[3 * v]);
      Vec3f acc(0.f, 0.f, 0.f);
      for (int k = m.w_start[v]; k < m.w_start[v + 1]; ++k) acc += m.w_value[k] * A[m.w_joint[k]].apply(x);
      (acc + tr).store(out + 3 * v);
    });
    off += size_t(m.num_verts());
  }
}

void SynthRenderer::render(const Camera& cam, const SmplxParams& p, int supersample, unsigned parts, Image& rgb,
                           Image& mask, Image* garment) {
  if (supersample < 1 || supersample > 8) fail("synth render", "supersample must be in [1, 8]");
  if (cam.width < 1 || cam.height < 1) fail("synth render", "empty camera");
  const int ss = supersample;

  // Faces of the selected parts (rebuilt only when the selection changes).
  if (faces_parts_ != parts || faces_.empty()) {
    faces_.clear();
    ranges_.clear();
    int vert_off = 0;
    if (parts & kSynthBody) {
      faces_.assign(body_.faces.begin(), body_.faces.end());
      ranges_.push_back({0, body_.num_faces, 0, 0.0f, false, body_.vt.data(), body_.ft.data()});
      vert_off = body_.num_verts;
    }
    for (const SynthMesh& m : subject_.meshes) {
      if (!(parts & part_of(m))) continue;
      ranges_.push_back({int(faces_.size() / 3), m.num_faces(), m.texture, m.gloss, m.garment, m.vt.data(), m.ft.data()});
      for (int32_t i : m.faces) faces_.push_back(i + vert_off);
      vert_off += m.num_verts();
    }
    faces_parts_ = parts;
  }

  std::vector<float> verts;
  pose(p, parts, verts);
  Camera big = cam;
  big.width = cam.width * ss;
  big.height = cam.height * ss;
  big.fx = cam.fx * ss;
  big.fy = cam.fy * ss;
  big.cx = cam.cx * ss;  // pixel-edge convention: continuous coordinates scale exactly
  big.cy = cam.cy * ss;
  rasterize_mesh(big, MeshView{verts.data(), int(verts.size() / 3), faces_.data(), int(faces_.size() / 3)}, raster_);

  // View-dependent shading: posed vertex normals of the glossy ranges, the camera centre.
  const bool shading = view_shading_ > 0;
  Vec3f eye(0.f, 0.f, 0.f);
  if (shading) {
    normals_.assign(verts.size(), 0.0f);
    for (const Range& R : ranges_) {
      if (!(R.gloss > 0)) continue;
      for (int f = R.first_face; f < R.first_face + R.num_faces; ++f) {
        const int32_t* t = &faces_[3 * size_t(f)];
        const Vec3f a = Vec3f::load(&verts[3 * size_t(t[0])]), b = Vec3f::load(&verts[3 * size_t(t[1])]),
                    c = Vec3f::load(&verts[3 * size_t(t[2])]);
        const Vec3f fn = cross(b - a, c - a);
        for (int k = 0; k < 3; ++k)
          for (int d = 0; d < 3; ++d) normals_[3 * size_t(t[k]) + d] += fn[d];
      }
    }
    eye = -(transpose(cam.R) * cam.t);
  }

  const TextureView tex[2] = {
      {subject_.body_texture.width, subject_.body_texture.height, 3, subject_.body_texture.data.data()},
      {subject_.garment_texture.width, subject_.garment_texture.height, 3, subject_.garment_texture.data.data()}};
  const int W = cam.width, H = cam.height, BW = big.width;
  rgb = Image(W, H, 3);
  mask = Image(W, H, 1);
  if (garment) *garment = Image(W, H, 1);
  const float inv = 1.0f / float(ss * ss);
  parallel_for(H, [&](int64_t y) {
    for (int x = 0; x < W; ++x) {
      float acc[3] = {0, 0, 0};
      int covered = 0, on_garment = 0;
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          const size_t q = size_t(y * ss + sy) * BW + size_t(x) * ss + sx;
          const int32_t t = raster_.tri[q];
          if (t < 0) continue;
          size_t r = 0;
          while (r + 1 < ranges_.size() && t >= ranges_[r + 1].first_face) ++r;
          const Range& R = ranges_[r];
          on_garment += R.garment ? 1 : 0;
          const int lf = t - R.first_face;
          const float* b = &raster_.bary[3 * q];
          float u = 0, v = 0;
          for (int i = 0; i < 3; ++i) {
            const int ti = R.ft[3 * lf + i];
            u += b[i] * R.vt[2 * ti];
            v += b[i] * R.vt[2 * ti + 1];
          }
          float c[3];
          bilinear_sample(tex[R.texture], u, v, c);
          if (shading && R.gloss > 0) {
            synth::V3 n(0, 0, 0), x(0, 0, 0);
            for (int i = 0; i < 3; ++i) {
              const size_t vi = size_t(faces_[3 * size_t(t) + i]);
              n += double(b[i]) * synth::V3(normals_[3 * vi], normals_[3 * vi + 1], normals_[3 * vi + 2]);
              x += double(b[i]) * synth::V3(verts[3 * vi], verts[3 * vi + 1], verts[3 * vi + 2]);
            }
            const synth::V3 view = synth::unit(synth::V3(eye.x, eye.y, eye.z) - x);
            const synth::V3 o = synth::view_shade(synth::V3(c[0], c[1], c[2]), synth::unit(n), view,
                                                  view_shading_ * R.gloss);
            for (int k = 0; k < 3; ++k) c[k] = float(o[k]);
          }
          for (int k = 0; k < 3; ++k) acc[k] += c[k];
          ++covered;
        }
      const size_t o = size_t(y) * W + x;
      for (int k = 0; k < 3; ++k) rgb.data[3 * o + k] = acc[k] * inv;  // black background
      mask.data[o] = float(covered) * inv;
      if (garment) garment->data[o] = float(on_garment) * inv;
    }
  });
}

Camera synth_camera(const SynthRenderer& renderer, const std::vector<const SmplxParams*>& frames, int size,
                    double distance, double fill) {
  if (frames.empty()) fail("synth camera", "no frames");
  if (size < 1 || !(distance > 0) || !(fill > 0 && fill <= 1)) fail("synth camera", "bad size, distance or fill");
  const int n = int(frames.size());
  std::vector<SynthRenderer> pool(size_t(std::max(1, num_threads())), renderer);
  std::vector<std::vector<float>> scratch(pool.size());
  // Per-frame results, reduced in frame order afterwards (deterministic).
  std::vector<double> box(size_t(n) * 6);
  parallel_for_dynamic(n, [&](int64_t i) {
    const size_t t = size_t(thread_index());
    std::vector<float>& v = scratch[t];
    pool[t].pose(*frames[i], kSynthAll, v);
    double* b = &box[size_t(i) * 6];
    for (int c = 0; c < 3; ++c) b[c] = 1e30, b[3 + c] = -1e30;
    for (size_t k = 0; k < v.size(); ++k) b[k % 3] = std::min(b[k % 3], double(v[k])), b[3 + k % 3] = std::max(b[3 + k % 3], double(v[k]));
  });
  double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], box[size_t(i) * 6 + c]), hi[c] = std::max(hi[c], box[size_t(i) * 6 + 3 + c]);
  // Camera on the +Z side looking along -Z, level. OpenCV axes in world terms:
  // x_cam = +X, y_cam = -Y (image rows go down while the body's Y goes up), z_cam = -Z.
  Camera cam;
  cam.width = cam.height = size;
  cam.R = Mat3f::from_cols({1, 0, 0}, {0, -1, 0}, {0, 0, -1});  // symmetric: rows = columns
  const Vec3f C(float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[1] + hi[1])), float(0.5 * (lo[2] + hi[2]) + distance));
  cam.t = -(cam.R * C);
  std::vector<double> ext(size_t(n), 0.0);
  parallel_for_dynamic(n, [&](int64_t i) {
    const size_t t = size_t(thread_index());
    std::vector<float>& v = scratch[t];
    pool[t].pose(*frames[i], kSynthAll, v);
    double e = 0;
    for (size_t k = 0; k < v.size(); k += 3) {
      const Vec3f xc = cam.to_camera(Vec3f(v[k], v[k + 1], v[k + 2]));
      if (!(xc.z > 0.1f)) {
        e = -1;  // behind the camera
        break;
      }
      e = std::max({e, std::abs(double(xc.x) / xc.z), std::abs(double(xc.y) / xc.z)});
    }
    ext[size_t(i)] = e;
  });
  double extent = 1e-9;
  for (double e : ext) {
    if (e < 0) fail("synth camera", "subject reaches behind the camera: increase the distance");
    extent = std::max(extent, e);
  }
  const float f = float(fill * 0.5 * size / extent);
  cam.fx = cam.fy = f;
  cam.cx = cam.cy = 0.5f * size;
  cam.near_plane = 0.05f;
  cam.far_plane = float(distance * 4 + 10);
  return cam;
}

Camera synth_view_camera(SynthRenderer& renderer, const SmplxParams& frame, int size, double distance,
                         double elevation, double fill) {
  if (size < 1 || !(distance > 0) || !(fill > 0 && fill <= 1) || !(std::abs(elevation) < 1.5))
    fail("synth camera", "bad size, distance, elevation or fill");
  std::vector<float> v;
  renderer.pose(frame, kSynthAll, v);
  double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
  for (size_t k = 0; k < v.size(); ++k)
    lo[k % 3] = std::min(lo[k % 3], double(v[k])), hi[k % 3] = std::max(hi[k % 3], double(v[k]));
  // Rows of R are the camera's axes in world terms (OpenCV): x = +X, z = the view direction,
  // y = z x x (down in the image); at elevation 0 this is synth_camera's rotation.
  const double se = std::sin(elevation), ce = std::cos(elevation);
  const Vec3f x(1, 0, 0), z(0, float(-se), float(-ce)), y(0, float(-ce), float(se));
  Camera cam;
  cam.width = cam.height = size;
  for (int c = 0; c < 3; ++c) cam.R.a[0][c] = x[c], cam.R.a[1][c] = y[c], cam.R.a[2][c] = z[c];
  const Vec3f C(float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[1] + hi[1]) + distance * se),
                float(0.5 * (lo[2] + hi[2]) + distance * ce));
  cam.t = -(cam.R * C);
  double extent = 1e-9;
  for (size_t k = 0; k < v.size(); k += 3) {
    const Vec3f xc = cam.to_camera(Vec3f(v[k], v[k + 1], v[k + 2]));
    if (!(xc.z > 0.1f)) fail("synth camera", "subject reaches behind the camera: increase the distance");
    extent = std::max({extent, std::abs(double(xc.x) / xc.z), std::abs(double(xc.y) / xc.z)});
  }
  cam.fx = cam.fy = float(fill * 0.5 * size / extent);
  cam.cx = cam.cy = 0.5f * size;
  cam.near_plane = 0.05f;
  cam.far_plane = float(distance * 4 + 10);
  return cam;
}

}  // namespace haha
