// Every .glb the packer writes passes the Khronos glTF validator (npm gltf-validator,
// installed project-locally: `npm ci --prefix tools/validator`) with zero errors, and its
// HAHA_gaussian_avatar object matches format/haha_avatar.schema.json (when Python's
// jsonschema is installed). Skips (GTEST_SKIP, with the reason) when node or the validator
// is missing.
#include <gtest/gtest.h>

#include <cmath>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "format/avatar_pack.h"
#include "support/format_realistic_avatar.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

const fs::path kRepo = fs::path(__FILE__).parent_path().parent_path().parent_path();

std::string quote(const fs::path& p) { return "'" + p.string() + "'"; }

bool validator_available(std::string* why) {
  if (std::system("node --version > /dev/null 2>&1") != 0) {
    *why = "node is not installed";
    return false;
  }
  if (!fs::exists(kRepo / "tools/validator/node_modules/gltf-validator")) {
    *why = "gltf-validator is not installed (run: npm ci --prefix tools/validator)";
    return false;
  }
  return true;
}

struct Report {
  int exit_code = -1;
  nlohmann::json json;
};

Report validate(const fs::path& glb) {
  const fs::path out = glb.string() + ".report.json";
  const std::string cmd = "node " + quote(kRepo / "tools/validator/validate.js") + " " + quote(glb) + " > " + quote(out);
  Report r;
  r.exit_code = WEXITSTATUS(std::system(cmd.c_str()));
  std::ifstream f(out);
  r.json = nlohmann::json::parse(f, nullptr, false);
  return r;
}

class FormatValidator : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!validator_available(&why)) GTEST_SKIP() << "glTF validator not run: " << why;
    dir_ = fs::temp_directory_path() / ("haha-validator-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  fs::path write(const std::string& name, const Avatar& a, const PackOptions& o) {
    const fs::path p = dir_ / name;
    write_avatar_glb(a, p.string(), o);
    return p;
  }
  fs::path dir_;
};

void expect_no_errors(const fs::path& p, int faces) {
  const Report r = validate(p);
  ASSERT_TRUE(r.json.is_object()) << p << ": no validator report";
  const auto& issues = r.json["issues"];
  EXPECT_EQ(issues["numErrors"].get<int>(), 0) << p << ": " << issues.dump(1);
  // Weights it can see (plain meshes; Draco it does not decode) sum to one, at any severity.
  for (const auto& m : issues["messages"]) EXPECT_NE(m.value("code", ""), "ACCESSOR_WEIGHTS_NON_NORMALIZED") << p << ": " << m.dump();
  EXPECT_EQ(r.exit_code, 0);
  // It really looked at our content: one skinned, textured mesh with all the faces.
  const auto& info = r.json["info"];
  EXPECT_TRUE(info.value("hasSkins", false)) << info.dump(1);
  EXPECT_TRUE(info.value("hasTextures", false)) << info.dump(1);
  EXPECT_EQ(info.value("totalTriangleCount", -1), faces) << info.dump(1);
}

TEST_F(FormatValidator, EveryPackVariantHasZeroErrors) {
  const Avatar a = test::make_test_avatar(200, 2, 64, 64);
  const int F = a.body.num_faces;
  expect_no_errors(write("default.glb", a, PackOptions{}), F);
  PackOptions lossless;
  lossless.lossless = true;
  lossless.pose_correctives = haha::PoseCorrectives::dense;
  expect_no_errors(write("lossless.glb", a, lossless), F);
  PackOptions jpg;
  jpg.texture_codec = TextureCodec::jpg;
  jpg.pose_correctives = haha::PoseCorrectives::dense;
  expect_no_errors(write("jpg.glb", a, jpg), F);
  PackOptions webp;
  webp.texture_codec = TextureCodec::webp;
  webp.texture_size = 32;
  expect_no_errors(write("webp.glb", a, webp), F);
  // Version 2: an edgebreaker mesh (the test body without its degenerate face) with
  // importance tiers and normals.
  PackOptions eb;
  eb.lod_tiers = 3;
  eb.normals = true;
  expect_no_errors(write("edgebreaker_lod.glb", test::without_degenerate_face(a), eb), F - 1);
  // Version 3: the plain mesh for engines without Draco.
  PackOptions plain;
  plain.mesh_compression = MeshCompression::none;
  expect_no_errors(write("plain.glb", a, plain), F);
  plain.normals = true;
  expect_no_errors(write("plain_normals.glb", a, plain), F);
}

// A garment is primitive 1 of the body mesh (format/spec.md, body.garment), in plain and
// Draco packs: a standard skinned primitive the validator finds no fault with, its
// triangles counted with the body's.
TEST_F(FormatValidator, GarmentPrimitiveHasZeroErrors) {
  const Avatar a = test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(200, 2, 64, 64)));
  const int F = a.body.num_faces;
  PackOptions plain;
  plain.mesh_compression = MeshCompression::none;
  for (const auto& [name, o] : {std::pair<const char*, PackOptions>{"garment.glb", PackOptions{}}, {"garment_plain.glb", plain}}) {
    const fs::path p = write(name, a, o);
    expect_no_errors(p, F);
    const Report r = validate(p);
    EXPECT_EQ(r.json["info"].value("drawCallCount", -1), 2) << name << ": the body's and the garment's primitives";
  }
}

