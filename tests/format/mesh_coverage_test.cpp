// The avatar's mesh coverage through the .glb: COLOR_0 alpha on every body mesh primitive
// with the material cut at kCoverageCutoff (alphaMode MASK), so plain glTF viewers cut the
// mesh where haha does; read back exactly (lossless) or within half an 8-bit step, every
// vertex on its side of the cut; without a coverage the file carries no trace of it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "format/avatar_info.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/glb.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

using glb::Json;

struct Case {
  std::string name;
  Avatar avatar;
  PackOptions options;
};

// Every storage the body mesh has: Draco sequential (the degenerate face keeps the tube
// sequential), Draco edgebreaker, plain accessors, lossless float32, each with a garment too.
std::vector<Case> cases() {
  const Avatar tube = test::make_test_avatar(60);
  const Avatar clean = test::without_degenerate_face(tube);
  const Avatar garment = test::with_test_garment(clean, 5);
  PackOptions draco, plain, lossless, keep;
  plain.mesh_compression = MeshCompression::none;
  lossless.lossless = true;
  keep.keep_face_order = true;
  std::vector<Case> out;
  for (const auto& [name, a] : {std::pair<std::string, Avatar>{"tube", tube}, {"clean", clean}, {"garment", garment}}) {
    const Avatar c = test::with_test_coverage(a);
    out.push_back({name + " draco", c, draco});
    out.push_back({name + " plain", c, plain});
    out.push_back({name + " lossless", c, lossless});
    out.push_back({name + " sequential", c, keep});
  }
  return out;
}

const Json& accessor(const Json& gltf, const Json& index) { return gltf["accessors"][index.get<size_t>()]; }

TEST(FormatMeshCoverage, RoundTripsInEveryStorage) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    const std::vector<uint8_t> bytes = pack_avatar(c.avatar, c.options);
    const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "coverage.glb");
    const std::vector<float>& want = c.avatar.mesh_coverage;
    const std::vector<float>& got = u.avatar.mesh_coverage;
    ASSERT_EQ(got.size(), want.size());
    for (size_t v = 0; v < want.size(); ++v) {
      if (c.options.lossless) {
        ASSERT_EQ(std::memcmp(&got[v], &want[v], 4), 0) << "vertex " << v << ": lossless packs keep the float";
      } else {
        ASSERT_LE(std::fabs(got[v] - want[v]), 0.5f / 255.0f + 1e-7f) << "vertex " << v;
        ASSERT_EQ(got[v] >= kCoverageCutoff, want[v] >= kCoverageCutoff) << "vertex " << v << " changed sides of the cut";
      }
    }
  }
}

// What a plain glTF viewer reads: white COLOR_0 whose alpha is the coverage of each glTF
// vertex's body vertex (seam duplicates alike), and a material cut at kCoverageCutoff.
TEST(FormatMeshCoverage, PlainViewersSeeColor0AlphaAndAMaskMaterial) {
  const Avatar a = test::with_test_coverage(test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(60))));
  PackOptions plain;
  plain.mesh_compression = MeshCompression::none;
  const std::vector<uint8_t> bytes = pack_avatar(a, plain);
  const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "coverage.glb");
  const Json& mat = g.json["materials"][0];
  EXPECT_EQ(mat["alphaMode"], "MASK");
  EXPECT_EQ(mat["alphaCutoff"].get<double>(), double(kCoverageCutoff));
  const Json& prims = g.json["meshes"][0]["primitives"];
  ASSERT_EQ(prims.size(), 2u);
  size_t seam_duplicates = 0;
  for (const Json& p : prims) {
    const Json& acc = accessor(g.json, p["attributes"]["COLOR_0"]);
    EXPECT_EQ(acc["type"], "VEC4");
    EXPECT_EQ(acc["componentType"], 5121);
    EXPECT_EQ(acc["normalized"], true);
    const glb::AccessorValues color = glb::read_accessor(g, p["attributes"]["COLOR_0"].get<int64_t>(), 4, "t", "COLOR_0");
    const glb::AccessorValues body = glb::read_accessor(g, p["attributes"]["_BODY_VERTEX"].get<int64_t>(), 1, "t", "_BODY_VERTEX");
    ASSERT_EQ(color.count, body.count);
    std::vector<int> uses(a.mesh_coverage.size(), 0);
    for (int64_t i = 0; i < color.count; ++i) {
      const size_t v = size_t(body.values[size_t(i)]);
      seam_duplicates += uses[v]++ > 0;
      for (int k = 0; k < 3; ++k) EXPECT_EQ(color.values[size_t(i) * 4 + k], 1.0);
      EXPECT_EQ(std::lround(color.values[size_t(i) * 4 + 3] * 255.0), std::lround(255.0 * a.mesh_coverage[v])) << "glTF vertex " << i;
    }
  }
  EXPECT_GT(seam_duplicates, 0u) << "the fixture must have UV seams";
}

