// Bad .glb input: each case gives one haha::Error naming the file and the problem, never
// a crash; plus a bounded randomized corruption run (flips, truncations, insertions).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <random>

#include "core/error.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/draco_io.h"
#include "format/glb.h"
#include "support/expect_error.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

using glb::Json;

const char* kName = "bad.glb";

// Expects an Error whose message is one line starting with "bad.glb: " and containing `needle`.
void expect_error(const std::vector<uint8_t>& bytes, const std::string& needle, const UnpackOptions& opt = {}) {
  haha::test::expect_error_at(kName, [&] { unpack_avatar(bytes.data(), bytes.size(), kName, opt); }, {needle});
}

struct Fixture {
  Avatar avatar = test::make_test_avatar(200);
  std::vector<uint8_t> lossy = pack_avatar(avatar, PackOptions{});
  // The test body's degenerate face keeps the default pack sequential; without it the
  // mesh is edgebreaker-encoded.
  std::vector<uint8_t> edgebreaker = pack_avatar(test::without_degenerate_face(avatar), PackOptions{});
  std::vector<uint8_t> plain = [this] {
    PackOptions o;
    o.mesh_compression = MeshCompression::none;
    return pack_avatar(avatar, o);
  }();
  std::vector<uint8_t> lossless = [this] {
    PackOptions o;
    o.lossless = true;
    return pack_avatar(avatar, o);
  }();
};
const Fixture& fx() {
  static const Fixture f;
  return f;
}

// Applies `edit` to the parsed JSON (and BIN) and writes the .glb again.
template <class F>
std::vector<uint8_t> edited(const std::vector<uint8_t>& bytes, F edit) {
  glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "fixture");
  edit(g.json, g.bin);
  g.json["buffers"][0]["byteLength"] = g.bin.size();
  return glb::write_glb(g.json, g.bin);
}

// Appends `stream` as a new bufferView and points the extension's Gaussians at it (with a
// correct checksum, so the Draco decoder / validation is what must catch the problem).
std::vector<uint8_t> with_gaussian_stream(const std::vector<uint8_t>& bytes, const std::vector<uint8_t>& stream) {
  return edited(bytes, [&](Json& j, std::vector<uint8_t>& bin) {
    while (bin.size() % 4) bin.push_back(0);
    const size_t off = bin.size();
    bin.insert(bin.end(), stream.begin(), stream.end());
    j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", stream.size()}});
    auto& g = j["extensions"]["HAHA_gaussian_avatar"]["gaussians"];
    g["bufferView"] = j["bufferViews"].size() - 1;
    g["crc32"] = glb::crc32(stream.data(), stream.size());
  });
}

// A Gaussian stream laid out like pack's lossless one (raw floats), from explicit arrays.
std::vector<uint8_t> gaussian_stream(const BoundGaussians& g) {
  using dracoio::AttrIn;
  using dracoio::Kind;
  using dracoio::Type;
  return dracoio::encode(g.size(),
                         {{"FACE", Kind::generic, Type::i32, 1, g.face.data(), 0},
                          {"OFFSET", Kind::generic, Type::f32, 3, g.offset.data(), 0},
                          {"ROTATION", Kind::generic, Type::f32, 4, g.rotation.data(), 0},
                          {"SCALE", Kind::generic, Type::f32, 3, g.scale.data(), 0},
                          {"COLOR", Kind::generic, Type::f32, 3, g.color.data(), 0},
                          {"OPACITY", Kind::generic, Type::f32, 1, g.opacity.data(), 0}},
                         nullptr, 0)
      .bytes;
}

TEST(FormatBadInput, ValidFixturesLoad) {
  EXPECT_NO_THROW(unpack_avatar(fx().lossy.data(), fx().lossy.size(), kName));
  EXPECT_NO_THROW(unpack_avatar(fx().lossless.data(), fx().lossless.size(), kName));
  // The stream helper itself produces a loadable file when the data is valid.
  const auto ok = with_gaussian_stream(fx().lossless, gaussian_stream(fx().avatar.gaussians));
  EXPECT_NO_THROW(unpack_avatar(ok.data(), ok.size(), kName));
}

