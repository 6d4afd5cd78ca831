// Pack -> unpack round trips of the avatar .glb: --lossless is bit-exact, the default is
// within the stated quantization bounds, and Draco keeps face and point order.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <cstring>

#include "body/lbs.h"
#include "core/error.h"
#include "format/avatar_loader.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/canonical_faces.h"
#include "format/draco_io.h"
#include "format/gaussian_lod.h"
#include "format/glb.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

template <class T>
bool bit_equal(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Per-corner UV values of a body (vt[ft[c]]), so different vt layouts compare by content.
std::vector<float> corner_uvs(const BodyModel& b) {
  std::vector<float> out;
  for (int32_t t : b.ft) out.push_back(b.vt[size_t(t) * 2]), out.push_back(b.vt[size_t(t) * 2 + 1]);
  return out;
}

TEST(FormatRoundTrip, LosslessRestoresEveryParameterBitExact) {
  const Avatar a = test::make_test_avatar();
  PackOptions opt;
  opt.lossless = true;
  opt.pose_correctives = haha::PoseCorrectives::dense;
  const std::vector<uint8_t> glb = pack_avatar(a, opt);
  const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
  const Avatar& b = u.avatar;
  EXPECT_TRUE(bit_equal(a.betas, b.betas));
  EXPECT_TRUE(bit_equal(a.expression, b.expression));
  EXPECT_EQ(std::memcmp(&a.face_scale_divisor, &b.face_scale_divisor, sizeof(float)), 0);
  EXPECT_EQ(a.texture.width, b.texture.width);
  EXPECT_EQ(a.texture.height, b.texture.height);
  EXPECT_TRUE(bit_equal(a.texture.rgb, b.texture.rgb));
  EXPECT_TRUE(bit_equal(a.gaussians.face, b.gaussians.face));
  EXPECT_TRUE(bit_equal(a.gaussians.offset, b.gaussians.offset));
  EXPECT_TRUE(bit_equal(a.gaussians.rotation, b.gaussians.rotation));
  EXPECT_TRUE(bit_equal(a.gaussians.scale, b.gaussians.scale));
  EXPECT_TRUE(bit_equal(a.gaussians.color, b.gaussians.color));
  EXPECT_TRUE(bit_equal(a.gaussians.opacity, b.gaussians.opacity));
  // Body: the rest shape with betas/expression baked, everything else as given.
  EXPECT_EQ(b.body.num_verts, a.body.num_verts);
  EXPECT_EQ(b.body.num_faces, a.body.num_faces);
  EXPECT_TRUE(bit_equal(baked_rest_vertices(a), b.body.v_template));
  EXPECT_EQ(a.body.faces, b.body.faces);
  EXPECT_EQ(a.body.parents, b.body.parents);
  EXPECT_TRUE(bit_equal(a.body.weights, b.body.weights));
  EXPECT_TRUE(bit_equal(a.body.j_regressor, b.body.j_regressor));
  EXPECT_TRUE(bit_equal(a.body.posedirs, b.body.posedirs));
  EXPECT_TRUE(bit_equal(corner_uvs(a.body), corner_uvs(b.body)));
  EXPECT_EQ(b.body.num_shape, 0);
  EXPECT_TRUE(b.body.shapedirs.empty());
  EXPECT_TRUE(u.info.texture_exact);
  EXPECT_EQ(u.info.pose_correctives, "float32");
  // Packing the unpacked avatar again gives the same file (the shape is already baked).
  EXPECT_EQ(pack_avatar(b, opt), glb);
}

TEST(FormatRoundTrip, DefaultPackIsWithinQuantizationBounds) {
  const Avatar a = test::make_test_avatar(2000);
  PackOptions opt;  // defaults, but a lossless 8-bit texture for a tight texture bound
  opt.texture_codec = TextureCodec::png;
  PackedSizes sz;
  const std::vector<uint8_t> glb = pack_avatar(a, opt, &sz);
  const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
  // Lossy packs store the Gaussians sorted by their face's place in the canonical face
  // order, stably, and name faces by it: compare against that order.
  const CanonicalFaces canon = canonical_faces(a.body.faces.data(), a.body.num_faces);
  std::vector<int32_t> rank(canon.order.size());
  for (size_t k = 0; k < canon.order.size(); ++k) rank[size_t(canon.order[k])] = int32_t(k);
  std::vector<int> order(size_t(a.gaussians.size()));
  for (size_t i = 0; i < order.size(); ++i) order[i] = int(i);
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) {
    return rank[size_t(a.gaussians.face[size_t(x)])] < rank[size_t(a.gaussians.face[size_t(y)])];
  });
  BoundGaussians g;
  g.resize(a.gaussians.size());
  for (int i = 0; i < g.size(); ++i) {
    const size_t o = size_t(order[size_t(i)]);
    g.face[size_t(i)] = rank[size_t(a.gaussians.face[o])];
    // The reader's face is the body face, corner for corner.
    for (int c = 0; c < 3; ++c)
      ASSERT_EQ(u.avatar.body.faces[size_t(g.face[size_t(i)]) * 3 + size_t(c)], a.body.faces[size_t(a.gaussians.face[o]) * 3 + size_t(c)]) << i;
    g.opacity[size_t(i)] = a.gaussians.opacity[o];
    for (int k = 0; k < 3; ++k) {
      g.offset[size_t(i) * 3 + k] = a.gaussians.offset[o * 3 + k];
      g.scale[size_t(i) * 3 + k] = a.gaussians.scale[o * 3 + k];
      g.color[size_t(i) * 3 + k] = a.gaussians.color[o * 3 + k];
    }
    for (int k = 0; k < 4; ++k) g.rotation[size_t(i) * 4 + k] = a.gaussians.rotation[o * 4 + k];
  }
  const BoundGaussians& h = u.avatar.gaussians;
  ASSERT_EQ(g.size(), h.size());
  EXPECT_EQ(u.info.gaussian_order, "face");
  EXPECT_EQ(g.face, h.face);  // integers: exact
  const GaussianBits bits;
  // Draco quantizes an attribute over its largest per-component extent R with 2^b - 1
  // steps: rounding error <= R / (2^b - 1) / 2 per component (+ float slack).
  auto range = [](const std::vector<float>& v, int comps) {
    float r = 0;
    for (int c = 0; c < comps; ++c) {
      float lo = INFINITY, hi = -INFINITY;
      for (size_t i = c; i < v.size(); i += comps) lo = std::min(lo, v[i]), hi = std::max(hi, v[i]);
      r = std::max(r, hi - lo);
    }
    return r;
  };
  auto step = [](float r, int b) { return r / float((1 << b) - 1); };
  const float off_tol = 0.5f * step(range(g.offset, 3), bits.offset) * 1.001f + 1e-6f;
  for (size_t i = 0; i < g.offset.size(); ++i) ASSERT_NEAR(g.offset[i], h.offset[i], off_tol) << i;
  const float col_tol = 0.5f * step(range(g.color, 3), bits.color) * 1.001f + 1e-6f;
  for (size_t i = 0; i < g.color.size(); ++i) ASSERT_NEAR(g.color[i], h.color[i], col_tol) << i;
  const float op_tol = 0.5f * step(range(g.opacity, 1), bits.opacity) * 1.001f + 1e-6f;
  for (size_t i = 0; i < g.opacity.size(); ++i) ASSERT_NEAR(g.opacity[i], h.opacity[i], op_tol) << i;
  // log(scale) quantized: relative error <= exp(step / 2) - 1.
  std::vector<float> logs(g.scale.size());
  for (size_t i = 0; i < logs.size(); ++i) logs[i] = std::log(g.scale[i]);
  const float rel = std::exp(0.5f * step(range(logs, 3), bits.scale) * 1.001f) - 1 + 1e-6f;
  for (size_t i = 0; i < g.scale.size(); ++i) ASSERT_NEAR(h.scale[i] / g.scale[i], 1.0f, rel) << i;
  // Rotation, "smallest three": the three stored components (|c| <= 1/sqrt 2, range R <=
  // sqrt 2) within half a step each; the largest (>= 1/2) rebuilt from them moves by at most
  // sum |c_i| |dc_i| / (1/2) <= 1.5 step. So |q - q'| <= sqrt(3/4 + 9/4) step < 2 step, up
  // to the sign of q.
  const float rot_tol = 2.0f * step(std::sqrt(2.0f), bits.rotation) * 1.001f + 1e-6f;
  for (int i = 0; i < g.size(); ++i) {
    const float* p = &g.rotation[size_t(i) * 4];
    const float* q = &h.rotation[size_t(i) * 4];
    double dp = 0, dm = 0;
    for (int k = 0; k < 4; ++k) dp += (p[k] - q[k]) * (p[k] - q[k]), dm += (p[k] + q[k]) * (p[k] + q[k]);
    ASSERT_LE(std::sqrt(std::min(dp, dm)), rot_tol) << i;
  }
  // Texture: 8-bit PNG, error <= half a level.
  ASSERT_EQ(u.avatar.texture.rgb.size(), a.texture.rgb.size());
  for (size_t i = 0; i < a.texture.rgb.size(); ++i) ASSERT_NEAR(a.texture.rgb[i], u.avatar.texture.rgb[i], 0.5f / 255 + 1e-6f);
  // Body: positions and UVs within their quantization steps.
  const std::vector<float> rest = baked_rest_vertices(a);
  const float pos_tol = 0.5f * step(range(rest, 3), MeshBits{}.position) * 1.01f + 1e-6f;
  for (size_t i = 0; i < rest.size(); ++i) ASSERT_NEAR(rest[i], u.avatar.body.v_template[i], pos_tol) << i;
  // Faces come back in the canonical order, each possibly rotated: body face f is face
  // rank[f] there, with the same corners (vertex and UV) in some rotation.
  const std::vector<float> uva = corner_uvs(a.body), uvb = corner_uvs(u.avatar.body);
  ASSERT_EQ(uva.size(), uvb.size());
  const float uv_tol = 0.5f * step(range(a.body.vt, 2), MeshBits{}.texcoord) * 1.01f + 1e-6f;
  for (int f = 0; f < a.body.num_faces; ++f) {
    const size_t k = size_t(rank[size_t(f)]);
    bool found = false;
    for (size_t r = 0; r < 3 && !found; ++r) {
      bool same = true;
      for (size_t c = 0; c < 3; ++c) {
        const size_t x = size_t(f) * 3 + c, y = k * 3 + (c + r) % 3;
        same = same && a.body.faces[x] == u.avatar.body.faces[y] && std::fabs(uva[x * 2] - uvb[y * 2]) <= uv_tol &&
               std::fabs(uva[x * 2 + 1] - uvb[y * 2 + 1]) <= uv_tol;
      }
      found = same;
    }
    ASSERT_TRUE(found) << "body face " << f;
  }
  // Weights: renormalised after 10-bit quantization; all influences kept (test weights >= 1e-4).
  for (size_t i = 0; i < a.body.weights.size(); ++i) ASSERT_NEAR(a.body.weights[i], u.avatar.body.weights[i], 2e-3f) << i;
  EXPECT_EQ(sz.skin_sets, 2);  // up to 6 influences per vertex: two JOINTS/WEIGHTS sets
  EXPECT_EQ(sz.max_influences, u.info.sizes.max_influences);
  EXPECT_EQ(u.info.pose_correctives, "sparse_lowrank");  // embedded compactly by default (bound: below)
  EXPECT_FALSE(u.info.texture_exact);
}