TEST(FormatMeshCoverage, DracoStreamsCarryColor0) {
  const Avatar a = test::with_test_coverage(test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(60))));
  for (bool lossless : {false, true}) {
    PackOptions o;
    o.lossless = lossless;
    const std::vector<uint8_t> bytes = pack_avatar(a, o);
    const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "coverage.glb");
    for (const Json& p : g.json["meshes"][0]["primitives"]) {
      EXPECT_TRUE(p["extensions"]["KHR_draco_mesh_compression"]["attributes"].contains("COLOR_0"));
      const Json& acc = accessor(g.json, p["attributes"]["COLOR_0"]);
      EXPECT_EQ(acc["componentType"], lossless ? 5126 : 5121);
      EXPECT_EQ(acc.contains("normalized"), !lossless);
    }
    EXPECT_EQ(g.json["materials"][0]["alphaMode"], "MASK");
  }
}

// Without a coverage nothing of it is written: no COLOR_0, no alpha mode, no extra bytes.
TEST(FormatMeshCoverage, AbsentCoverageLeavesNoTrace) {
  const Avatar a = test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(60)));
  for (MeshCompression m : {MeshCompression::draco, MeshCompression::none}) {
    PackOptions o;
    o.mesh_compression = m;
    PackedSizes without, with;
    const std::vector<uint8_t> bytes = pack_avatar(a, o, &without);
    pack_avatar(test::with_test_coverage(a), o, &with);
    EXPECT_LT(without.mesh, with.mesh);
    const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "plain.glb");
    EXPECT_FALSE(g.json["materials"][0].contains("alphaMode"));
    EXPECT_FALSE(g.json["materials"][0].contains("alphaCutoff"));
    for (const Json& p : g.json["meshes"][0]["primitives"]) EXPECT_FALSE(p["attributes"].contains("COLOR_0"));
    const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "plain.glb");
    EXPECT_TRUE(u.avatar.mesh_coverage.empty());
  }
}

TEST(FormatMeshCoverage, LodTiersKeepTheCoverage) {
  const Avatar a = test::with_test_coverage(test::without_degenerate_face(test::make_test_avatar(400)));
  PackOptions o;
  o.lod_tiers = 2;
  const std::vector<uint8_t> bytes = pack_avatar(a, o);
  UnpackOptions first_tier;
  first_tier.max_gaussians = 1;
  const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "lod.glb", first_tier);
  EXPECT_EQ(u.avatar.mesh_coverage.size(), a.mesh_coverage.size());
}

// `haha info`: the share of body vertices under the cutoff, in the text and the JSON.
TEST(FormatMeshCoverage, InfoReportsTheCut) {
  const Avatar a = test::with_test_coverage(test::make_test_avatar(30));
  const int V = a.body.num_verts, cut = int(std::count_if(a.mesh_coverage.begin(), a.mesh_coverage.end(),
                                                           [](float c) { return c < kCoverageCutoff; }));
  const std::vector<uint8_t> bytes = pack_avatar(a, PackOptions{});
  const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "info.glb");
  const StorageReport r = storage_report(u);
  const nlohmann::json j = avatar_summary_json("info.glb", u, r);
  EXPECT_EQ(j["meshCoverage"]["vertices"], V);
  EXPECT_EQ(j["meshCoverage"]["verticesUnderCutoff"], cut);
  EXPECT_NEAR(j["meshCoverage"]["shareUnderCutoff"].get<double>(), double(cut) / V, 1e-12);
  EXPECT_EQ(j["meshCoverage"]["cutoff"].get<double>(), 0.5);
  const std::string text = avatar_summary_text("info.glb", u, r);
  EXPECT_NE(text.find("coverage      " + std::to_string(cut) + " of " + std::to_string(V) + " body vertices"), std::string::npos) << text;

  const std::vector<uint8_t> none = pack_avatar(test::make_test_avatar(30), PackOptions{});
  const UnpackedAvatar n = unpack_avatar(none.data(), none.size(), "none.glb");
  EXPECT_TRUE(avatar_summary_json("none.glb", n, storage_report(n))["meshCoverage"].is_null());
  EXPECT_EQ(avatar_summary_text("none.glb", n, storage_report(n)).find("coverage  "), std::string::npos);
}

}  // namespace
}  // namespace haha
