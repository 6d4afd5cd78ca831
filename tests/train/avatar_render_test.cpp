// The avatar render chain (posed body -> Gaussians / textured mesh -> merge) and its
// backward, as the trainer uses it. The pieces (face frames, rasterizers, merge) have their
// own double-precision finite-difference tests; this checks the glue: every gradient
// output against central differences of the chained float forward, along random
// directions (which averages float noise), with a relative tolerance of 3%. The
// silhouette union is checked in double precision.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "body/lbs.h"
#include "render/avatar_render.h"
#include "render/mesh_antialias.h"
#include "train/image_loss.h"
#include "support/train_test_scene.h"

namespace haha {
namespace {

using test::scene_camera;
using test::scene_pose;
using test::scene_truth;

constexpr int kSize = 48;

struct Scene {
  Avatar a = scene_truth(16, 1.0f);
  Camera cam = scene_camera(kSize);
  std::vector<float> verts;
  std::vector<float> weights;  // fixed random image weights: L = sum w . I + sum wa . A
  std::vector<float> walpha;
  std::vector<int32_t> neighbors = mesh_face_neighbors(a.body.faces.data(), a.body.num_faces, a.body.num_verts);
  explicit Scene(bool few = false) {
    a.texture.rgb[5] = 0.9f;
    Lbs<float> lbs(a.body);
    verts.resize(3 * size_t(a.body.num_verts));
    lbs.forward(scene_pose(1, 6), verts.data(), nullptr, nullptr);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1, 1);
    weights.resize(3 * kSize * kSize);
    walpha.resize(kSize * kSize);
    for (float& w : weights) w = u(rng);
    for (float& w : walpha) w = u(rng);
    BoundGaussians& g = a.gaussians;
    if (few) {
      // Three Gaussians far apart (first, middle, last head face), large, anisotropic,
      // rotated, semi-transparent: few pixels near the hard cuts, no overlaps.
      const int n = g.size();
      BoundGaussians k;
      for (int i : {0, n / 2, n - 1}) {
        k.face.push_back(g.face[size_t(i)]);
        k.offset.insert(k.offset.end(), {0.1f, 2.0f, -0.2f});
        k.rotation.insert(k.rotation.end(), {0.9f, 0.3f, -0.2f, 0.25f});
        k.scale.insert(k.scale.end(), {0.35f, 0.2f, 0.12f});
        k.color.insert(k.color.end(), {0.8f, 0.3f, 0.5f});
        k.opacity.push_back(0.6f);
      }
      g = k;
    }
  }
};
// The scene's render request for these vertices, Gaussians and texture (it points into
// itself and the arguments: keep them alive, do not copy).
struct SceneRequest {
  TextureView tv;
  GaussianSetView gv;
  BodyTopology topology;
  AvatarRenderRequest req;
  SceneRequest(const Scene& s, const std::vector<float>& verts, const BoundGaussians& g, const std::vector<float>& tex,
               bool mesh, bool gauss)
      : tv{s.a.texture.width, s.a.texture.height, 3, tex.data()},
        gv{g.size(), g.face.data(), g.offset.data(), g.rotation.data(), g.scale.data(), g.color.data(), g.opacity.data()},
        topology(topology_of(s.a.body)) {
    req.camera = &s.cam;
    req.body = &topology;
    req.verts = verts.data();
    req.face_scale_divisor = s.a.face_scale_divisor;
    req.gaussians = gauss ? &gv : nullptr;
    req.texture = mesh ? &tv : nullptr;
    req.background[0] = 0.2f;
    req.background[2] = 0.7f;
  }
  SceneRequest(const SceneRequest&) = delete;
};

double loss_of(const Scene& s, const std::vector<float>& verts, const BoundGaussians& g, const std::vector<float>& tex,
               bool mesh, bool gauss, AvatarRenderBuffers& buf) {
  const SceneRequest r(s, verts, g, tex, mesh, gauss);
  render_avatar(r.req, buf);
  double L = 0;
  for (size_t i = 0; i < buf.image.size(); ++i) L += double(s.weights[i]) * buf.image[i];
  for (size_t i = 0; i < buf.alpha.size(); ++i) L += double(s.walpha[i]) * buf.alpha[i];
  return L;
}

// Directional check of one buffer: dL/dx . d against (L(x + h d) - L(x - h d)) / 2h.
template <class Eval>
void check_direction(const char* what, const std::vector<float>& grad, Eval&& eval_at, float h, int seed) {
  std::mt19937 rng(static_cast<uint32_t>(seed));
  std::normal_distribution<float> nd(0, 1);
  std::vector<float> d(grad.size());
  for (float& x : d) x = nd(rng);
  double an = 0;
  for (size_t i = 0; i < grad.size(); ++i) an += double(grad[i]) * d[i];
  const double fd = (eval_at(d, h) - eval_at(d, -h)) / (2.0 * h);
  EXPECT_NEAR(an, fd, 0.03 * std::max(std::fabs(fd), std::fabs(an)) + 1e-4) << what;
  EXPECT_GT(std::fabs(an), 1e-3) << what << ": gradient vanishes, the check would be empty";
}

// Zero the loss weights of pixels near a hard cut of the forward, where finite differences
// see jumps the (correct) gradient ignores: the alpha cut-off band of each Gaussian, the
// depth test (centre z close to D) and the mesh silhouette (visibility is held fixed).
int mask_hard_cuts(Scene& s, const AvatarRenderBuffers& buf, bool mesh) {
  const int W = kSize, H = kSize;
  int kept = 0;  // weighted pixels that see the mesh or a Gaussian
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int p = y * W + x;
      bool cut = false;
      for (size_t i = 0; i < buf.raster.proj.size(); ++i) {
        if (buf.raster.radii[i] <= 0) continue;
        const auto& g = buf.raster.proj[i];
        const float dx = x + 0.5f - g.mx, dy = y + 0.5f - g.my;
        const float alpha = g.opacity * std::exp(-0.5f * (g.ca * dx * dx + g.cc * dy * dy) - g.cb * dx * dy);
        if (alpha > 0.2f / 255 && alpha < 4.0f / 255) cut = true;
        if (mesh && std::fabs(g.z - buf.mesh.depth[p]) < 0.01f) cut = true;
      }
      if (mesh) {  // silhouette and occlusion edges: coverage or depth jumps to a neighbour
        const auto& r = buf.mesh_render.raster;
        for (int k = 0; k < 4; ++k) {
          const int xx = x + (k == 0) - (k == 1), yy = y + (k == 2) - (k == 3);
          if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
          const size_t q = size_t(yy * W + xx);
          if ((r.tri[q] >= 0) != (r.tri[size_t(p)] >= 0)) cut = true;
          if (r.tri[q] >= 0 && r.tri[size_t(p)] >= 0 && std::fabs(r.depth[q] - r.depth[size_t(p)]) > 0.1f) cut = true;
        }
      }
      if (cut) {
        s.walpha[size_t(p)] = 0;
        for (int c = 0; c < 3; ++c) s.weights[3 * size_t(p) + c] = 0;
      } else if ((mesh && buf.mesh.mask[p] > 0) || buf.alpha[size_t(p)] > 0) {
        ++kept;
      }
    }
  return kept;
}