TEST(FormatBadInput, EmptyAndNotGlb) {
  expect_error({}, "shorter than a GLB header");
  const std::string text = "{\"asset\": {\"version\": \"2.0\"}} this is JSON, not GLB";
  expect_error(std::vector<uint8_t>(text.begin(), text.end()), "bad magic");
}

TEST(FormatBadInput, TruncatedAtEveryRegion) {
  const auto& f = fx().lossy;
  // Header, inside JSON, inside BIN (Draco mesh, Gaussians, image), one byte short.
  for (size_t n : {size_t(0), size_t(11), size_t(19), size_t(40), f.size() / 3, f.size() / 2, f.size() - 100, f.size() - 1}) {
    std::vector<uint8_t> t(f.begin(), f.begin() + long(n));
    EXPECT_THROW(unpack_avatar(t.data(), t.size(), kName), Error) << n;
  }
  std::vector<uint8_t> t(f.begin(), f.end() - 1);
  expect_error(t, "truncated");
}

// A version-3 file turned into an older version's layout: the vertex map as the private
// Draco attribute BODY_VERTEX, no canonical face order.
void as_old_version(Json& j, int version) {
  Json& ext = j["extensions"]["HAHA_gaussian_avatar"];
  Json& prim = j["meshes"][0]["primitives"][0];
  ext["version"] = version;
  ext["body"]["draco"]["attributes"]["BODY_VERTEX"] = prim["extensions"]["KHR_draco_mesh_compression"]["attributes"]["_BODY_VERTEX"];
  prim["extensions"]["KHR_draco_mesh_compression"]["attributes"].erase("_BODY_VERTEX");
  prim["attributes"].erase("_BODY_VERTEX");
  ext["gaussians"].erase("faceOrder");
}

TEST(FormatBadInput, WrongExtensionVersion) {
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["version"] = 5; }),
               "unsupported version 5");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["version"] = 0; }),
               "unsupported version 0");
  // Version 1 had a joint regressor in every file.
  expect_error(edited(fx().lossy, [](Json& j, auto&) { as_old_version(j, 1); }), "jointRegressor: missing");
  // Version 3 names the vertex map publicly and says which face order the Gaussians use.
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"].erase("_BODY_VERTEX"); }),
               "_BODY_VERTEX");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["gaussians"].erase("faceOrder"); }),
               "faceOrder: missing");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["faceOrder"] = "sorted"; }),
               "faceOrder: unknown 'sorted'");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["version"] = "1"; }),
               "unsupported version");
}

// A plain (Draco-free) body mesh: every accessor is checked against its bufferView before
// anything is allocated, and every index against the vertices.
TEST(FormatBadInput, PlainMeshAccessors) {
  const Fixture& f = fx();
  ASSERT_FALSE(unpack_avatar(f.plain.data(), f.plain.size(), kName).info.sizes.draco_mesh);
  auto attr = [](Json& j, const char* name) -> Json& { return j["accessors"][j["meshes"][0]["primitives"][0]["attributes"][name].get<size_t>()]; };
  expect_error(edited(f.plain, [&](Json& j, auto&) { attr(j, "POSITION")["count"] = 100000000; }), "do not fit its bufferView");
  expect_error(edited(f.plain, [&](Json& j, auto&) { attr(j, "TEXCOORD_0")["byteOffset"] = 1 << 30; }), "do not fit its bufferView");
  expect_error(edited(f.plain, [&](Json& j, auto&) { j["bufferViews"][attr(j, "WEIGHTS_0")["bufferView"].get<size_t>()]["byteStride"] = 4; }),
               "byteStride smaller than an element");
  expect_error(edited(f.plain, [&](Json& j, auto&) { attr(j, "JOINTS_0")["type"] = "VEC3"; }), "type VEC3, expected VEC4");
  expect_error(edited(f.plain, [&](Json& j, auto&) { attr(j, "_BODY_VERTEX")["sparse"] = Json::object(); }), "sparse accessors are not supported");
  expect_error(edited(f.plain, [&](Json& j, auto&) { j["meshes"][0]["primitives"][0]["attributes"].erase("_BODY_VERTEX"); }), "_BODY_VERTEX");
  expect_error(edited(f.plain, [&](Json& j, auto&) { j["meshes"][0]["primitives"][0]["mode"] = 0; }), "not a triangle list");
  // Values: a vertex map entry and an index out of range.
  expect_error(edited(f.plain, [&](Json& j, std::vector<uint8_t>& bin) {
                 const Json& bv = j["bufferViews"][attr(j, "_BODY_VERTEX")["bufferView"].get<size_t>()];
                 const uint16_t big = 60000;
                 std::memcpy(&bin[bv["byteOffset"].get<size_t>() + 4], &big, 2);
               }),
               "_BODY_VERTEX 60000 out of range");
  expect_error(edited(f.plain, [&](Json& j, std::vector<uint8_t>& bin) {
                 const Json& acc = j["accessors"][j["meshes"][0]["primitives"][0]["indices"].get<size_t>()];
                 const Json& bv = j["bufferViews"][acc["bufferView"].get<size_t>()];
                 const uint16_t big = 65000;
                 std::memcpy(&bin[bv["byteOffset"].get<size_t>() + 6], &big, 2);
               }),
               "index 65000 out of range");
}

