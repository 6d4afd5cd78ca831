// A garment (body/garment.h) in the .glb: primitive 1 of the body mesh, a standard skinned
// primitive beside the body's (format/spec.md, body.garment), read back as one mesh whose
// garment the unpacked avatar carries again; version-3 files (the garment inside primitive
// 0) still load the same way.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <random>

#include "body/lbs.h"
#include "core/error.h"
#include "format/avatar_loader.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/glb.h"
#include "support/format_test_avatar.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
const fs::path kRepo = fs::path(__FILE__).parent_path().parent_path().parent_path();

Avatar garment_avatar(int on_garment = 7) {
  return test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(120)), on_garment);
}

PackOptions plain_pack() {
  PackOptions o;
  o.mesh_compression = MeshCompression::none;
  return o;
}

PackOptions lossless_pack() {
  PackOptions o;
  o.lossless = true;
  o.pose_correctives = PoseCorrectives::dense;
  return o;
}

int garment_gaussians(const Avatar& a) {
  const auto& f = a.gaussians.face;
  return int(std::count_if(f.begin(), f.end(), [&](int32_t x) { return x >= a.body.garment_first_face; }));
}

TEST(GarmentPrimitive, IsASecondSkinnedPrimitiveOfTheBodyMesh) {
  const Avatar a = garment_avatar();
  const BodyModel& b = a.body;
  for (const PackOptions& opt : {PackOptions{}, plain_pack(), lossless_pack()}) {
    const std::vector<uint8_t> bytes = pack_avatar(a, opt);
    const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "garment.glb");
    const auto& prims = g.json["meshes"][0]["primitives"];
    ASSERT_EQ(prims.size(), 2u);
    const bool draco = opt.mesh_compression == MeshCompression::draco;
    for (const auto& p : prims) {
      EXPECT_EQ(p["mode"], 4);
      EXPECT_EQ(p["material"], 0);
      for (const char* k : {"POSITION", "TEXCOORD_0", "JOINTS_0", "WEIGHTS_0", "_BODY_VERTEX"}) EXPECT_TRUE(p["attributes"].contains(k)) << k;
      EXPECT_TRUE(p.contains("indices"));
      EXPECT_EQ(p.contains("extensions"), draco);
    }
    // Triangles: the body's, then the garment's.
    EXPECT_EQ(g.json["accessors"][int(prims[0]["indices"])]["count"], b.garment_first_face * 3);
    EXPECT_EQ(g.json["accessors"][int(prims[1]["indices"])]["count"], (b.num_faces - b.garment_first_face) * 3);
    const auto& ext = g.json["extensions"][kAvatarExtension];
    EXPECT_EQ(ext["version"], kAvatarFormatVersion);
    EXPECT_EQ(ext["body"]["garment"]["primitive"], 1);
    EXPECT_EQ(ext["body"]["garment"].contains("draco"), draco);
    if (draco) {
      EXPECT_NE(ext["body"]["garment"]["draco"]["bufferView"], ext["body"]["draco"]["bufferView"]);
    }
  }
}

// The unpacked avatar carries its garment again (where it starts, its chart, its own UVs),
// so unpack -> pack writes the garment primitive again with the same Gaussians on it.
TEST(GarmentPrimitive, UnpackRestoresTheGarmentAndRepackKeepsIt) {
  const Avatar a = garment_avatar();
  const BodyModel& b = a.body;
  const Garment want = garment_of(b);
  for (const PackOptions& opt : {PackOptions{}, plain_pack(), lossless_pack()}) {
    const std::vector<uint8_t> bytes = pack_avatar(a, opt);
    const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "garment.glb");
    const BodyModel& ub = u.avatar.body;
    ASSERT_TRUE(ub.has_garment());
    EXPECT_EQ(ub.garment_first_vert, b.garment_first_vert);
    EXPECT_EQ(ub.garment_first_face, b.garment_first_face);
    EXPECT_FLOAT_EQ(ub.garment_chart, b.garment_chart);
    EXPECT_EQ(garment_gaussians(u.avatar), 7);
    const Garment got = garment_of(ub);
    EXPECT_EQ(got.num_verts(), want.num_verts());
    EXPECT_EQ(got.num_faces(), want.num_faces());
    for (size_t i = 0; i < got.vt.size(); i += 2) EXPECT_GE(got.vt[i], 1.0f - b.garment_chart - 1e-3f) << "a garment UV outside its chart";
    for (size_t i = 0; i < got.verts.size(); ++i) EXPECT_NEAR(got.verts[i], want.verts[i], 1e-4f);

    const std::vector<uint8_t> again = pack_avatar(u.avatar, opt);
    const UnpackedAvatar u2 = unpack_avatar(again.data(), again.size(), "again.glb");
    const glb::Glb g = glb::parse_glb(again.data(), again.size(), "again.glb");
    EXPECT_EQ(g.json["meshes"][0]["primitives"].size(), 2u);
    EXPECT_EQ(u2.info.garment_first_vertex, b.garment_first_vert);
    EXPECT_EQ(u2.info.garment_first_face, b.garment_first_face);
    EXPECT_EQ(u2.info.garment_gaussians, 7);
    EXPECT_EQ(garment_gaussians(u2.avatar), 7);
    EXPECT_EQ(u2.avatar.gaussians.size(), a.gaussians.size());
  }
}