void run_case(bool mesh, bool gauss) {
  Scene s(true);
  AvatarRenderBuffers buf;
  const BoundGaussians& g = s.a.gaussians;
  const size_t n = size_t(g.size()), nv = s.verts.size();
  loss_of(s, s.verts, g, s.a.texture.rgb, mesh, gauss, buf);
  if (gauss) {
    int visible = 0;
    for (size_t i = 0; i < n; ++i) visible += buf.raster.radii[i] > 0;
    ASSERT_EQ(visible, 3);
  }
  const int kept = mask_hard_cuts(s, buf, mesh);
  EXPECT_GT(kept, mesh && gauss ? 150 : 40) << "too few pixels left to test";
  std::vector<float> dv(nv, 0.0f), doff(3 * n, 0.0f), drot(4 * n, 0.0f), dsc(3 * n, 0.0f), dcol(3 * n, 0.0f),
      dop(n, 0.0f), dtex(s.a.texture.rgb.size(), 0.0f), dmeans(3 * n);
  std::mt19937 rng(3);
  std::normal_distribution<float> nd(0, 1);
  for (float& x : dmeans) x = nd(rng);  // an extra regulariser gradient on the world means
  const SceneRequest sr(s, s.verts, g, s.a.texture.rgb, mesh, gauss);
  const AvatarRenderRequest& req = sr.req;
  render_avatar(req, buf);
  AvatarRenderGrads gr{dv.data(), doff.data(), drot.data(), dsc.data(), dcol.data(), dop.data(), dtex.data(), nullptr};
  render_avatar_backward(req, buf, s.weights.data(), s.walpha.data(), gauss ? dmeans.data() : nullptr, gr);
  // With the extra means gradient the loss is L + dmeans . means (means posed from verts, g).
  auto means_term = [&](const std::vector<float>& verts, const BoundGaussians& gg) {
    if (!gauss) return 0.0;
    AvatarRenderBuffers b2;
    const GaussianSetView v{gg.size(), gg.face.data(), gg.offset.data(), gg.rotation.data(),
                            gg.scale.data(), gg.color.data(), gg.opacity.data()};
    AvatarRenderRequest r = req;
    r.verts = verts.data();
    r.gaussians = &v;
    r.texture = nullptr;
    render_avatar(r, b2);
    double t = 0;
    for (size_t i = 0; i < 3 * n; ++i) t += double(dmeans[i]) * b2.means[i];
    return t;
  };
  AvatarRenderBuffers tmp;
  auto full = [&](const std::vector<float>& verts, const BoundGaussians& gg, const std::vector<float>& tex) {
    return loss_of(s, verts, gg, tex, mesh, gauss, tmp) + means_term(verts, gg);
  };
  if (mesh)
    check_direction("texture", dtex, [&](const std::vector<float>& d, float h) {
      std::vector<float> t = s.a.texture.rgb;
      for (size_t i = 0; i < t.size(); ++i) t[i] += h * d[i];
      return full(s.verts, g, t);
    }, 1e-2f, 1);
  if (gauss) {
    auto check_g = [&](const char* what, const std::vector<float>& grad, std::vector<float> BoundGaussians::*field,
                       float h, int seed) {
      check_direction(what, grad, [&](const std::vector<float>& d, float hh) {
        BoundGaussians x = g;
        for (size_t i = 0; i < grad.size(); ++i) (x.*field)[i] += hh * d[i];
        return full(s.verts, x, s.a.texture.rgb);
      }, h, seed);
    };
    check_g("colour", dcol, &BoundGaussians::color, 1e-2f, 2);
    check_g("opacity", dop, &BoundGaussians::opacity, 1e-3f, 3);
    check_g("offset", doff, &BoundGaussians::offset, 2e-3f, 4);
    check_g("scale", dsc, &BoundGaussians::scale, 1e-3f, 5);
    check_g("rotation", drot, &BoundGaussians::rotation, 2e-3f, 6);
  }
  check_direction("vertices", dv, [&](const std::vector<float>& d, float h) {
    std::vector<float> v = s.verts;
    for (size_t i = 0; i < v.size(); ++i) v[i] += h * d[i];
    return full(v, g, s.a.texture.rgb);
  }, 1e-4f, 7);
}