// The mesh coverage (COLOR_0 alpha + alphaMode MASK): the accessor's shape and type, its
// count, white RGB, one alpha per body vertex, the material's cut, all primitives or none.
struct CoverageFixture {
  Avatar avatar = test::with_test_coverage(test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(80))));
  std::vector<uint8_t> draco = pack_avatar(avatar, PackOptions{});
  std::vector<uint8_t> plain = [this] {
    PackOptions o;
    o.mesh_compression = MeshCompression::none;
    return pack_avatar(avatar, o);
  }();
};
const CoverageFixture& coverage_fx() {
  static const CoverageFixture f;
  return f;
}

// Points primitive `p`'s COLOR_0 at a new float VEC4 accessor holding `rgba`.
void set_colors(Json& j, std::vector<uint8_t>& bin, size_t p, const std::vector<float>& rgba) {
  while (bin.size() % 4) bin.push_back(0);
  const size_t off = bin.size();
  bin.resize(off + rgba.size() * 4);
  std::memcpy(&bin[off], rgba.data(), rgba.size() * 4);
  j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", rgba.size() * 4}});
  j["accessors"].push_back({{"bufferView", j["bufferViews"].size() - 1}, {"componentType", 5126}, {"count", rgba.size() / 4}, {"type", "VEC4"}});
  j["meshes"][0]["primitives"][p]["attributes"]["COLOR_0"] = j["accessors"].size() - 1;
}

// Primitive 0's colours as the file stores them, as floats, with their body vertices.
std::pair<std::vector<float>, std::vector<int64_t>> colors_of(const std::vector<uint8_t>& bytes) {
  const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "fixture");
  const Json& a = g.json["meshes"][0]["primitives"][0]["attributes"];
  const glb::AccessorValues c = glb::read_accessor(g, a["COLOR_0"].get<int64_t>(), 4, "fixture", "COLOR_0");
  const glb::AccessorValues b = glb::read_accessor(g, a["_BODY_VERTEX"].get<int64_t>(), 1, "fixture", "_BODY_VERTEX");
  return {std::vector<float>(c.values.begin(), c.values.end()), std::vector<int64_t>(b.values.begin(), b.values.end())};
}