// A mesh coverage: COLOR_0 (normalized bytes, or float32 in the lossless Draco stream) on
// both primitives and the MASK material, with zero errors and no warning about any of it.
TEST_F(FormatValidator, MeshCoverageHasZeroErrors) {
  const Avatar a = test::with_test_coverage(test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(200, 2, 64, 64))));
  const int F = a.body.num_faces;
  PackOptions plain, lossless;
  plain.mesh_compression = MeshCompression::none;
  lossless.lossless = true;
  for (const auto& [name, o] : {std::pair<const char*, PackOptions>{"coverage.glb", PackOptions{}}, {"coverage_plain.glb", plain},
                                {"coverage_lossless.glb", lossless}}) {
    const fs::path p = write(name, a, o);
    expect_no_errors(p, F);
    const Report r = validate(p);
    for (const auto& m : r.json["issues"]["messages"]) {
      const std::string text = m.dump();
      EXPECT_EQ(text.find("COLOR_0"), std::string::npos) << name << ": " << text;
      EXPECT_EQ(text.find("alpha"), std::string::npos) << name << ": " << text;
    }
  }
}

TEST_F(FormatValidator, RealisticAvatarHasZeroErrors) {
  const Avatar a = test::make_realistic_avatar(3000, 256);
  expect_no_errors(write("realistic.glb", a, PackOptions{}), a.body.num_faces);
  PackOptions plain;
  plain.mesh_compression = MeshCompression::none;
  const fs::path p = write("realistic_plain.glb", a, plain);
  expect_no_errors(p, a.body.num_faces);
  // No required extension at all: any glTF 2.0 reader may open it.
  const Report r = validate(p);
  EXPECT_TRUE(r.json["info"].value("extensionsRequired", nlohmann::json::array()).empty()) << r.json["info"].dump(1);
}

TEST_F(FormatValidator, AnimationsHaveZeroErrorsAndWarnings) {
  const Avatar a = test::make_test_avatar(100);
  Motion walk, still;
  walk.fps = 30;
  for (int k = 0; k < 40; ++k) {
    SmplxParams p;
    p.pose[1] = 0.2f * float(k);  // the root turns past pi: keys change quaternion sign
    p.pose[3 * 16 + 2] = -std::sin(0.3f * float(k));
    p.pose[3 * 18 + 1] = -0.5f;  // still, not at rest: a one-key track
    p.transl = {0.02f * float(k), 0.0f, 0.0f};
    walk.frames.push_back(p);
  }
  still.frames.resize(1);
  for (int bits : {16, 8, 0}) {
    PackOptions o;
    o.mesh_compression = MeshCompression::none;  // nothing hidden from the validator in Draco
    o.animation_bits = bits;
    o.animations = {{"walk", walk}, {"still", still}};
    const fs::path p = write("animated" + std::to_string(bits) + ".glb", a, o);
    expect_no_errors(p, a.body.num_faces);
    const Report r = validate(p);
    EXPECT_EQ(r.json["issues"]["numWarnings"].get<int>(), 0) << r.json["issues"].dump(1);
    EXPECT_EQ(r.json["info"].value("animationCount", -1), 2) << r.json["info"].dump(1);
  }
}

TEST_F(FormatValidator, SplatPrimitiveOnlyTripsTheValidatorsUnknownAttributeNames) {
  // gltf-validator 2.0.0-dev.3.10 predates KHR_gaussian_splatting and reports its attribute
  // names as invalid; nothing else may be wrong with the file.
  PackOptions o;
  o.khr_gaussian_splatting = true;
  const Report r = validate(write("splats.glb", test::make_test_avatar(100), o));
  ASSERT_TRUE(r.json.is_object());
  int other = 0, names = 0;
  for (const auto& m : r.json["issues"]["messages"]) {
    if (m["severity"].get<int>() != 0) continue;
    const std::string code = m["code"], ptr = m.value("pointer", "");
    if (code == "MESH_PRIMITIVE_INVALID_ATTRIBUTE" && ptr.find("KHR_gaussian_splatting:") != std::string::npos) {
      ++names;
    } else {
      ++other;
      ADD_FAILURE() << m.dump();
    }
  }
  EXPECT_EQ(names, 4);  // ROTATION, SCALE, OPACITY, SH_DEGREE_0_COEF_0
  EXPECT_EQ(other, 0);
}

TEST_F(FormatValidator, ExtensionObjectMatchesTheJsonSchema) {
  if (std::system("python3 -c 'import jsonschema' > /dev/null 2>&1") != 0) GTEST_SKIP() << "python3 jsonschema not installed";
  PackOptions o;
  o.lossless = true;
  o.pose_correctives = haha::PoseCorrectives::dense;
  o.khr_gaussian_splatting = true;
  const fs::path p = write("schema.glb", test::make_test_avatar(50), o);
  const fs::path q = write("schema_default.glb", test::make_test_avatar(50), PackOptions{});
  PackOptions lod;
  lod.lod_tiers = 2;
  lod.mesh_compression = MeshCompression::none;
  const fs::path r = write("schema_lod.glb", test::without_degenerate_face(test::make_test_avatar(50)), lod);
  const fs::path g = write("schema_garment.glb", test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(50))), PackOptions{});
  const fs::path script = dir_ / "check.py";
  std::ofstream(script) << "import json, struct, sys, jsonschema\n"
                           "schema = json.load(open(sys.argv[1]))\n"
                           "for f in sys.argv[2:]:\n"
                           "    b = open(f, 'rb').read()\n"
                           "    n = struct.unpack('<I', b[12:16])[0]\n"
                           "    jsonschema.validate(json.loads(b[20:20 + n])['extensions']['HAHA_gaussian_avatar'], schema)\n";
  const std::string cmd = "python3 " + quote(script) + " " + quote(kRepo / "format/haha_avatar.schema.json") + " " +
                          quote(p) + " " + quote(q) + " " + quote(r) + " " + quote(g);
  EXPECT_EQ(std::system(cmd.c_str()), 0);
}

}  // namespace
}  // namespace haha