// The antialiased mesh in the merged render: the orchestration's forward and backward equal
// the pieces composed by hand (render_mesh -> antialias -> merge over the background, and
// back through merge, antialias_backward and render_mesh_backward), each of which has its
// own finite-difference test in double. The antialiased layer has partly covered pixels and
// its vertex gradient differs from the hard silhouette's (the silhouette's share).
TEST(AvatarRender, AntialiasedMeshMatchesThePiecesComposed) {
  Scene s;
  const int P = kSize * kSize;
  const TextureView tv{s.a.texture.width, s.a.texture.height, 3, s.a.texture.rgb.data()};
  AvatarRenderRequest req;
  req.camera = &s.cam;
  BodyTopology topology = topology_of(s.a.body);
  topology.face_neighbors = s.neighbors.data();
  req.body = &topology;
  req.verts = s.verts.data();
  req.texture = &tv;
  req.antialias = true;
  const float bg[3] = {0.2f, 0.0f, 0.7f};
  for (int c = 0; c < 3; ++c) req.background[c] = bg[c];
  AvatarRenderBuffers buf;
  render_avatar(req, buf);
  std::vector<float> dv(s.verts.size(), 0.0f);
  AvatarRenderGrads gr;
  gr.verts = dv.data();
  render_avatar_backward(req, buf, s.weights.data(), nullptr, nullptr, gr);

  // By hand.
  MeshRenderInput in;
  in.verts = s.verts.data();
  in.num_verts = s.a.body.num_verts;
  in.faces = s.a.body.faces.data();
  in.num_faces = s.a.body.num_faces;
  in.uv = s.a.body.vt.data();
  in.num_uv = s.a.body.num_uv();
  in.uv_faces = s.a.body.ft.data();
  in.texture = tv;
  MeshRender mr;
  render_mesh(s.cam, in, mr);
  AntialiasInputsT<float> ai;
  ai.camera = s.cam;
  ai.mesh = {s.verts.data(), in.num_verts, in.faces, in.num_faces};
  ai.neighbors = s.neighbors.data();
  ai.tri = mr.raster.tri.data();
  ai.depth = mr.raster.depth.data();
  ai.color = mr.color.data();
  ai.mask = mr.raster.mask.data();
  std::vector<float> M(3 * size_t(P)), m(static_cast<size_t>(P)), image(3 * size_t(P));
  antialias(ai, M.data(), m.data());
  int partial = 0;
  for (int p = 0; p < P; ++p) {
    partial += m[size_t(p)] > 0 && m[size_t(p)] < 1;
    for (int c = 0; c < 3; ++c) image[3 * size_t(p) + c] = m[size_t(p)] * M[3 * size_t(p) + c] + (1 - m[size_t(p)]) * bg[c];
  }
  EXPECT_GT(partial, 30) << "the silhouette is antialiased";
  for (size_t i = 0; i < image.size(); ++i) ASSERT_NEAR(buf.image[i], image[i], 1e-6) << "image value " << i;
  std::vector<float> dM(3 * size_t(P)), dm(static_cast<size_t>(P)), dcol(3 * size_t(P), 0.0f), dv_hand(s.verts.size(), 0.0f);
  for (int p = 0; p < P; ++p) {
    double g = 0;
    for (int c = 0; c < 3; ++c) {
      const float w = s.weights[3 * size_t(p) + c];
      dM[3 * size_t(p) + c] = m[size_t(p)] * w;
      g += w * (M[3 * size_t(p) + c] - bg[c]);
    }
    dm[size_t(p)] = float(g);
  }
  antialias_backward(ai, dM.data(), dm.data(), dcol.data(), nullptr, dv_hand.data());
  render_mesh_backward(s.cam, in, mr, dcol.data(), nullptr, nullptr, dv_hand.data());
  double scale = 0, diff_hard = 0;
  for (float x : dv_hand) scale = std::max(scale, double(std::fabs(x)));
  for (size_t i = 0; i < dv.size(); ++i) EXPECT_NEAR(dv[i], dv_hand[i], 1e-4 * scale) << "vertex coordinate " << i;

  std::vector<float> dv_hard(s.verts.size(), 0.0f);
  req.antialias = false;
  AvatarRenderBuffers hard;
  render_avatar(req, hard);
  gr.verts = dv_hard.data();
  render_avatar_backward(req, hard, s.weights.data(), nullptr, nullptr, gr);
  for (size_t i = 0; i < dv.size(); ++i) diff_hard = std::max(diff_hard, double(std::fabs(dv[i] - dv_hard[i])));
  EXPECT_GT(diff_hard, 0.1 * scale) << "the silhouette adds to the vertex gradient";
}