TEST(FormatBadInput, MeshCoverage) {
  const CoverageFixture& f = coverage_fx();
  EXPECT_EQ(unpack_avatar(f.plain.data(), f.plain.size(), kName).avatar.mesh_coverage.size(), f.avatar.mesh_coverage.size());
  auto color_acc = [](Json& j, size_t p = 0) -> Json& { return j["accessors"][j["meshes"][0]["primitives"][p]["attributes"]["COLOR_0"].get<size_t>()]; };
  for (const std::vector<uint8_t>* file : {&f.plain, &f.draco}) {
    expect_error(edited(*file, [&](Json& j, auto&) { color_acc(j)["type"] = "VEC3"; }), "COLOR_0: type VEC3, expected VEC4");
    expect_error(edited(*file, [&](Json& j, auto&) { color_acc(j)["componentType"] = 5122; }), "COLOR_0: componentType 5122");
    expect_error(edited(*file, [&](Json& j, auto&) { color_acc(j).erase("normalized"); }), "COLOR_0: componentType 5121");
    expect_error(edited(*file, [&](Json& j, auto&) { j["materials"][0].erase("alphaMode"); }), "without its material's alphaMode MASK");
    expect_error(edited(*file, [&](Json& j, auto&) { j["materials"][0]["alphaCutoff"] = 0.3; }), "alphaCutoff");
    expect_error(edited(*file, [&](Json& j, auto&) { j["materials"][0]["alphaMode"] = "BLEND"; }), "without its material's alphaMode MASK");
    // The garment's primitive without it, and a MASK material without any.
    expect_error(edited(*file, [&](Json& j, auto&) {
                   j["meshes"][0]["primitives"][1]["attributes"].erase("COLOR_0");
                   if (j["meshes"][0]["primitives"][1].contains("extensions"))
                     j["meshes"][0]["primitives"][1]["extensions"]["KHR_draco_mesh_compression"]["attributes"].erase("COLOR_0");
                 }),
                 "COLOR_0 on some body mesh primitives but not on all");
    expect_error(edited(*file, [&](Json& j, auto&) {
                   for (Json& p : j["meshes"][0]["primitives"]) p["attributes"].erase("COLOR_0");
                 }),
                 "alphaMode MASK, but the body mesh has no COLOR_0");
  }
  expect_error(edited(f.plain, [&](Json& j, auto&) { color_acc(j)["count"] = color_acc(j)["count"].get<int>() - 1; }), "COLOR_0 has");
  // Values (a float accessor in place of the packed one): seam duplicates that disagree, a
  // tinted colour, an alpha outside [0, 1].
  const auto [rgba, body] = colors_of(f.plain);
  size_t dup = 0;
  for (size_t g = 0; g < body.size() && !dup; ++g)
    for (size_t e = 0; e < g; ++e)
      if (body[e] == body[g]) dup = g;
  ASSERT_GT(dup, 0u) << "the fixture must have a seam duplicate";
  auto with = [&](size_t at, float value) {
    std::vector<float> c = rgba;
    c[at] = value;
    return edited(f.plain, [&](Json& j, std::vector<uint8_t>& bin) { set_colors(j, bin, 0, c); });
  };
  EXPECT_NO_THROW(unpack_avatar(with(0, 1.0f).data(), with(0, 1.0f).size(), kName));
  expect_error(with(dup * 4 + 3, rgba[dup * 4 + 3] > 0.5f ? 0.0f : 1.0f), "differs between its glTF vertices (seam duplicates)");
  expect_error(with(1, 0.5f), "is not white");
  expect_error(with(3, 1.5f), "alpha of body vertex");
  expect_error(with(3, std::nanf("")), "alpha of body vertex");
}

// Version-2 parts that a corrupt file can get wrong: an edgebreaker mesh in a version-1
// file, a method that contradicts the stream, FACE_CORNER out of range or inconsistent,
// rest joints without usable inverse bind matrices.
TEST(FormatBadInput, Version2Parts) {
  const Fixture& f = fx();
  ASSERT_TRUE(unpack_avatar(f.edgebreaker.data(), f.edgebreaker.size(), kName).info.sizes.edgebreaker);
  expect_error(edited(f.edgebreaker, [](Json& j, auto&) {
                 j["extensions"]["HAHA_gaussian_avatar"]["version"] = 1;
                 j["extensions"]["HAHA_gaussian_avatar"]["body"]["jointRegressor"] = {{"bufferView", 0}, {"count", 0}, {"crc32", 0}};
               }),
               "edgebreaker-encoded, which version 1 files never are");
  expect_error(edited(f.edgebreaker, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["body"]["draco"]["method"] = "sequential"; }),
               "draco.method: says 'sequential'");
  // FACE_CORNER pointed at ROTATION_LARGEST (values 0..3, unrelated to the faces).
  expect_error(edited(f.edgebreaker, [](Json& j, auto&) {
                 auto& ga = j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["attributes"];
                 ga["FACE_CORNER"] = ga["ROTATION_LARGEST"];
               }),
               "FACE_CORNER");
  expect_error(edited(f.edgebreaker, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["attributes"].erase("FACE_CORNER"); }),
               "FACE_CORNER");
  expect_error(edited(f.edgebreaker, [](Json& j, auto&) { j["skins"][0].erase("inverseBindMatrices"); }),
               "inverseBindMatrices: missing");
  expect_error(edited(f.edgebreaker, [](Json& j, auto&) { j["accessors"][j["skins"][0]["inverseBindMatrices"].get<int>()]["count"] = 54; }),
               "must be 55 float MAT4");
  expect_error(edited(f.edgebreaker, [](Json& j, auto&) { j["accessors"][j["skins"][0]["inverseBindMatrices"].get<int>()]["byteOffset"] = 64; }),
               "runs past its bufferView");
}