// Compact pose correctives at full rank (no approximation): a block below the threshold
// (norm <= t M_j, M_j the joint's largest block norm) comes back zero; the kept blocks of a
// joint, with coefficients in [-1, 1] quantized to half a step 1 / (2^b - 1) and the mixing
// rows of norm <= M_j (refitted by least squares, which cannot do worse than the SVD's
// rows), come back within sqrt(3 K 9) M_j / (2^b - 1) in Frobenius norm (+ float slack).
TEST(FormatRoundTrip, CompactPoseCorrectivesWithinBound) {
  const Avatar a = test::make_test_avatar(50);
  PackOptions opt;
  opt.pose_corrective_codec.threshold = 0.3;
  opt.pose_corrective_codec.rank = 9;
  opt.pose_corrective_codec.energy = 1.0;
  for (int bits : {4, 8}) {
    opt.pose_corrective_codec.bits = bits;
    const std::vector<uint8_t> glb = pack_avatar(a, opt);
    const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
    EXPECT_EQ(u.info.pose_correctives, "sparse_lowrank");
    EXPECT_EQ(u.info.pose_corrective_rank, 9);
    const std::vector<float>& p = a.body.posedirs;
    const std::vector<float>& q = u.avatar.body.posedirs;
    ASSERT_EQ(p.size(), q.size());
    const int V = a.body.num_verts;
    int kept_total = 0;
    for (int j = 0; j < kNumJoints - 1; ++j) {
      auto block_sq = [&](const std::vector<float>& x, const std::vector<float>* y, int v) {
        double s = 0;
        for (int c = 0; c < 3; ++c)
          for (int k = 0; k < 9; ++k) {
            const size_t i = (size_t(v) * 3 + size_t(c)) * kNumPoseFeatures + size_t(9 * j + k);
            const double d = double(x[i]) - (y ? double((*y)[i]) : 0.0);
            s += d * d;
          }
        return s;
      };
      double M = 0;
      for (int v = 0; v < V; ++v) M = std::max(M, std::sqrt(block_sq(p, nullptr, v)));
      double err_sq = 0;
      int K = 0;
      for (int v = 0; v < V; ++v) {
        if (std::sqrt(block_sq(p, nullptr, v)) > 0.3 * M) {
          ++K;
          err_sq += block_sq(p, &q, v);
        } else {
          ASSERT_EQ(block_sq(q, nullptr, v), 0.0) << "joint " << j + 1 << " vertex " << v;
        }
      }
      kept_total += K;
      const double bound = std::sqrt(27.0 * K) * M / double((1 << bits) - 1) + 1e-5 * M;
      EXPECT_LE(std::sqrt(err_sq), bound) << "joint " << j + 1 << ", " << bits << " bits";
    }
    EXPECT_EQ(u.info.pose_corrective_blocks, kept_total);
  }
}