TEST(AvatarRender, GaussiansOnlyGradients) { run_case(false, true); }
TEST(AvatarRender, MergedGradients) { run_case(true, true); }
TEST(AvatarRender, MeshOnlyGradients) { run_case(true, false); }

TEST(AvatarRender, MergeLayersAreConsistent) {
  Scene s;
  AvatarRenderBuffers both, mesh_only;
  loss_of(s, s.verts, s.a.gaussians, s.a.texture.rgb, true, true, both);
  loss_of(s, s.verts, s.a.gaussians, s.a.texture.rgb, true, false, mesh_only);
  const int P = kSize * kSize;
  int covered = 0;
  for (int p = 0; p < P; ++p) {
    // I = C_front + (1 - A) * (mesh or background).
    for (int c = 0; c < 3; ++c)
      ASSERT_NEAR(both.image[3 * size_t(p) + c],
                  both.color_front[3 * size_t(p) + c] + (1 - both.alpha[size_t(p)]) * mesh_only.image[3 * size_t(p) + c],
                  1e-5);
    covered += both.mesh.mask[p] > 0;
  }
  EXPECT_GT(covered, 50);
  // Gaussians behind the mesh are hidden: a mesh-covered pixel's alpha never exceeds the
  // alpha of the same Gaussians rendered without occlusion.
  AvatarRenderBuffers gs_only;
  loss_of(s, s.verts, s.a.gaussians, s.a.texture.rgb, false, true, gs_only);
  for (int p = 0; p < P; ++p) ASSERT_LE(both.alpha[size_t(p)], gs_only.alpha[size_t(p)] + 1e-6f);
}