TEST(FormatBadInput, LodTiers) {
  PackOptions o;
  o.lod_tiers = 3;
  const std::vector<uint8_t> lod = pack_avatar(fx().avatar, o);
  ASSERT_EQ(unpack_avatar(lod.data(), lod.size(), kName).info.lod_counts.size(), 3u);
  expect_error(edited(lod, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["tiers"][1]["count"] = 49; }),
               "tiers: hold");
  expect_error(edited(lod, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["bufferView"] = 0; }),
               "both a bufferView and tiers");
  expect_error(edited(lod, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["tiers"] = Json::array(); }),
               "tiers: must be an array");
  expect_error(edited(lod, [](Json& j, auto&) {
                 auto& g = j["extensions"]["HAHA_gaussian_avatar"]["gaussians"];
                 std::swap(g["tiers"][0]["count"], g["tiers"][2]["count"]);  // same total, wrong per stream
               }),
               "points, the file says");
  // Whole tiers in another order are still a valid file.
  const std::vector<uint8_t> swapped = edited(lod, [](Json& j, auto&) {
    auto& g = j["extensions"]["HAHA_gaussian_avatar"]["gaussians"];
    std::swap(g["tiers"][0], g["tiers"][2]);
  });
  EXPECT_EQ(unpack_avatar(swapped.data(), swapped.size(), kName).avatar.gaussians.size(), 200);
}

TEST(FormatBadInput, CompactPoseCorrectives) {
  const auto pc = [](Json& j) -> Json& { return j["extensions"]["HAHA_gaussian_avatar"]["body"]["poseCorrectives"]; };
  ASSERT_EQ(unpack_avatar(fx().lossy.data(), fx().lossy.size(), kName).info.pose_correctives, "sparse_lowrank");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["encoding"] = "wavelet"; }), "encoding: unknown 'wavelet'");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["rank"] = 0; }), "rank");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["rank"] = 2; }), "wrong mixing-row byte length");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["count"] = pc(j)["count"].get<int>() - 1; }), "points, the file says");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["count"] = -1; }), "count");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["count"] = 0; }), "a point cloud for zero blocks");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["mixingCrc32"] = pc(j)["mixingCrc32"].get<int64_t>() ^ 1; }),
               "checksum mismatch");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["attributes"].erase("COEF_Y"); }), "COEF_Y");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { std::swap(pc(j)["attributes"]["JOINT"], pc(j)["attributes"]["COEF_X"]); }),
               "poseCorrectives");
  expect_error(edited(fx().lossy, [&](Json& j, auto&) { pc(j)["bufferView"] = j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["bufferView"]; }),
               "checksum mismatch");
  // NaN mixing rows with a matching checksum.
  expect_error(edited(fx().lossy, [&](Json& j, std::vector<uint8_t>& bin) {
                 const Json& v = j["bufferViews"][pc(j)["mixingBufferView"].get<size_t>()];
                 const size_t off = v.value("byteOffset", size_t(0));
                 const float nan = std::nanf("");
                 std::memcpy(&bin[off], &nan, 4);
                 pc(j)["mixingCrc32"] = glb::crc32(&bin[off], v["byteLength"].get<size_t>());
               }),
               "non-finite mixing row");
}

