// What engines and asset tools need of the file (format/spec.md, version 3): a plain mesh
// with no required extension, skin weights that sum to exactly one, Gaussians that stay on
// their faces when a tool rewrites the mesh, and skinned KHR_gaussian_splatting splats.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>

#include "body/lbs.h"
#include "body/rotation.h"
#include "core/error.h"
#include "format/avatar_loader.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/draco_io.h"
#include "format/glb.h"
#include "support/format_realistic_avatar.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

using glb::Json;

// Posed Gaussians (means, then quaternions with w >= 0) of an avatar, in stored order.
std::vector<float> posed(const Avatar& a, const SmplxParams& p) {
  AvatarLoader rt(a);
  PosedAvatar out;
  rt.repose(p, out);
  std::vector<float> v(out.means);
  for (int i = 0; i < out.num_gaussians; ++i) {
    const float s = out.quats[size_t(i) * 4] < 0 ? -1.0f : 1.0f;
    for (int k = 0; k < 4; ++k) v.push_back(s * out.quats[size_t(i) * 4 + k]);
  }
  return v;
}

float worst_difference(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  float w = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) w = std::max(w, std::fabs(a[i] - b[i]));
  return w;
}

SmplxParams strong_pose(uint32_t seed) {
  SmplxParams p;
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, 0.4f);
  for (float& x : p.pose) x = n(rng);
  p.transl = {0.1f, -0.2f, 0.3f};
  return p;
}

UnpackedAvatar unpack(const std::vector<uint8_t>& bytes, const char* name) { return unpack_avatar(bytes.data(), bytes.size(), name); }

// Per-vertex skin-weight codes (all sets) of the body primitive, Draco or plain.
std::vector<std::vector<int64_t>> weight_codes(const std::vector<uint8_t>& bytes) {
  const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "mem");
  const Json& prim = g.json["meshes"][0]["primitives"][0];
  const int sets = g.json["extensions"]["HAHA_gaussian_avatar"]["body"]["skinSets"].get<int>();
  std::vector<std::vector<int64_t>> out(static_cast<size_t>(sets));
  for (int s = 0; s < sets; ++s) {
    const std::string wn = "WEIGHTS_" + std::to_string(s);
    const Json& acc = g.json["accessors"][prim["attributes"][wn].get<size_t>()];
    EXPECT_EQ(acc["componentType"].get<int>(), 5123) << wn;
    EXPECT_TRUE(acc.value("normalized", false)) << wn;
    if (prim.contains("extensions")) {
      const Json& kd = prim["extensions"]["KHR_draco_mesh_compression"];
      const glb::ByteSpan sp = glb::buffer_view(g, kd["bufferView"].get<int>(), "mem");
      const dracoio::Decoded d(sp.data, sp.size, true, "mem", "mesh");
      out[size_t(s)] = d.ints(kd["attributes"][wn].get<int>(), 4, wn);
    } else {
      for (double x : glb::read_accessor(g, prim["attributes"][wn].get<int64_t>(), 4, "mem", wn).values)
        out[size_t(s)].push_back(std::llround(x * 65535.0));
    }
  }
  return out;
}