TEST(FormatRoundTrip, PoseCorrectivesInt16WithinHalfStep) {
  const Avatar a = test::make_test_avatar(50);
  PackOptions opt;
  opt.pose_correctives = haha::PoseCorrectives::dense;
  const std::vector<uint8_t> glb = pack_avatar(a, opt);
  const Avatar b = unpack_avatar(glb.data(), glb.size(), "mem.glb").avatar;
  ASSERT_EQ(a.body.posedirs.size(), b.body.posedirs.size());
  // Per feature scale = max|x| / 32767; rounding error <= scale / 2 <= 0.001 / 32767 / 2.
  for (size_t i = 0; i < a.body.posedirs.size(); ++i) ASSERT_NEAR(a.body.posedirs[i], b.body.posedirs[i], 0.001f / 32767 * 0.51f);
}

TEST(FormatRoundTrip, DracoSequentialKeepsFaceAndPointOrder) {
  // Faces in an order edgebreaker would not keep (reversed strips, a degenerate face, a
  // face repeating a vertex set), points that are exact duplicates (no dedup allowed).
  std::vector<float> pos = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 0, 2, 2, 2};
  std::vector<int32_t> faces = {3, 2, 1, 0, 1, 2, 4, 5, 3, 5, 5, 5, 1, 2, 3, 2, 1, 0};
  std::vector<int32_t> ids = {10, 11, 12, 13, 14, 15};
  std::vector<dracoio::AttrIn> at = {{"POSITION", dracoio::Kind::position, dracoio::Type::f32, 3, pos.data(), 0},
                                     {"ID", dracoio::Kind::generic, dracoio::Type::i32, 1, ids.data(), 0}};
  const dracoio::Encoded e = dracoio::encode(6, at, faces.data(), 6);
  dracoio::Decoded d(e.bytes.data(), e.bytes.size(), true, "test", "mesh");
  EXPECT_EQ(d.num_points(), 6);
  EXPECT_EQ(d.faces(), faces);
  EXPECT_EQ(d.floats(e.unique_ids[0], 3, "POSITION"), pos);
  const std::vector<int64_t> got = d.ints(e.unique_ids[1], 1, "ID");
  EXPECT_EQ(std::vector<int64_t>(ids.begin(), ids.end()), got);

  // Point cloud: a decreasing integer sequence and floats come back in input order.
  std::vector<int32_t> seq(1000);
  std::vector<float> val(1000);
  for (int i = 0; i < 1000; ++i) seq[size_t(i)] = 999 - (i * 7919) % 1000, val[size_t(i)] = float(seq[size_t(i)]) * 0.5f;
  const dracoio::Encoded pe = dracoio::encode(1000, {{"S", dracoio::Kind::generic, dracoio::Type::i32, 1, seq.data(), 0},
                                                     {"V", dracoio::Kind::generic, dracoio::Type::f32, 1, val.data(), 12}},
                                              nullptr, 0);
  dracoio::Decoded pd(pe.bytes.data(), pe.bytes.size(), false, "test", "points");
  const std::vector<int64_t> s2 = pd.ints(pe.unique_ids[0], 1, "S");
  const std::vector<float> v2 = pd.floats(pe.unique_ids[1], 1, "V");
  for (int i = 0; i < 1000; ++i) {
    ASSERT_EQ(s2[size_t(i)], seq[size_t(i)]);
    ASSERT_NEAR(v2[size_t(i)], val[size_t(i)], 499.5f / 4095 * 0.51f);
  }
}