TEST(FormatBadInput, MissingExtensionOrUnsupportedRequirement) {
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"].erase("HAHA_gaussian_avatar"); }), "not a HAHA avatar");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensionsRequired"].push_back("KHR_unknown_thing"); }),
               "KHR_unknown_thing");
}

TEST(FormatBadInput, ChecksumMismatch) {
  expect_error(edited(fx().lossy, [](Json& j, std::vector<uint8_t>& bin) {
                 const auto& bv = j["bufferViews"][j["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["bufferView"].get<int>()];
                 bin[bv["byteOffset"].get<size_t>() + bv["byteLength"].get<size_t>() / 2] ^= 0x40;
               }),
               "gaussians: checksum mismatch");
}

TEST(FormatBadInput, DracoStreamThatDoesNotDecode) {
  std::vector<uint8_t> junk(300);
  std::mt19937 rng(5);
  for (auto& b : junk) b = uint8_t(rng());
  expect_error(with_gaussian_stream(fx().lossy, junk), "gaussians: not a Draco stream");
  // A Draco header that is right followed by garbage: the decoder itself must refuse it.
  BoundGaussians two = fx().avatar.gaussians;
  std::vector<uint8_t> cut = gaussian_stream(two);
  for (size_t i = 20; i < cut.size(); ++i) cut[i] = uint8_t(rng());
  expect_error(with_gaussian_stream(fx().lossless, cut), "gaussians: Draco stream does not decode");
  // A valid Draco stream of the wrong kind (a mesh where a point cloud belongs).
  edited(fx().lossy, [](Json&, auto&) {});
  const auto& f = fx().lossy;
  glb::Glb g = glb::parse_glb(f.data(), f.size(), "x");
  const glb::ByteSpan mesh = glb::buffer_view(g, g.json["extensions"]["HAHA_gaussian_avatar"]["body"]["draco"]["bufferView"].get<int>(), "x");
  expect_error(with_gaussian_stream(f, std::vector<uint8_t>(mesh.data, mesh.data + mesh.size)), "not a point cloud");
  // A Draco point cloud with a wrong Gaussian count.
  BoundGaussians fewer = fx().avatar.gaussians;
  fewer.resize(fewer.size() - 1);
  expect_error(with_gaussian_stream(fx().lossless, gaussian_stream(fewer)), "points, the file says");
}

TEST(FormatBadInput, FaceIndexOutOfRange) {
  BoundGaussians g = fx().avatar.gaussians;
  g.face[7] = fx().avatar.body.num_faces;  // one past the end
  expect_error(with_gaussian_stream(fx().lossless, gaussian_stream(g)), "refers to face");
  g.face[7] = -1;
  expect_error(with_gaussian_stream(fx().lossless, gaussian_stream(g)), "refers to face -1");
}

TEST(FormatBadInput, NaNAndInvalidValues) {
  BoundGaussians g = fx().avatar.gaussians;
  g.offset[5] = std::nanf("");
  expect_error(with_gaussian_stream(fx().lossless, gaussian_stream(g)), "gaussian offset: non-finite");
  g = fx().avatar.gaussians;
  g.scale[3] = -1.0f;
  expect_error(with_gaussian_stream(fx().lossless, gaussian_stream(g)), "gaussian scale: non-positive");
  g = fx().avatar.gaussians;
  g.opacity[0] = INFINITY;
  expect_error(with_gaussian_stream(fx().lossless, gaussian_stream(g)), "gaussian opacity: non-finite");
  // JSON numbers beyond float range (JSON has no NaN literal).
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["subject"]["betas"][0] = 1e300; }),
               "out of float range");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["faceFrame"]["scaleDivisor"] = -1.0; }),
               "face_scale_divisor");
}