TEST(FormatEngineCompat, PlainMeshNeedsNoExtensionAndReposesLikeTheDracoFile) {
  const Avatar a = test::make_test_avatar(400);
  PackOptions draco_opt, plain_opt;
  plain_opt.mesh_compression = MeshCompression::none;
  PackedSizes ds, ps;
  const std::vector<uint8_t> draco = pack_avatar(a, draco_opt, &ds), plain = pack_avatar(a, plain_opt, &ps);
  const glb::Glb g = glb::parse_glb(plain.data(), plain.size(), "plain");
  EXPECT_FALSE(g.json.contains("extensionsRequired"));
  for (const Json& e : g.json["extensionsUsed"]) EXPECT_NE(e.get<std::string>(), "KHR_draco_mesh_compression");
  EXPECT_FALSE(g.json["meshes"][0]["primitives"][0].contains("extensions"));
  EXPECT_FALSE(g.json["extensions"]["HAHA_gaussian_avatar"]["body"].contains("draco"));
  EXPECT_EQ(g.json["asset"]["generator"].get<std::string>(), "haha pack (HAHA_gaussian_avatar v4)");
  EXPECT_TRUE(ds.draco_mesh);
  EXPECT_FALSE(ps.draco_mesh);
  EXPECT_GT(ps.mesh, ds.mesh);  // the price of no Draco
  const UnpackedAvatar ud = unpack(draco, "draco.glb"), up = unpack(plain, "plain.glb");
  EXPECT_FALSE(up.info.sizes.draco_mesh);
  EXPECT_EQ(up.info.gaussian_face_order, "canonical");
  // Same Gaussians (same quantization, same order); the meshes differ by the Draco
  // position quantization only (16 bits over the body's 1.7 m: <= 1.3e-5 m per vertex,
  // which the face frames of the test body's small faces turn into <= 1 mm of a posed
  // Gaussian under a strong pose).
  EXPECT_EQ(ud.avatar.gaussians.offset, up.avatar.gaussians.offset);
  EXPECT_LT(worst_difference(posed(ud.avatar, strong_pose(3)), posed(up.avatar, strong_pose(3))), 1e-3f);
  // The plain file's rest vertices are the packer's float32 values exactly.
  EXPECT_EQ(up.avatar.body.v_template, baked_rest_vertices(a));
}

TEST(FormatEngineCompat, SkinWeightsSumToExactlyOneInEveryVariant) {
  const Avatar a = test::make_test_avatar(50);
  for (MeshCompression mc : {MeshCompression::draco, MeshCompression::none}) {
    for (int bits : {8, 10, 16}) {
      PackOptions opt;
      opt.mesh_compression = mc;
      opt.mesh_bits.weight = bits;
      const std::vector<uint8_t> bytes = pack_avatar(a, opt);
      const auto codes = weight_codes(bytes);
      const size_t n = codes[0].size() / 4;
      ASSERT_GT(n, 0u);
      for (size_t v = 0; v < n; ++v) {
        int64_t sum = 0;
        for (const auto& set : codes)
          for (int k = 0; k < 4; ++k) sum += set[v * 4 + size_t(k)];
        ASSERT_EQ(sum, 65535) << "vertex " << v << ", bits " << bits;
      }
      // Each weight within a step of the original (renormalised over the kept ones).
      const UnpackedAvatar u = unpack(bytes, "w.glb");
      const double step = 1.0 / (1 << bits);
      for (int v = 0; v < a.body.num_verts; ++v) {
        double sum = 0;
        for (int j = 0; j < kNumJoints; ++j) {
          const float got = u.avatar.body.weights[size_t(v) * kNumJoints + size_t(j)];
          sum += got;
          EXPECT_NEAR(got, a.body.weights[size_t(v) * kNumJoints + size_t(j)], step + 1e-4) << v << " " << j;
        }
        EXPECT_NEAR(sum, 1.0, 1e-6);
      }
    }
  }
}