TEST(FormatRoundTrip, PackedMeshKeepsBodyFaceOrderInTheGltf) {
  // The glTF's own Draco stream decodes to the body's faces in the body's order (through
  // the _BODY_VERTEX map), including the degenerate last face of the test body.
  const Avatar a = test::make_test_avatar(10);
  const std::vector<uint8_t> bytes = pack_avatar(a, PackOptions{});
  const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "mem");
  const auto& kd = g.json["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"];
  const glb::ByteSpan s = glb::buffer_view(g, kd["bufferView"].get<int>(), "mem");
  dracoio::Decoded d(s.data, s.size, true, "mem", "mesh");
  const auto map = d.ints(kd["attributes"]["_BODY_VERTEX"].get<int>(), 1, "BV");
  const std::vector<int32_t> f = d.faces();
  ASSERT_EQ(f.size(), a.body.faces.size());
  for (size_t c = 0; c < f.size(); ++c) ASSERT_EQ(map[size_t(f[c])], a.body.faces[c]) << "corner " << c;
  // The indices accessor announces exactly F * 3 indices.
  EXPECT_EQ(g.json["accessors"][g.json["meshes"][0]["primitives"][0]["indices"].get<int>()]["count"].get<int>(), a.body.num_faces * 3);
}

// Posed Gaussians (mean, rotation up to sign, scale) of an unpacked avatar, sorted so two
// files with the Gaussians in different orders compare element by element.
std::vector<std::array<float, 10>> posed_gaussians(const Avatar& a, const SmplxParams& p) {
  AvatarLoader rt(a);
  PosedAvatar posed;
  rt.repose(p, posed);
  std::vector<std::array<float, 10>> out(size_t(posed.num_gaussians));
  for (int i = 0; i < posed.num_gaussians; ++i) {
    auto& g = out[size_t(i)];
    const float sign = posed.quats[size_t(i) * 4] < 0 ? -1.0f : 1.0f;
    for (int k = 0; k < 3; ++k) g[size_t(k)] = posed.means[size_t(i) * 3 + k];
    for (int k = 0; k < 4; ++k) g[size_t(3 + k)] = sign * posed.quats[size_t(i) * 4 + k];
    for (int k = 0; k < 3; ++k) g[size_t(7 + k)] = posed.scales[size_t(i) * 3 + k];
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Edgebreaker reorders the faces and rotates their corners; through the canonical face
// order and FACE_CORNER the reader gives every Gaussian its body face corner for corner,
// so the file reposes exactly like the sequential one (same quantization, so the same
// rest vertices).
TEST(FormatRoundTrip, EdgebreakerFileReposesLikeTheBodyFaceOrder) {
  const Avatar a = test::without_degenerate_face(test::make_test_avatar(400));
  PackOptions eb_opt, seq_opt;
  seq_opt.keep_face_order = true;
  PackedSizes eb_sz, seq_sz;
  const std::vector<uint8_t> eb = pack_avatar(a, eb_opt, &eb_sz), seq = pack_avatar(a, seq_opt, &seq_sz);
  ASSERT_TRUE(eb_sz.edgebreaker);
  ASSERT_FALSE(seq_sz.edgebreaker);
  EXPECT_LT(eb_sz.mesh, seq_sz.mesh);
  const UnpackedAvatar ue = unpack_avatar(eb.data(), eb.size(), "eb.glb"), us = unpack_avatar(seq.data(), seq.size(), "seq.glb");
  EXPECT_TRUE(ue.info.sizes.edgebreaker);
  // Both name the Gaussians' faces in the canonical order: the same faces either way.
  EXPECT_EQ(ue.avatar.gaussians.face, us.avatar.gaussians.face);
  // Each Gaussian's face, corner by corner, is its body face.
  std::vector<std::array<int32_t, 3>> want, got;
  for (int32_t f : a.gaussians.face) want.push_back({a.body.faces[size_t(f) * 3], a.body.faces[size_t(f) * 3 + 1], a.body.faces[size_t(f) * 3 + 2]});
  const BodyModel& be = ue.avatar.body;
  for (int32_t f : ue.avatar.gaussians.face) got.push_back({be.faces[size_t(f) * 3], be.faces[size_t(f) * 3 + 1], be.faces[size_t(f) * 3 + 2]});
  std::sort(want.begin(), want.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(want, got);
  // And they repose identically under a strong pose.
  SmplxParams p;
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0.0f, 0.4f);
  for (float& x : p.pose) x = n(rng);
  p.transl = {0.1f, -0.2f, 0.3f};
  const auto ge = posed_gaussians(ue.avatar, p), gs = posed_gaussians(us.avatar, p);
  ASSERT_EQ(ge.size(), gs.size());
  float worst = 0;
  for (size_t i = 0; i < ge.size(); ++i)
    for (size_t k = 0; k < 10; ++k) worst = std::max(worst, std::fabs(ge[i][k] - gs[i][k]));
  EXPECT_LT(worst, 1e-5f);
  // Both readers' rest joints: the regressor is gone, the inverse bind matrices hold them.
  EXPECT_TRUE(ue.avatar.body.j_regressor.empty());
  EXPECT_EQ(ue.avatar.body.joints_rest.size(), size_t(kNumJoints) * 3);
}

// A version-1 file (sequential mesh, joint regressor) still loads: the lossless pack is
// one apart from its version number and where it names the vertex map.
TEST(FormatRoundTrip, Version1FileStillLoads) {
  const Avatar a = test::make_test_avatar(100);
  PackOptions opt;
  opt.lossless = true;
  const std::vector<uint8_t> v2 = pack_avatar(a, opt);
  glb::Glb g = glb::parse_glb(v2.data(), v2.size(), "v2");
  // Version 1 named the vertex map privately and knew no face order but the file's.
  glb::Json& ext = g.json["extensions"]["HAHA_gaussian_avatar"];
  glb::Json& prim = g.json["meshes"][0]["primitives"][0];
  ext["version"] = 1;
  ext["body"]["draco"].erase("method");
  ext["body"]["draco"]["attributes"]["BODY_VERTEX"] = prim["extensions"]["KHR_draco_mesh_compression"]["attributes"]["_BODY_VERTEX"];
  prim["extensions"]["KHR_draco_mesh_compression"]["attributes"].erase("_BODY_VERTEX");
  prim["attributes"].erase("_BODY_VERTEX");
  ext["gaussians"].erase("faceOrder");
  const std::vector<uint8_t> v1 = glb::write_glb(g.json, g.bin);
  const UnpackedAvatar u1 = unpack_avatar(v1.data(), v1.size(), "v1.glb"), u2 = unpack_avatar(v2.data(), v2.size(), "v2.glb");
  EXPECT_EQ(u1.info.version, 1);
  EXPECT_EQ(u2.info.version, kAvatarFormatVersion);
  EXPECT_EQ(u1.avatar.body.faces, u2.avatar.body.faces);
  EXPECT_TRUE(bit_equal(u1.avatar.body.j_regressor, a.body.j_regressor));
  EXPECT_TRUE(bit_equal(u1.avatar.gaussians.offset, u2.avatar.gaussians.offset));
}

// Importance tiers (--lod): each prefix holds the most important Gaussians, its measured
// PSNR grows with the prefix, a loader can stop after any tier, and all tiers together
// hold every Gaussian.
TEST(FormatRoundTrip, LodTiersArePrefixesALoaderCanTake) {
  const Avatar a = test::without_degenerate_face(test::make_test_avatar(700));
  const LodPlan plan = plan_lod(a, 3);
  ASSERT_EQ(plan.counts, (std::vector<int>{175, 175, 350}));
  ASSERT_EQ(plan.psnr.size(), 3u);
  EXPECT_LT(plan.psnr[0], plan.psnr[1]);
  EXPECT_TRUE(std::isinf(plan.psnr[2]));
  // Ranked by opacity x footprint: nothing in a later tier outranks the first tier.
  std::vector<int32_t> sorted = plan.order;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < 700; ++i) ASSERT_EQ(sorted[size_t(i)], i);
  PackOptions opt;
  opt.lod_tiers = 3;
  const std::vector<uint8_t> glb = pack_avatar(a, opt);
  const UnpackedAvatar all = unpack_avatar(glb.data(), glb.size(), "lod.glb");
  EXPECT_EQ(all.avatar.gaussians.size(), 700);
  EXPECT_EQ(all.info.lod_counts, plan.counts);
  for (size_t t = 0; t < 2; ++t) EXPECT_NEAR(all.info.lod_psnr[t], plan.psnr[t], 0.01);
  // The multiset of faces is the avatar's (order within tiers is by face).
  std::vector<int32_t> fa, fb;
  for (int32_t f : a.gaussians.face) fa.push_back(f);
  for (int32_t f : all.avatar.gaussians.face) fb.push_back(f);
  EXPECT_EQ(fa.size(), fb.size());
  // A prefix: the tiers that fit, the first always.
  for (auto [limit, want] : {std::pair{1, 175}, std::pair{175, 175}, std::pair{349, 175}, std::pair{350, 350}, std::pair{699, 350}, std::pair{0, 700}}) {
    UnpackOptions o;
    o.max_gaussians = limit;
    const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "lod.glb", o);
    EXPECT_EQ(u.avatar.gaussians.size(), want) << "limit " << limit;
    EXPECT_EQ(u.info.sizes.num_gaussians, want);
  }
  // The first tier's Gaussians are the plan's first 175 (compare opacities as a multiset,
  // within the 5-bit quantization step).
  UnpackOptions first;
  first.max_gaussians = 1;
  const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "lod.glb", first);
  std::vector<float> want_op, got_op(u.avatar.gaussians.opacity);
  for (int i = 0; i < 175; ++i) want_op.push_back(a.gaussians.opacity[size_t(plan.order[size_t(i)])]);
  std::sort(want_op.begin(), want_op.end());
  std::sort(got_op.begin(), got_op.end());
  for (size_t i = 0; i < want_op.size(); ++i) ASSERT_NEAR(want_op[i], got_op[i], 1.0f / 31 * 0.51f + 1e-6f) << i;
  PackOptions bad = opt;
  bad.lossless = true;
  EXPECT_THROW(pack_avatar(a, bad), Error);
}