TEST(FormatBadInput, InconsistentStructure) {
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["body"]["faceCount"] = 7; }), "faces, the file says");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["bufferViews"][0]["byteLength"] = 1u << 30; }), "outside");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["skins"][0]["joints"].erase(3); }), "55 joints");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["extensions"]["HAHA_gaussian_avatar"]["gaussians"].erase("attributes"); }),
               "gaussians.attributes: missing");
  expect_error(edited(fx().lossy, [](Json& j, auto&) { j["images"][0]["mimeType"] = "image/gif"; }), "unsupported mimeType");
}

// Randomized corruption: every outcome must be success or haha::Error (a crash or any
// other exception fails the test). Bounded: fixed seed, fixed count.
void fuzz(const std::vector<uint8_t>& base, int iterations, uint32_t seed, const UnpackOptions& opt,
          bool only_draco_streams, int* errors) {
  std::mt19937 rng(seed);
  glb::Glb g = glb::parse_glb(base.data(), base.size(), "x");
  const size_t bin_start = base.size() - ((g.bin.size() + 3) / 4 * 4);
  std::vector<std::pair<size_t, size_t>> streams;  // [begin, end) in file bytes
  for (int v : {g.json["extensions"]["HAHA_gaussian_avatar"]["body"]["draco"]["bufferView"].get<int>(),
                g.json["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["bufferView"].get<int>()}) {
    const auto& bv = g.json["bufferViews"][size_t(v)];
    streams.push_back({bin_start + bv["byteOffset"].get<size_t>(), bin_start + bv["byteOffset"].get<size_t>() + bv["byteLength"].get<size_t>()});
  }
  for (int it = 0; it < iterations; ++it) {
    std::vector<uint8_t> b = base;
    const int kind = int(rng() % 4);
    auto pos = [&]() -> size_t {
      if (only_draco_streams) {
        const auto& s = streams[rng() % streams.size()];
        return s.first + rng() % (s.second - s.first);
      }
      return rng() % b.size();
    };
    if (kind == 0) {  // flip 1..8 bits
      const int n = 1 + int(rng() % 8);
      for (int k = 0; k < n; ++k) b[pos()] ^= uint8_t(1u << (rng() % 8));
    } else if (kind == 1) {  // random bytes
      const int n = 1 + int(rng() % 16);
      for (int k = 0; k < n; ++k) b[pos()] = uint8_t(rng());
    } else if (kind == 2 && !only_draco_streams) {  // truncate
      b.resize(rng() % b.size());
    } else {  // overwrite a run with 0x00 or 0xFF
      const size_t p = pos(), n = 1 + rng() % 64;
      const uint8_t v = (rng() & 1) ? 0xFF : 0x00;
      for (size_t k = p; k < std::min(b.size(), p + n); ++k) b[k] = v;
    }
    try {
      unpack_avatar(b.data(), b.size(), kName, opt);
    } catch (const Error& e) {
      ++*errors;
      if (std::getenv("HAHA_FUZZ_LOG")) std::fprintf(stderr, "%u/%d: %s\n", seed, it, e.what());
    }
  }
}

TEST(FormatBadInput, RandomCorruptionNeverCrashes) {
  // HAHA_FUZZ_SCALE=k runs k times as many iterations (longer soak runs by hand).
  const int scale = std::getenv("HAHA_FUZZ_SCALE") ? std::max(1, std::atoi(std::getenv("HAHA_FUZZ_SCALE"))) : 1;
  const auto t0 = std::chrono::steady_clock::now();
  int errors = 0;
  fuzz(fx().lossy, 1500 * scale, 11, UnpackOptions{}, false, &errors);
  fuzz(fx().lossless, 500 * scale, 12, UnpackOptions{}, false, &errors);
  // Most corruptions must be detected (checksums, JSON, structure checks).
  EXPECT_GT(errors, 1500 * scale);
  // With checksums off the Draco decoder itself meets corrupted streams.
  int derr = 0;
  UnpackOptions raw;
  raw.verify_checksums = false;
  fuzz(fx().lossy, 1500 * scale, 13, raw, true, &derr);
  fuzz(fx().lossless, 500 * scale, 14, raw, true, &derr);
  EXPECT_GT(derr, 0);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  RecordProperty("seconds", std::to_string(secs));
}

}  // namespace
}  // namespace haha