// The body mesh rewritten as an asset tool may write it: decoded from Draco, vertices and
// faces shuffled, every face's corners rotated, all attributes interleaved in one
// bufferView (byteStride) with float weights and vertex map, body.draco dropped (a tool
// cannot keep its checksum true).
std::vector<uint8_t> rewritten_like_a_tool(const std::vector<uint8_t>& file, uint32_t seed) {
  glb::Glb g = glb::parse_glb(file.data(), file.size(), "file");
  Json& prim = g.json["meshes"][0]["primitives"][0];
  const Json kd = prim["extensions"]["KHR_draco_mesh_compression"];
  const glb::ByteSpan sp = glb::buffer_view(g, kd["bufferView"].get<int>(), "file");
  const dracoio::Decoded d(sp.data, sp.size, true, "file", "mesh");
  const int Vg = d.num_points(), sets = g.json["extensions"]["HAHA_gaussian_avatar"]["body"]["skinSets"].get<int>();
  const std::vector<float> pos = d.floats(kd["attributes"]["POSITION"].get<int>(), 3, "P");
  const std::vector<float> uv = d.floats(kd["attributes"]["TEXCOORD_0"].get<int>(), 2, "T");
  const std::vector<int64_t> bv = d.ints(kd["attributes"]["_BODY_VERTEX"].get<int>(), 1, "B");
  std::mt19937 rng(seed);
  std::vector<int32_t> new_of(static_cast<size_t>(Vg));
  std::iota(new_of.begin(), new_of.end(), 0);
  std::shuffle(new_of.begin(), new_of.end(), rng);
  const size_t stride = 12 + 8 + size_t(sets) * 20 + 4;
  std::vector<uint8_t> inter(size_t(Vg) * stride);
  auto put = [&](int v, size_t at, const void* src, size_t n) { std::memcpy(&inter[size_t(new_of[size_t(v)]) * stride + at], src, n); };
  for (int v = 0; v < Vg; ++v) {
    put(v, 0, &pos[size_t(v) * 3], 12);
    put(v, 12, &uv[size_t(v) * 2], 8);
    const float b = float(bv[size_t(v)]);
    put(v, stride - 4, &b, 4);
  }
  for (int s = 0; s < sets; ++s) {
    const std::string n = std::to_string(s);
    const auto j = d.ints(kd["attributes"]["JOINTS_" + n].get<int>(), 4, "J"), w = d.ints(kd["attributes"]["WEIGHTS_" + n].get<int>(), 4, "W");
    for (int v = 0; v < Vg; ++v) {
      uint8_t jb[4];
      float wf[4];
      for (int k = 0; k < 4; ++k) jb[k] = uint8_t(j[size_t(v) * 4 + size_t(k)]), wf[k] = float(double(w[size_t(v) * 4 + size_t(k)]) / 65535.0);
      put(v, 20 + size_t(s) * 20, jb, 4);
      put(v, 24 + size_t(s) * 20, wf, 16);
    }
  }
  std::vector<int32_t> faces = d.faces(), out_faces;
  std::vector<size_t> order(faces.size() / 3);
  std::iota(order.begin(), order.end(), size_t(0));
  std::shuffle(order.begin(), order.end(), rng);
  for (size_t f : order) {
    const size_t r = rng() % 3;
    for (size_t i = 0; i < 3; ++i) out_faces.push_back(new_of[size_t(faces[f * 3 + (r + i) % 3])]);
  }
  auto add_view = [&](const void* data, size_t n, Json extra) {
    while (g.bin.size() % 4) g.bin.push_back(0);
    Json v = {{"buffer", 0}, {"byteOffset", g.bin.size()}, {"byteLength", n}};
    v.update(extra);
    g.bin.insert(g.bin.end(), static_cast<const uint8_t*>(data), static_cast<const uint8_t*>(data) + n);
    g.json["bufferViews"].push_back(v);
    return int(g.json["bufferViews"].size()) - 1;
  };
  const int iv = add_view(inter.data(), inter.size(), {{"byteStride", stride}, {"target", 34962}});
  const int fv = add_view(out_faces.data(), out_faces.size() * 4, {{"target", 34963}});
  auto accessor = [&](int view, size_t offset, int type, const char* shape, bool normalized = false) {
    Json acc = {{"bufferView", view}, {"byteOffset", offset}, {"componentType", type}, {"count", Vg}, {"type", shape}};
    if (normalized) acc["normalized"] = true;
    g.json["accessors"].push_back(acc);
    return int(g.json["accessors"].size()) - 1;
  };
  Json attrs;
  attrs["POSITION"] = accessor(iv, 0, 5126, "VEC3");
  attrs["TEXCOORD_0"] = accessor(iv, 12, 5126, "VEC2");
  for (int s = 0; s < sets; ++s) {
    attrs["JOINTS_" + std::to_string(s)] = accessor(iv, 20 + size_t(s) * 20, 5121, "VEC4");
    attrs["WEIGHTS_" + std::to_string(s)] = accessor(iv, 24 + size_t(s) * 20, 5126, "VEC4");
  }
  attrs["_BODY_VERTEX"] = accessor(iv, stride - 4, 5126, "SCALAR");
  g.json["accessors"].push_back({{"bufferView", fv}, {"componentType", 5125}, {"count", out_faces.size()}, {"type", "SCALAR"}});
  prim = {{"attributes", attrs}, {"indices", int(g.json["accessors"].size()) - 1}, {"mode", 4}, {"material", 0}};
  g.json.erase("extensionsRequired");
  Json used = Json::array();
  for (const Json& e : g.json["extensionsUsed"])
    if (e != "KHR_draco_mesh_compression") used.push_back(e);
  g.json["extensionsUsed"] = used;
  g.json["extensions"]["HAHA_gaussian_avatar"]["body"].erase("draco");
  g.json["buffers"][0]["byteLength"] = g.bin.size();
  return glb::write_glb(g.json, g.bin);
}