TEST(FormatRoundTrip, TextureOptions) {
  const Avatar a = test::make_test_avatar(20);
  for (TextureCodec c : {TextureCodec::png, TextureCodec::jpg, TextureCodec::webp}) {
    PackOptions opt;
    opt.texture_codec = c;
    opt.texture_size = 16;
    const std::vector<uint8_t> glb = pack_avatar(a, opt);
    const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
    EXPECT_EQ(u.avatar.texture.width, 16);
    EXPECT_EQ(u.avatar.texture.height, 16);
    EXPECT_EQ(u.info.texture_mime, texture_mime(c));
    // The resampled texture keeps the mean colour (box filter) up to codec error.
    double m0 = 0, m1 = 0;
    for (float x : a.texture.rgb) m0 += x;
    for (float x : u.avatar.texture.rgb) m1 += x;
    EXPECT_NEAR(m0 / a.texture.rgb.size(), m1 / u.avatar.texture.rgb.size(), 0.02);
  }
  PackOptions bad;
  bad.lossless = true;
  bad.texture_size = 16;
  EXPECT_THROW(pack_avatar(a, bad), Error);
}

TEST(FormatRoundTrip, DefaultTextureQualityFollowsTheTextureSize) {
  // Quality 0 (the default) packs up to 512^2 at 90 and larger textures at 75: the same
  // bytes as those qualities given, and a smaller file than 90 for the large texture.
  EXPECT_EQ(default_texture_quality(256), 90);
  EXPECT_EQ(default_texture_quality(512), 90);
  EXPECT_EQ(default_texture_quality(1024), 75);
  const Avatar a = test::make_test_avatar(20);
  PackOptions opt, q;
  ASSERT_EQ(opt.texture_quality, 0);
  for (int side : {64, 1024}) {
    opt.texture_size = q.texture_size = side;
    q.texture_quality = side <= 512 ? 90 : 75;
    EXPECT_EQ(pack_avatar(a, opt), pack_avatar(a, q)) << side;
  }
  q.texture_quality = 90;
  EXPECT_LT(pack_avatar(a, opt).size(), pack_avatar(a, q).size());
}