// The merged render's removal cost (AvatarRenderGrads::removal_cost) against rendering the
// avatar again without each Gaussian: the mesh and the background behind the Gaussians
// count, those hidden behind the mesh cost nothing. Float renders: 1e-3 of a pixel plus
// 1e-3 relative (the early stop may act where many Gaussians overlap).
TEST(AvatarRender, RemovalCostIsWhatDeletingEachGaussianChanges) {
  Scene s;
  AvatarRenderBuffers buf, rest;
  loss_of(s, s.verts, s.a.gaussians, s.a.texture.rgb, true, true, buf);
  const std::vector<float> all = buf.image;
  const BoundGaussians& g = s.a.gaussians;
  const int n = g.size();
  ASSERT_GT(n, 20);
  std::vector<float> cost(static_cast<size_t>(n), 0.0f), d_op(static_cast<size_t>(n));
  {
    const SceneRequest r(s, s.verts, g, s.a.texture.rgb, true, true);
    render_avatar(r.req, buf);
    const std::vector<float> d_image(all.size(), 0.0f);
    AvatarRenderGrads gr;
    gr.opacity = d_op.data();
    gr.removal_cost = cost.data();
    render_avatar_backward(r.req, buf, d_image.data(), nullptr, nullptr, gr);
  }
  int shown = 0, hidden = 0;
  for (int i = 0; i < n; i += std::max(1, n / 40)) {
    BoundGaussians k = g;
    k.opacity[size_t(i)] = 0.0f;  // alpha 0 everywhere: as if deleted
    loss_of(s, s.verts, k, s.a.texture.rgb, true, true, rest);
    double want = 0;
    for (size_t q = 0; q < all.size(); ++q) want += std::fabs(double(all[q]) - double(rest.image[q])) / 3;
    EXPECT_NEAR(cost[size_t(i)], want, 1e-3 + 1e-3 * want) << "Gaussian " << i;
    shown += want > 0.05;
    hidden += want == 0.0;
  }
  EXPECT_GT(shown, 5);
  EXPECT_GT(hidden, 0) << "some Gaussians lie behind the mesh";
}

TEST(SilhouetteUnion, GradientMatchesFiniteDifferences) {
  // S = 1 - (1 - m)(1 - A), L = g . S; central differences in double, relative 1e-9.
  const double m[5] = {0.0, 1.0, 0.3, 0.5, 0.9};
  const double a[5] = {0.2, 0.7, 0.0, 1.0, 0.45};
  const double g[5] = {1.0, -2.0, 0.5, 3.0, -0.7};
  double s[5], d[5];
  silhouette_union(m, a, 5, s);
  silhouette_union_backward(m, g, 5, d);
  for (int i = 0; i < 5; ++i) {
    const double h = 1e-6;
    double ap[5], am[5], sp[5], sm[5];
    for (int k = 0; k < 5; ++k) ap[k] = am[k] = a[k];
    ap[i] += h;
    am[i] -= h;
    silhouette_union(m, ap, 5, sp);
    silhouette_union(m, am, 5, sm);
    double fd = 0;
    for (int k = 0; k < 5; ++k) fd += g[k] * (sp[k] - sm[k]) / (2 * h);
    EXPECT_NEAR(d[i], fd, 1e-9 * std::max(1.0, std::fabs(fd)));
  }
  EXPECT_DOUBLE_EQ(s[1], 1.0);  // inside the mesh: covered whatever A is, no gradient to A
  EXPECT_DOUBLE_EQ(d[1], 0.0);
  double z[1];
  silhouette_union<double>(nullptr, nullptr, 1, z);  // nothing: empty silhouette
  EXPECT_DOUBLE_EQ(z[0], 0.0);
}

TEST(GroundTruth, CompositeOverBackground) {
  const float rgb[6] = {0.4f, 0.2f, 0.0f, 0.5f, 0.5f, 0.5f}, mask[2] = {0.5f, 0.0f}, bg[3] = {1.0f, 0.0f, 0.5f};
  float out[6];
  composite_ground_truth(rgb, mask, 2, true, bg, out);  // already on black: rgb + (1 - m) bg
  EXPECT_FLOAT_EQ(out[0], 0.9f);
  EXPECT_FLOAT_EQ(out[3], 1.5f);
  composite_ground_truth(rgb, mask, 2, false, bg, out);  // photo with background: m rgb + (1 - m) bg
  EXPECT_FLOAT_EQ(out[0], 0.7f);
  EXPECT_FLOAT_EQ(out[3], 1.0f);
  EXPECT_FLOAT_EQ(out[5], 0.5f);
}

}  // namespace
}  // namespace haha