TEST(FormatEngineCompat, GaussiansStayOnTheirFacesWhenAToolRewritesTheMesh) {
  const Avatar a = test::make_test_avatar(400);
  const std::vector<uint8_t> original = pack_avatar(a, PackOptions{});
  const UnpackedAvatar uo = unpack(original, "original.glb");
  for (uint32_t seed : {1u, 2u}) {
    const std::vector<uint8_t> rewritten = rewritten_like_a_tool(original, seed);
    const UnpackedAvatar ur = unpack(rewritten, "rewritten.glb");
    EXPECT_FALSE(ur.info.sizes.draco_mesh);
    // Bit-identical reposing: the same values, only their places in the file moved.
    EXPECT_EQ(posed(ur.avatar, strong_pose(seed)), posed(uo.avatar, strong_pose(seed)));
  }
}

TEST(FormatEngineCompat, LosslessFilesRefuseARewrittenMesh) {
  // Lossless packs bind the Gaussians to the file's face order: without body.draco (a tool
  // rewrote the mesh) the reader cannot trust it and says so, instead of binding wrongly.
  const Avatar a = test::make_test_avatar(30);
  PackOptions opt;
  opt.lossless = true;
  const std::vector<uint8_t> bytes = pack_avatar(a, opt);
  glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "lossless");
  EXPECT_EQ(g.json["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["faceOrder"], "file");
  g.json["extensions"]["HAHA_gaussian_avatar"]["body"].erase("draco");
  const std::vector<uint8_t> edited = glb::write_glb(g.json, g.bin);
  try {
    unpack(edited, "edited.glb");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the mesh was rewritten"), std::string::npos) << e.what();
  }
  PackOptions both = opt;
  both.mesh_compression = MeshCompression::none;
  EXPECT_THROW(pack_avatar(a, both), Error);
}

// The KHR_gaussian_splatting splats are skinned: node with the body's skin, JOINTS_0 /
// WEIGHTS_0 per splat whose codes sum to 65535; linear blend skinning of their rest
// centres follows the exact face-frame reposing (no splat is left behind).
TEST(FormatEngineCompat, SplatsAreSkinnedAndFollowTheSkeleton) {
  const Avatar a = test::make_realistic_avatar(1500, 64, 3, BodyResolution::low);
  PackOptions opt;
  opt.khr_gaussian_splatting = true;
  opt.gaussian_bits = GaussianBits{0, 0, 0, 0, 0};  // compare the skinning, not the quantization
  opt.mesh_bits.position = 0;
  const std::vector<uint8_t> bytes = pack_avatar(a, opt);
  const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "splats");
  const Json& sp = g.json["extensions"]["HAHA_gaussian_avatar"]["splats"];
  const Json& node = g.json["nodes"][sp["node"].get<size_t>()];
  EXPECT_EQ(node["skin"].get<int>(), 0);
  EXPECT_EQ(node["mesh"].get<int>(), sp["mesh"].get<int>());
  const Json& attrs = g.json["meshes"][sp["mesh"].get<size_t>()]["primitives"][0]["attributes"];
  const auto means = glb::read_accessor(g, attrs["POSITION"].get<int64_t>(), 3, "splats", "POSITION").values;
  const auto joints = glb::read_accessor(g, attrs["JOINTS_0"].get<int64_t>(), 4, "splats", "JOINTS_0").values;
  const auto weights = glb::read_accessor(g, attrs["WEIGHTS_0"].get<int64_t>(), 4, "splats", "WEIGHTS_0");
  EXPECT_TRUE(weights.normalized);
  const int N = a.gaussians.size();
  ASSERT_EQ(int(means.size()), N * 3);
  for (int i = 0; i < N; ++i) {
    int64_t sum = 0;
    for (int k = 0; k < 4; ++k) {
      const int64_t c = std::llround(weights.values[size_t(i) * 4 + size_t(k)] * 65535.0);
      ASSERT_EQ(c % 257, 0) << "splat " << i;  // exact in 8 bits
      sum += c;
    }
    ASSERT_EQ(sum, 65535) << "splat " << i;
  }
  // Pose: the left arm raised above the head and its elbow bent, the rest still.
  SmplxParams p;
  p.pose[16 * 3 + 2] = -1.3f;  // left shoulder
  p.pose[18 * 3 + 1] = -0.9f;  // left elbow
  const UnpackedAvatar u = unpack(bytes, "splats.glb");
  AvatarLoader rt(u.avatar);
  PosedAvatar exact;
  rt.repose(p, exact);
  // The splats are in the packer's (trainer's) order; the unpacked Gaussians are sorted by
  // face: match them by their rest centres.
  PosedAvatar rest;
  rt.repose(SmplxParams{}, rest);
  Lbs<double> lbs(u.avatar.body);
  LbsCache<double> cache;
  std::vector<double> verts(size_t(u.avatar.body.num_verts) * 3);
  lbs.forward(p, verts.data(), nullptr, &cache);
  std::vector<double> moved, err, far;
  const std::vector<float> rest_verts = baked_rest_vertices(a);
  for (int i = 0; i < N; ++i) {
    const Vec3d x(means[size_t(i) * 3], means[size_t(i) * 3 + 1], means[size_t(i) * 3 + 2]);
    int best = -1;
    double best_d = 1e30;
    for (int k = 0; k < N; ++k) {
      const double dd = norm(x - Vec3d(rest.means[size_t(k) * 3], rest.means[size_t(k) * 3 + 1], rest.means[size_t(k) * 3 + 2]));
      if (dd < best_d) best_d = dd, best = k;
    }
    ASSERT_LT(best_d, 1e-5) << "splat " << i << " has no Gaussian at its rest centre";
    Vec3d skinned{};
    for (int k = 0; k < 4; ++k) skinned = skinned + weights.values[size_t(i) * 4 + size_t(k)] * cache.skinning[size_t(joints[size_t(i) * 4 + size_t(k)])].apply(x);
    const Vec3d want(exact.means[size_t(best) * 3], exact.means[size_t(best) * 3 + 1], exact.means[size_t(best) * 3 + 2]);
    moved.push_back(norm(want - x));
    const int32_t* fv = &a.body.faces[size_t(a.gaussians.face[size_t(i)]) * 3];
    Vec3d centre{};
    for (int c = 0; c < 3; ++c) centre += (1.0 / 3) * Vec3d(Vec3f::load(&rest_verts[size_t(fv[c]) * 3]));
    far.push_back(norm(x - centre));
    err.push_back(norm(skinned - want));
  }
  std::vector<double> sorted_err = err;
  std::sort(sorted_err.begin(), sorted_err.end());
  const double median_err = sorted_err[sorted_err.size() / 2];
  std::printf("splats: skinned vs exact centres: median %.4f m, max %.4f m; displacement max %.3f m\n", median_err,
              sorted_err.back(), *std::max_element(moved.begin(), moved.end()));
  // Linear blend skinning of a centre approximates the face-frame reposing: exact for a
  // Gaussian on a rigidly moving face, off where a face stretches or a Gaussian sits far
  // from its face (its offset swings with the face's rotation). Of the splats that moved by
  // more than 5 cm, count those skinned no closer to their exact position than half the
  // way from where they rested ("left behind").
  int moved_far = 0, behind = 0;
  for (size_t i = 0; i < err.size(); ++i) {
    if (moved[i] <= 0.05) continue;
    ++moved_far;
    if (err[i] >= 0.5 * moved[i]) {
      ++behind;
      std::printf("  behind: splat %zu moved %.3f m, skinned %.3f m off, %.3f m from its face's centre\n", i, moved[i], err[i],
                  far[i]);
    }
  }
  std::printf("splats moved > 5 cm: %d, left behind: %d\n", moved_far, behind);
  EXPECT_GT(moved_far, 50);
  EXPECT_LE(behind, moved_far / 100);
  EXPECT_LT(median_err, 1e-3);
}

}  // namespace
}  // namespace haha