// Filtering can remove every Gaussian: such an avatar packs without a point cloud (Draco
// has no empty one, glTF no empty accessor) and reads back as the textured mesh alone.
TEST(FormatRoundTrip, AvatarWithoutGaussiansPacksAndReadsBack) {
  Avatar a = test::make_test_avatar(0);
  ASSERT_EQ(a.gaussians.size(), 0);
  PackOptions lossy, lossless, splats;
  lossless.lossless = true;
  splats.khr_gaussian_splatting = true;
  for (const PackOptions& o : {lossy, lossless, splats}) {
    const std::vector<uint8_t> b = pack_avatar(a, o);
    const UnpackedAvatar u = unpack_avatar(b.data(), b.size(), "empty.glb");
    EXPECT_EQ(u.avatar.gaussians.size(), 0);
    EXPECT_EQ(u.info.sizes.num_gaussians, 0);
    EXPECT_EQ(u.avatar.body.num_faces, a.body.num_faces);
    EXPECT_FALSE(u.info.splats);
  }
}

}  // namespace
}  // namespace haha

namespace haha {
namespace {

// A body with a rest displacement (the clothed surface, BodyModel::rest_offsets): every pack
// stores the displaced rest positions and the bare body's joints, so a reader that knows
// nothing of the displacement reposes exactly as the trainer's LBS does.
TEST(FormatRoundTrip, RestDisplacementReposesAsTheTrainerDoes) {
  Avatar a = test::make_test_avatar(200);
  a.body.rest_offsets.resize(a.body.v_template.size());
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> d(0.0f, 0.03f);
  for (float& x : a.body.rest_offsets) x = d(rng);
  SmplxParams rest, p;
  std::normal_distribution<float> n(0.0f, 0.4f);
  for (float& x : p.pose) x = n(rng);
  p.transl = {0.1f, -0.2f, 0.3f};
  for (SmplxParams* q : {&rest, &p}) q->betas = a.betas, q->expression = a.expression;
  Lbs<float> lbs(a.body);
  std::vector<float> want(a.body.v_template.size()), want_j(3 * kNumJoints), rest_j(3 * kNumJoints);
  lbs.forward(p, want.data(), want_j.data(), nullptr);
  lbs.forward(rest, want.data(), rest_j.data(), nullptr);  // the bare body's rest joints
  const std::vector<float> baked = baked_rest_vertices(a);
  lbs.forward(p, want.data(), want_j.data(), nullptr);
  for (const bool lossless : {true, false}) {
    PackOptions opt;
    opt.lossless = lossless;
    opt.mesh_compression = lossless ? MeshCompression::draco : MeshCompression::none;
    if (lossless) opt.pose_correctives = PoseCorrectives::dense;
    const std::vector<uint8_t> glb = pack_avatar(a, opt);
    const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
    const BodyModel& b = u.avatar.body;
    EXPECT_TRUE(b.rest_offsets.empty()) << "the file's rest positions hold it";
    EXPECT_TRUE(b.j_regressor.empty()) << "a regressor would move the joints with the clothes";
    ASSERT_EQ(b.joints_rest.size(), rest_j.size());
    for (size_t i = 0; i < rest_j.size(); ++i) EXPECT_NEAR(b.joints_rest[i], rest_j[i], 2e-6f) << "joint value " << i;
    float worst_rest = 0;
    for (size_t i = 0; i < baked.size(); ++i) worst_rest = std::max(worst_rest, std::fabs(b.v_template[i] - baked[i]));
    EXPECT_LT(worst_rest, lossless ? 1e-7f : 1e-3f) << "rest positions, " << (lossless ? "lossless" : "default");
    if (!lossless) continue;  // the default pack's weights and correctives are quantized (tests above)
    const AvatarLoader loader(u.avatar);
    PosedAvatar posed;
    loader.repose(p, posed);
    float worst = 0;
    for (size_t i = 0; i < want.size(); ++i) worst = std::max(worst, std::fabs(posed.verts[i] - want[i]));
    EXPECT_LT(worst, 2e-5f) << "m, posed vertices of the lossless pack against the trainer's LBS";
  }
}

}  // namespace
}  // namespace haha