// The version-3 layout (the garment inside primitive 0, the fuzz corpus' seed written by
// that packer) still loads, with its garment restored.
TEST(GarmentPrimitive, VersionThreeFileStillLoads) {
  const fs::path seed = kRepo / "tests/fuzz/corpus/avatar_glb/seed8_v3_garment.glb";
  const std::vector<uint8_t> bytes = test::slurp_bytes(seed);
  ASSERT_FALSE(bytes.empty()) << seed;
  const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), seed.string());
  EXPECT_EQ(u.info.version, 3);
  const BodyModel& ub = u.avatar.body;
  ASSERT_TRUE(ub.has_garment());
  EXPECT_EQ(ub.garment_first_vert, u.info.garment_first_vertex);
  EXPECT_EQ(ub.garment_first_face, u.info.garment_first_face);
  EXPECT_EQ(garment_gaussians(u.avatar), u.info.garment_gaussians);
  const Garment g = garment_of(ub);
  EXPECT_EQ(g.num_faces(), ub.num_faces - ub.garment_first_face);
  for (size_t i = 0; i < g.vt.size(); i += 2) EXPECT_GE(g.vt[i], 1.0f - ub.garment_chart - 1e-3f);
  // Packed again it is a version-4 file with the garment primitive.
  const std::vector<uint8_t> again = pack_avatar(u.avatar, PackOptions{});
  const glb::Glb gl = glb::parse_glb(again.data(), again.size(), "again.glb");
  EXPECT_EQ(gl.json["meshes"][0]["primitives"].size(), 2u);
  EXPECT_EQ(unpack_avatar(again.data(), again.size(), "again.glb").info.garment_gaussians, u.info.garment_gaussians);
}

// A garment file that does not hold together gives one error naming the file and the part.
TEST(GarmentPrimitive, InconsistentGarmentFilesAreRefused) {
  const std::vector<uint8_t> bytes = pack_avatar(garment_avatar(), plain_pack());
  const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "garment.glb");
  auto expect_refused = [&](const std::function<void(glb::Json&)>& edit, const std::string& expect) {
    glb::Json j = g.json;
    edit(j);
    const std::vector<uint8_t> bad = glb::write_glb(j, g.bin);
    try {
      unpack_avatar(bad.data(), bad.size(), "bad.glb");
      ADD_FAILURE() << "accepted; expected an error mentioning " << expect;
    } catch (const Error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("bad.glb"), std::string::npos) << m;
      EXPECT_NE(m.find(expect), std::string::npos) << m;
    }
  };
  auto garment = [](glb::Json& j) -> glb::Json& { return j["extensions"][kAvatarExtension]["body"]["garment"]; };
  expect_refused([](glb::Json& j) { j["extensions"][kAvatarExtension]["body"].erase("garment"); }, "a second primitive");
  expect_refused([](glb::Json& j) { j["extensions"][kAvatarExtension]["version"] = 3; }, "a second primitive");
  expect_refused([&](glb::Json& j) { garment(j)["firstFace"] = int(garment(j)["firstFace"]) - 1; }, "primitives[0]");
  expect_refused([&](glb::Json& j) { garment(j)["firstVertex"] = int(garment(j)["firstVertex"]) + 1; }, "joins the body's and the garment's");
  expect_refused([&](glb::Json& j) { garment(j)["chart"] = 0.9; }, "chart");
  expect_refused([](glb::Json& j) { j["meshes"][0]["primitives"].push_back(j["meshes"][0]["primitives"][1]); }, "3 primitives");
}

// A body model given to the loader (haha render --model) supplies the body's correctives:
// it is checked against the body part, and the garment keeps its own weights, no
// correctives, as the trainer's LBS does.
TEST(GarmentPrimitive, BodyModelSuppliesTheBodysCorrectivesOnly) {
  const Avatar bare = test::without_degenerate_face(test::make_test_avatar(120));
  const Avatar a = test::with_test_garment(bare, 7);
  PackOptions opt = plain_pack();
  opt.pose_correctives = PoseCorrectives::none;
  const std::vector<uint8_t> bytes = pack_avatar(a, opt);
  const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "garment.glb");
  ASSERT_TRUE(u.avatar.body.posedirs.empty());
  AvatarLoader loader(u.avatar);
  loader.set_pose_correctives(bare.body);
  ASSERT_TRUE(loader.has_pose_correctives());
  SmplxParams p;
  std::mt19937 rng(5);
  std::normal_distribution<float> n(0.0f, 0.4f);
  for (float& x : p.pose) x = n(rng);
  p.betas = a.betas, p.expression = a.expression;
  std::vector<float> want(a.body.v_template.size());
  Lbs<float>(a.body).forward(p, want.data(), nullptr, nullptr);
  PosedAvatar posed;
  loader.repose(p, posed);
  float worst = 0;
  for (size_t i = 0; i < want.size(); ++i) worst = std::max(worst, std::fabs(posed.verts[i] - want[i]));
  EXPECT_LT(worst, 2e-3f) << "m, every posed vertex (body with correctives, garment without)";
  // A model of another topology is still refused.
  BodyModel other = bare.body;
  other.faces.resize(other.faces.size() - 3);
  other.num_faces -= 1;
  EXPECT_THROW(loader.set_pose_correctives(other), Error);
}

}  // namespace
}  // namespace haha