namespace haha {
namespace {

// A body with a garment appended (body/garment.h): every pack stores it as part of the one
// mesh and says where it starts and how many Gaussians it carries; the lossless pack reposes
// it as the trainer's LBS does (the garment's own weights, no correctives), the default and
// plain packs within their quantization.
TEST(FormatRoundTrip, GarmentIsPartOfTheMeshAndReposesAsTheTrainerDoes) {
  const Avatar a = test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(120)), 7);
  const BodyModel& body = a.body;
  ASSERT_TRUE(body.has_garment());
  SmplxParams p;
  std::mt19937 rng(9);
  std::normal_distribution<float> n(0.0f, 0.4f);
  for (float& x : p.pose) x = n(rng);
  p.betas = a.betas, p.expression = a.expression;
  std::vector<float> want(body.v_template.size());
  Lbs<float>(body).forward(p, want.data(), nullptr, nullptr);
  PackOptions lossless, lossy, plain;
  lossless.lossless = true;
  lossless.pose_correctives = PoseCorrectives::dense;
  plain.mesh_compression = MeshCompression::none;
  for (const PackOptions& opt : {lossless, lossy, plain}) {
    const std::vector<uint8_t> glb = pack_avatar(a, opt);
    const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "garment.glb");
    EXPECT_EQ(u.avatar.body.num_verts, body.num_verts);
    EXPECT_EQ(u.avatar.body.num_faces, body.num_faces);
    EXPECT_EQ(u.info.garment_first_vertex, body.garment_first_vert);
    EXPECT_EQ(u.info.garment_first_face, body.garment_first_face);
    EXPECT_EQ(u.info.garment_gaussians, 7);
    const AvatarLoader loader(u.avatar);
    PosedAvatar posed;
    loader.repose(p, posed);
    float worst = 0;
    for (size_t i = 3 * size_t(body.garment_first_vert); i < want.size(); ++i)
      worst = std::max(worst, std::fabs(posed.verts[i] - want[i]));
    EXPECT_LT(worst, opt.lossless ? 2e-5f : 2e-3f) << "m, the garment's posed vertices";
  }
}

}  // namespace
}  // namespace haha
