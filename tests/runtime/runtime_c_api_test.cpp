// The C API of libhaha_runtime.so (runtime/include/haha/haha_runtime.h): what the shared
// library exports (C symbols only, no trainer code), and every call through the .so against
// the C++ runtime it wraps, including every error path (status + one-line message naming
// the file), with nothing crashing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "format/animation.h"
#include "format/avatar_loader.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/glb.h"
#include "haha/haha_runtime.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/motion.h"
#include "io/npy.h"
#include "support/format_test_avatar.h"
#include "support/runtime_sample_inputs.h"

namespace fs = std::filesystem;

namespace haha {
namespace {

// ---- fixtures -------------------------------------------------------------------------

// A fresh directory per test process, removed at exit (by its static owner's destructor).
struct OwnedDir {
  fs::path path = fs::temp_directory_path() / ("haha_runtime_c_api_" + std::to_string(::getpid()));
  OwnedDir() { fs::create_directories(path); }
  ~OwnedDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};
const fs::path& tmp_dir() {
  static const OwnedDir dir;
  return dir.path;
}

void write_bytes(const fs::path& p, const std::vector<uint8_t>& b) {
  std::ofstream f(p, std::ios::binary);
  f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

struct Fixture {
  Avatar avatar = test::make_test_avatar(300, 2, 32, 24);
  std::vector<uint8_t> lossless, lossy_no_correctives;
  fs::path lossless_path, lossy_path;
  Fixture() {
    PackOptions o;
    o.lossless = true;
    o.pose_correctives = haha::PoseCorrectives::dense;
    lossless = pack_avatar(avatar, o);
    PackOptions bare;
    bare.pose_correctives = PoseCorrectives::none;  // the default embeds them compactly
    lossy_no_correctives = pack_avatar(avatar, bare);
    lossless_path = tmp_dir() / "lossless.glb";
    lossy_path = tmp_dir() / "lossy.glb";
    write_bytes(lossless_path, lossless);
    write_bytes(lossy_path, lossy_no_correctives);
  }
};
const Fixture& fx() {
  static const Fixture f;
  return f;
}

// Owning handles for the tests.
struct AvatarHandle {
  haha_avatar* p = nullptr;
  ~AvatarHandle() { haha_avatar_free(p); }
};
struct PosedHandle {
  haha_posed* p = nullptr;
  ~PosedHandle() { haha_posed_free(p); }
};

haha_avatar* load_ok(const fs::path& path, const char* model = nullptr) {
  haha_avatar* a = nullptr;
  EXPECT_EQ(haha_avatar_load(path.c_str(), model, &a), HAHA_OK) << haha_last_error();
  EXPECT_STREQ(haha_last_error(), "");
  return a;
}

// The C++ runtime of the same bytes: what the C API must reproduce exactly.
AvatarLoader cpp_runtime(const std::vector<uint8_t>& bytes) {
  return AvatarLoader(unpack_avatar(bytes.data(), bytes.size(), "mem.glb").avatar);
}

using test::front_camera;
using test::random_pose;
Camera to_cpp(const haha_camera& c) {
  Camera k;
  k.width = c.width, k.height = c.height, k.fx = c.fx, k.fy = c.fy, k.cx = c.cx, k.cy = c.cy;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) k.R.a[i][j] = c.rotation[3 * i + j];
  k.t = Vec3f(c.translation[0], c.translation[1], c.translation[2]);
  return k;
}

// Expects `status` with a one-line message containing every needle (and starting with
// `prefix` when given).
void expect_failure(haha_status got, haha_status want, const std::vector<std::string>& needles,
                    const std::string& prefix = "") {
  EXPECT_EQ(got, want) << haha_status_string(got) << ": " << haha_last_error();
  const std::string msg = haha_last_error();
  EXPECT_FALSE(msg.empty());
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  for (const auto& n : needles) EXPECT_NE(msg.find(n), std::string::npos) << "message: " << msg << "\nmissing: " << n;
  if (!prefix.empty()) {
    EXPECT_EQ(msg.rfind(prefix + ": ", 0), 0u) << "message should start with '" << prefix << ": ': " << msg;
  }
}

std::string run_output(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  EXPECT_EQ(pclose(p), 0) << cmd;
  return out;
}

// Symbol names (last column) of nm output lines.
std::vector<std::string> symbol_names(const std::string& nm_output) {
  std::vector<std::string> names;
  size_t start = 0;
  while (start < nm_output.size()) {
    size_t end = nm_output.find('\n', start);
    if (end == std::string::npos) end = nm_output.size();
    const std::string line = nm_output.substr(start, end - start);
    start = end + 1;
    // "<address> <type> <name>", names may contain spaces when demangled.
    const size_t a = line.find(' ');
    if (a == std::string::npos) continue;
    const size_t b = line.find(' ', a + 1);
    if (b == std::string::npos) continue;
    names.push_back(line.substr(b + 1));
  }
  return names;
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// ---- the shared library ------------------------------------------------------------------

TEST(RuntimeCApi, ExportsOnlyTheCApi) {
  const std::string so = HAHA_RUNTIME_SO;
  const std::vector<std::string> exported = symbol_names(run_output("nm -D --defined-only '" + so + "'"));
  ASSERT_FALSE(exported.empty());
  std::set<std::string> names;
  for (const std::string& s : exported) {
    EXPECT_EQ(s.rfind("haha_", 0), 0u) << "exported symbol outside the C API: " << s;
    names.insert(s.substr(0, s.find('@')));  // strip a symbol version, if any
  }
  for (const char* f : {"haha_version", "haha_version_string", "haha_last_error", "haha_status_string",
                        "haha_set_num_threads", "haha_avatar_load", "haha_avatar_load_memory", "haha_avatar_free",
                        "haha_avatar_get_info", "haha_avatar_faces", "haha_avatar_face_uvs", "haha_avatar_texture",
                        "haha_avatar_mesh_coverage", "haha_posed_create", "haha_posed_free", "haha_repose", "haha_posed_vertices",
                        "haha_posed_normals", "haha_posed_joints", "haha_posed_gaussians", "haha_render",
                        "haha_motion_load", "haha_motion_load_for_avatar", "haha_motion_free", "haha_motion_info", "haha_motion_frame",
                        "haha_avatar_animation_count", "haha_avatar_animation_info", "haha_avatar_sample_animation",
                        "haha_write_png"})
    EXPECT_TRUE(names.count(f)) << f << " is not exported";

  // No trainer code: neither among the exported names (demangled) nor anywhere in the
  // full symbol table (local symbols included).
  for (const std::string& s : symbol_names(run_output("nm -D -C --defined-only '" + so + "'"))) {
    const std::string l = lower(s);
    for (const char* bad : {"trainer", "adam", "lpips", "knn"}) EXPECT_EQ(l.find(bad), std::string::npos) << s;
  }
  const std::string full = run_output("nm -C '" + so + "' 2>&1");
  EXPECT_NE(full.find("haha_avatar_load"), std::string::npos) << "nm -C gave no symbol table";
  for (const char* bad : {"haha::Trainer", "haha::Adam", "haha::LpipsNet", "haha::knn", "haha::Knn"})
    EXPECT_EQ(full.find(bad), std::string::npos) << bad << " is linked into " << so;

  // A SONAME with the version, so consumers bind to a compatible library.
  const std::string dyn = run_output("objdump -p '" + so + "'");
  EXPECT_NE(dyn.find("SONAME               libhaha_runtime.so." + std::to_string(HAHA_RUNTIME_VERSION_MAJOR) + "." +
                     std::to_string(HAHA_RUNTIME_VERSION_MINOR)),
            std::string::npos)
      << dyn;
}

TEST(RuntimeCApi, VersionAndStatusStrings) {
  int major = -1, minor = -1, patch = -1;
  EXPECT_EQ(haha_version(&major, &minor, &patch), HAHA_OK);
  EXPECT_EQ(major, HAHA_RUNTIME_VERSION_MAJOR);
  EXPECT_EQ(minor, HAHA_RUNTIME_VERSION_MINOR);
  EXPECT_EQ(patch, HAHA_RUNTIME_VERSION_PATCH);
  EXPECT_EQ(haha_version(nullptr, nullptr, nullptr), HAHA_OK);
  EXPECT_EQ(std::string(haha_version_string()),
            std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch));
  EXPECT_STREQ(haha_status_string(HAHA_OK), "HAHA_OK");
  EXPECT_STREQ(haha_status_string(HAHA_ERROR_FORMAT), "HAHA_ERROR_FORMAT");
  EXPECT_STREQ(haha_status_string(haha_status(99)), "unknown status");
  expect_failure(haha_set_num_threads(0), HAHA_ERROR_ARGUMENT, {"haha_set_num_threads", ">= 1"});
  EXPECT_EQ(haha_set_num_threads(2), HAHA_OK);
  EXPECT_STREQ(haha_last_error(), "");  // a success clears the last error
}

// ---- avatars -------------------------------------------------------------------------------

TEST(RuntimeCApi, LoadsFromFileAndMemoryWithTheAvatarsCounts) {
  const Avatar& a = fx().avatar;
  AvatarHandle file, mem;
  file.p = load_ok(fx().lossless_path);
  ASSERT_EQ(haha_avatar_load_memory(fx().lossless.data(), fx().lossless.size(), "mem.glb", nullptr, &mem.p), HAHA_OK)
      << haha_last_error();
  for (haha_avatar* h : {file.p, mem.p}) {
    haha_avatar_info info{};
    ASSERT_EQ(haha_avatar_get_info(h, &info), HAHA_OK);
    EXPECT_EQ(info.num_vertices, a.body.num_verts);
    EXPECT_EQ(info.num_faces, a.body.num_faces);
    EXPECT_EQ(info.num_gaussians, a.gaussians.size());
    EXPECT_EQ(info.num_joints, 55);
    EXPECT_EQ(info.texture_width, 32);
    EXPECT_EQ(info.texture_height, 24);
    EXPECT_EQ(info.has_pose_correctives, 1);  // embedded
    EXPECT_EQ(info.missing_pose_correctives, 0);
  }
  // Faces as stored; UVs per corner; the texture within 8-bit rounding.
  std::vector<uint32_t> faces(a.body.faces.size());
  ASSERT_EQ(haha_avatar_faces(file.p, faces.data(), faces.size()), HAHA_OK);
  for (size_t i = 0; i < faces.size(); ++i) ASSERT_EQ(faces[i], uint32_t(a.body.faces[i])) << i;
  std::vector<float> uv(a.body.faces.size() * 2);
  ASSERT_EQ(haha_avatar_face_uvs(file.p, uv.data(), uv.size()), HAHA_OK);
  for (size_t i = 0; i < a.body.ft.size(); ++i)
    for (int k = 0; k < 2; ++k) ASSERT_EQ(uv[2 * i + k], a.body.vt[size_t(a.body.ft[i]) * 2 + k]) << i;
  std::vector<uint8_t> tex(32 * 24 * 3);
  ASSERT_EQ(haha_avatar_texture(file.p, tex.data(), tex.size()), HAHA_OK);
  for (size_t i = 0; i < tex.size(); ++i) ASSERT_NEAR(tex[i], a.texture.rgb[i] * 255.0f, 0.5f + 1e-3f) << i;

  // Too small: an argument error naming the call and the sizes, nothing written.
  std::vector<uint32_t> small(faces.size() - 1, 7u);
  expect_failure(haha_avatar_faces(file.p, small.data(), small.size()), HAHA_ERROR_ARGUMENT,
                 {"haha_avatar_faces", "capacity " + std::to_string(small.size()), std::to_string(faces.size())});
  for (uint32_t x : small) ASSERT_EQ(x, 7u);
  expect_failure(haha_avatar_face_uvs(file.p, uv.data(), uv.size() - 1), HAHA_ERROR_ARGUMENT, {"haha_avatar_face_uvs", "capacity"});
  expect_failure(haha_avatar_texture(file.p, tex.data(), tex.size() - 1), HAHA_ERROR_ARGUMENT, {"haha_avatar_texture", "capacity"});
  expect_failure(haha_avatar_get_info(nullptr, nullptr), HAHA_ERROR_ARGUMENT, {"haha_avatar_get_info", "NULL"});
  expect_failure(haha_avatar_faces(file.p, nullptr, 100000), HAHA_ERROR_ARGUMENT, {"indices is NULL"});
}

// The mesh coverage per body vertex for engines that draw the mesh themselves: exact from a
// lossless pack, within half an 8-bit step (and on the same side of the cut) from a lossy one;
// 1 everywhere without one.
TEST(RuntimeCApi, MeshCoverageForEnginesThatDrawTheMesh) {
  const Avatar a = test::with_test_coverage(test::make_test_avatar(40));
  const size_t V = size_t(a.body.num_verts);
  PackOptions lossless;
  lossless.lossless = true;
  for (const PackOptions& o : {PackOptions{}, lossless}) {
    const std::vector<uint8_t> bytes = pack_avatar(a, o);
    AvatarHandle h;
    ASSERT_EQ(haha_avatar_load_memory(bytes.data(), bytes.size(), "coverage.glb", nullptr, &h.p), HAHA_OK) << haha_last_error();
    std::vector<float> c(V, -1.0f);
    int32_t has = -1;
    ASSERT_EQ(haha_avatar_mesh_coverage(h.p, c.data(), c.size(), &has), HAHA_OK) << haha_last_error();
    EXPECT_EQ(has, 1);
    for (size_t v = 0; v < V; ++v) {
      if (o.lossless) ASSERT_EQ(c[v], a.mesh_coverage[v]) << v;
      ASSERT_NEAR(c[v], a.mesh_coverage[v], 0.5f / 255.0f + 1e-7f) << v;
      ASSERT_EQ(c[v] >= HAHA_MESH_COVERAGE_CUTOFF, a.mesh_coverage[v] >= HAHA_MESH_COVERAGE_CUTOFF) << v;
    }
    has = -1;
    EXPECT_EQ(haha_avatar_mesh_coverage(h.p, nullptr, 0, &has), HAHA_OK);  // the flag alone
    EXPECT_EQ(has, 1);
    std::vector<float> small(V - 1, 7.0f);
    expect_failure(haha_avatar_mesh_coverage(h.p, small.data(), small.size(), nullptr), HAHA_ERROR_ARGUMENT,
                   {"haha_avatar_mesh_coverage", "capacity " + std::to_string(V - 1), std::to_string(V)});
    for (float x : small) ASSERT_EQ(x, 7.0f);
  }
  AvatarHandle none;
  none.p = load_ok(fx().lossless_path);
  std::vector<float> c(size_t(fx().avatar.body.num_verts), -1.0f);
  int32_t has = -1;
  ASSERT_EQ(haha_avatar_mesh_coverage(none.p, c.data(), c.size(), &has), HAHA_OK);
  EXPECT_EQ(has, 0);
  for (float x : c) ASSERT_EQ(x, 1.0f);
  expect_failure(haha_avatar_mesh_coverage(nullptr, c.data(), c.size(), &has), HAHA_ERROR_ARGUMENT, {"haha_avatar_mesh_coverage", "NULL"});
}

// haha_avatar_load_lod: a file with importance tiers loads the tiers that fit; a file
// without tiers loads whole.
TEST(RuntimeCApi, LoadsAPrefixOfImportanceTiers) {
  PackOptions o;
  o.lod_tiers = 3;  // 300 Gaussians: tiers of 75, 75, 150
  const fs::path path = tmp_dir() / "lod.glb";
  write_bytes(path, pack_avatar(fx().avatar, o));
  for (auto [limit, want] : {std::pair{0, 300}, std::pair{1, 75}, std::pair{150, 150}, std::pair{299, 150}, std::pair{300, 300}}) {
    AvatarHandle h;
    ASSERT_EQ(haha_avatar_load_lod(path.c_str(), nullptr, limit, &h.p), HAHA_OK) << haha_last_error();
    haha_avatar_info info{};
    ASSERT_EQ(haha_avatar_get_info(h.p, &info), HAHA_OK);
    EXPECT_EQ(info.num_gaussians, want) << "limit " << limit;
  }
  AvatarHandle whole;
  ASSERT_EQ(haha_avatar_load_lod(fx().lossy_path.c_str(), nullptr, 10, &whole.p), HAHA_OK) << haha_last_error();
  haha_avatar_info info{};
  ASSERT_EQ(haha_avatar_get_info(whole.p, &info), HAHA_OK);
  EXPECT_EQ(info.num_gaussians, 300);
  expect_failure(haha_avatar_load_lod(nullptr, nullptr, 0, &whole.p), HAHA_ERROR_ARGUMENT, {"haha_avatar_load_lod", "NULL"});
}

TEST(RuntimeCApi, BodyModelSuppliesMissingPoseCorrectives) {
  // Packed without correctives, trained with them: flagged missing until the model is given.
  AvatarHandle bare;
  bare.p = load_ok(fx().lossy_path);
  haha_avatar_info info{};
  ASSERT_EQ(haha_avatar_get_info(bare.p, &info), HAHA_OK);
  EXPECT_EQ(info.has_pose_correctives, 0);
  EXPECT_EQ(info.missing_pose_correctives, 1);

  // The default pack embeds them (compact): nothing missing without the model.
  const fs::path compact = tmp_dir() / "compact.glb";
  write_bytes(compact, pack_avatar(fx().avatar, PackOptions{}));
  AvatarHandle embedded;
  embedded.p = load_ok(compact);
  ASSERT_EQ(haha_avatar_get_info(embedded.p, &info), HAHA_OK);
  EXPECT_EQ(info.has_pose_correctives, 1);
  EXPECT_EQ(info.missing_pose_correctives, 0);

  const fs::path model = tmp_dir() / "model.npz";
  BodyModel body = fx().avatar.body;
  save_body_model(body, model.string());
  AvatarHandle with;
  with.p = load_ok(fx().lossy_path, model.c_str());
  ASSERT_EQ(haha_avatar_get_info(with.p, &info), HAHA_OK);
  EXPECT_EQ(info.has_pose_correctives, 1);
  EXPECT_EQ(info.missing_pose_correctives, 0);
  // ... from memory too.
  AvatarHandle mem;
  ASSERT_EQ(haha_avatar_load_memory(fx().lossy_no_correctives.data(), fx().lossy_no_correctives.size(), nullptr,
                                    model.c_str(), &mem.p),
            HAHA_OK)
      << haha_last_error();
  ASSERT_EQ(haha_avatar_get_info(mem.p, &info), HAHA_OK);
  EXPECT_EQ(info.has_pose_correctives, 1);

  // A model of another mesh: the caller's mistake, named.
  const fs::path other = tmp_dir() / "other_model.npz";
  save_body_model(test::make_test_body(8, 10), other.string());
  haha_avatar* out = reinterpret_cast<haha_avatar*>(0x1);
  expect_failure(haha_avatar_load(fx().lossy_path.c_str(), other.c_str(), &out), HAHA_ERROR_ARGUMENT,
                 {other.string(), "pose correctives"});
  EXPECT_EQ(out, reinterpret_cast<haha_avatar*>(0x1));  // untouched on failure
  // A model file that is missing / not an npz.
  const fs::path missing = tmp_dir() / "no_such_model.npz";
  expect_failure(haha_avatar_load(fx().lossy_path.c_str(), missing.c_str(), &out), HAHA_ERROR_IO, {"cannot open"},
                 missing.string());
  const fs::path junk = tmp_dir() / "junk_model.npz";
  write_bytes(junk, std::vector<uint8_t>(100, 0x5a));
  expect_failure(haha_avatar_load(fx().lossy_path.c_str(), junk.c_str(), &out), HAHA_ERROR_FORMAT, {}, junk.string());
}

TEST(RuntimeCApi, BadFilesFailWithTheFileNamed) {
  haha_avatar* out = nullptr;
  const std::string missing = (tmp_dir() / "does_not_exist.glb").string();
  expect_failure(haha_avatar_load(missing.c_str(), nullptr, &out), HAHA_ERROR_IO, {"cannot open", "No such file"}, missing);
  EXPECT_EQ(out, nullptr);
  expect_failure(haha_avatar_load(tmp_dir().c_str(), nullptr, &out), HAHA_ERROR_IO, {"is a directory"}, tmp_dir().string());

  const std::vector<uint8_t>& good = fx().lossy_no_correctives;
  // Truncated: in the header, the JSON, the BIN chunk, one byte short.
  for (size_t n : {size_t(0), size_t(7), size_t(30), good.size() / 2, good.size() - 1}) {
    const fs::path p = tmp_dir() / ("truncated_" + std::to_string(n) + ".glb");
    write_bytes(p, std::vector<uint8_t>(good.begin(), good.begin() + long(n)));
    expect_failure(haha_avatar_load(p.c_str(), nullptr, &out), HAHA_ERROR_FORMAT, {}, p.string());
    expect_failure(haha_avatar_load_memory(good.data(), n, "cut.glb", nullptr, &out), HAHA_ERROR_FORMAT, {}, "cut.glb");
  }
  // Garbage.
  std::vector<uint8_t> junk(5000);
  std::mt19937 rng(3);
  for (auto& b : junk) b = uint8_t(rng());
  const fs::path jp = tmp_dir() / "garbage.glb";
  write_bytes(jp, junk);
  expect_failure(haha_avatar_load(jp.c_str(), nullptr, &out), HAHA_ERROR_FORMAT, {}, jp.string());
  expect_failure(haha_avatar_load_memory(junk.data(), junk.size(), nullptr, nullptr, &out), HAHA_ERROR_FORMAT, {},
                 "<memory>");
  // A valid file with one flipped byte inside the Gaussian stream: the checksum catches it.
  const glb::Glb g = glb::parse_glb(good.data(), good.size(), "fixture");
  const auto& bv = g.json["bufferViews"][g.json["extensions"]["HAHA_gaussian_avatar"]["gaussians"]["bufferView"].get<int>()];
  const size_t bin_start = 12 + 8 + g.json_chunk_bytes + 8;  // glb header, JSON chunk, BIN chunk header
  std::vector<uint8_t> flipped = good;
  flipped[bin_start + bv["byteOffset"].get<size_t>() + bv["byteLength"].get<size_t>() / 2] ^= 0x10;
  const fs::path fp = tmp_dir() / "flipped.glb";
  write_bytes(fp, flipped);
  expect_failure(haha_avatar_load(fp.c_str(), nullptr, &out), HAHA_ERROR_FORMAT, {"gaussians: checksum mismatch"},
                 fp.string());
  EXPECT_EQ(out, nullptr);
  // NULL arguments.
  expect_failure(haha_avatar_load(nullptr, nullptr, &out), HAHA_ERROR_ARGUMENT, {"haha_avatar_load", "path is NULL"});
  expect_failure(haha_avatar_load(fp.c_str(), nullptr, nullptr), HAHA_ERROR_ARGUMENT, {"out_avatar is NULL"});
  expect_failure(haha_avatar_load_memory(nullptr, 10, nullptr, nullptr, &out), HAHA_ERROR_ARGUMENT, {"data is NULL"});
  haha_avatar_free(nullptr);  // no-op
  haha_posed_free(nullptr);
  haha_motion_free(nullptr);
}

// ---- repose and read-back ------------------------------------------------------------------

TEST(RuntimeCApi, ReposeMatchesTheCppRuntime) {
  AvatarHandle a;
  a.p = load_ok(fx().lossless_path);
  PosedHandle p;
  ASSERT_EQ(haha_posed_create(a.p, &p.p), HAHA_OK);
  const AvatarLoader ref = cpp_runtime(fx().lossless);
  const size_t V = size_t(ref.num_verts()), N = size_t(ref.num_gaussians());

  // Rest pose (NULL pose and translation) is the loader's rest pose: the baked mesh.
  ASSERT_EQ(haha_repose(p.p, nullptr, nullptr, nullptr, 0, nullptr, 0), HAHA_OK) << haha_last_error();
  std::vector<float> verts(3 * V);
  ASSERT_EQ(haha_posed_vertices(p.p, verts.data(), verts.size()), HAHA_OK);
  PosedAvatar rest;
  ref.repose(SmplxParams{}, rest);
  EXPECT_EQ(verts, rest.verts);
  const std::vector<float> baked = baked_rest_vertices(fx().avatar);
  for (size_t i = 0; i < baked.size(); ++i) ASSERT_NEAR(verts[i], baked[i], 2e-6f) << i;

  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const std::array<float, 165> pose = random_pose(seed, 0.4f);
    const float transl[3] = {0.1f, -0.2f, 0.3f};
    ASSERT_EQ(haha_repose(p.p, pose.data(), transl, nullptr, 0, nullptr, 0), HAHA_OK) << haha_last_error();
    SmplxParams sp;
    std::copy(pose.begin(), pose.end(), sp.pose.begin());
    sp.transl = {transl[0], transl[1], transl[2]};
    PosedAvatar want;
    ref.repose(sp, want);
    ASSERT_EQ(haha_posed_vertices(p.p, verts.data(), verts.size()), HAHA_OK);
    EXPECT_EQ(verts, want.verts);
    std::vector<float> joints(3 * 55);
    ASSERT_EQ(haha_posed_joints(p.p, joints.data(), joints.size()), HAHA_OK);
    EXPECT_EQ(joints, want.joints);
    std::vector<float> means(3 * N), rot(4 * N), scales(3 * N), colors(3 * N), opacity(N);
    const haha_gaussian_arrays g{N, means.data(), rot.data(), scales.data(), colors.data(), opacity.data()};
    ASSERT_EQ(haha_posed_gaussians(p.p, &g), HAHA_OK);
    EXPECT_EQ(means, want.means);
    EXPECT_EQ(rot, want.quats);
    EXPECT_EQ(scales, want.scales);
    EXPECT_EQ(colors, std::vector<float>(want.colors, want.colors + 3 * N));
    EXPECT_EQ(opacity, std::vector<float>(want.opacities, want.opacities + N));
  }

  // NULL arrays are skipped; a capacity below N is refused and nothing is written.
  std::vector<float> means(3 * N, -7.0f);
  haha_gaussian_arrays only_means{N, means.data(), nullptr, nullptr, nullptr, nullptr};
  ASSERT_EQ(haha_posed_gaussians(p.p, &only_means), HAHA_OK);
  std::fill(means.begin(), means.end(), -7.0f);
  only_means.capacity = N - 1;
  expect_failure(haha_posed_gaussians(p.p, &only_means), HAHA_ERROR_ARGUMENT,
                 {"haha_posed_gaussians", "capacity " + std::to_string(N - 1), std::to_string(N)});
  for (float x : means) ASSERT_EQ(x, -7.0f);
  expect_failure(haha_posed_vertices(p.p, verts.data(), verts.size() - 1), HAHA_ERROR_ARGUMENT,
                 {"haha_posed_vertices", "capacity"});
  expect_failure(haha_posed_normals(p.p, verts.data(), verts.size() - 1), HAHA_ERROR_ARGUMENT, {"haha_posed_normals", "capacity"});
  expect_failure(haha_posed_joints(p.p, verts.data(), 3 * 55 - 1), HAHA_ERROR_ARGUMENT, {"haha_posed_joints", "capacity"});
  expect_failure(haha_posed_gaussians(p.p, nullptr), HAHA_ERROR_ARGUMENT, {"out is NULL"});
}

TEST(RuntimeCApi, ReposeRefusesWhatItCannotHonour) {
  AvatarHandle a;
  a.p = load_ok(fx().lossless_path);
  PosedHandle p;
  ASSERT_EQ(haha_posed_create(a.p, &p.p), HAHA_OK);
  // Before the first repose there is nothing to read or render.
  std::vector<float> buf(100000);
  expect_failure(haha_posed_vertices(p.p, buf.data(), buf.size()), HAHA_ERROR_STATE, {"haha_posed_vertices", "haha_repose"});
  const haha_camera cam = front_camera(16, 16);
  expect_failure(haha_render(p.p, &cam, nullptr, 0, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_STATE,
                 {"haha_render"});
  // Shape overrides: the file's shape is baked.
  const float betas[2] = {1, 2};
  expect_failure(haha_repose(p.p, nullptr, nullptr, betas, 2, nullptr, 0), HAHA_ERROR_ARGUMENT, {"betas", "baked"});
  expect_failure(haha_repose(p.p, nullptr, nullptr, nullptr, 0, betas, 2), HAHA_ERROR_ARGUMENT, {"expression", "baked"});
  expect_failure(haha_repose(p.p, nullptr, nullptr, nullptr, 3, nullptr, 0), HAHA_ERROR_ARGUMENT, {"betas"});
  // Non-finite values.
  std::array<float, 165> pose{};
  pose[40] = NAN;
  expect_failure(haha_repose(p.p, pose.data(), nullptr, nullptr, 0, nullptr, 0), HAHA_ERROR_ARGUMENT, {"pose[40]", "not finite"});
  const float t[3] = {0, INFINITY, 0};
  expect_failure(haha_repose(p.p, nullptr, t, nullptr, 0, nullptr, 0), HAHA_ERROR_ARGUMENT, {"translation[1]"});
  expect_failure(haha_posed_vertices(p.p, buf.data(), buf.size()), HAHA_ERROR_STATE, {});  // still never posed
  expect_failure(haha_repose(nullptr, nullptr, nullptr, nullptr, 0, nullptr, 0), HAHA_ERROR_ARGUMENT, {"posed is NULL"});
  expect_failure(haha_posed_create(nullptr, &p.p), HAHA_ERROR_ARGUMENT, {"avatar is NULL"});
}

TEST(RuntimeCApi, NormalsAreUnitAndFollowTheBody) {
  AvatarHandle a;
  a.p = load_ok(fx().lossless_path);
  PosedHandle p;
  ASSERT_EQ(haha_posed_create(a.p, &p.p), HAHA_OK);
  const Avatar& av = fx().avatar;
  const size_t V = size_t(av.body.num_verts);
  std::vector<float> v0(3 * V), n0(3 * V), n1(3 * V);
  ASSERT_EQ(haha_repose(p.p, nullptr, nullptr, nullptr, 0, nullptr, 0), HAHA_OK);
  ASSERT_EQ(haha_posed_vertices(p.p, v0.data(), v0.size()), HAHA_OK);
  ASSERT_EQ(haha_posed_normals(p.p, n0.data(), n0.size()), HAHA_OK);
  // Unit length; each face's own normal agrees with its corners' vertex normals.
  for (size_t i = 0; i < V; ++i) ASSERT_NEAR(std::hypot(n0[3 * i], n0[3 * i + 1], n0[3 * i + 2]), 1.0, 1e-5) << i;
  int agree = 0, faces = 0;
  for (size_t t = 0; t < av.body.faces.size(); t += 3) {
    const float* A = &v0[size_t(av.body.faces[t]) * 3];
    const float* B = &v0[size_t(av.body.faces[t + 1]) * 3];
    const float* C = &v0[size_t(av.body.faces[t + 2]) * 3];
    const Vec3f fn = cross(Vec3f(B[0] - A[0], B[1] - A[1], B[2] - A[2]), Vec3f(C[0] - A[0], C[1] - A[1], C[2] - A[2]));
    if (norm(fn) < 1e-9f) continue;  // the degenerate face
    ++faces;
    bool ok = true;
    for (int k = 0; k < 3; ++k) {
      const float* n = &n0[size_t(av.body.faces[t + k]) * 3];
      ok = ok && fn.x * n[0] + fn.y * n[1] + fn.z * n[2] > 0;
    }
    agree += ok;
  }
  EXPECT_GT(agree, faces * 95 / 100);
  // A global rotation (90 degrees about Y) rotates the normals with the body.
  std::array<float, 165> pose{};
  pose[1] = float(M_PI / 2);
  ASSERT_EQ(haha_repose(p.p, pose.data(), nullptr, nullptr, 0, nullptr, 0), HAHA_OK);
  ASSERT_EQ(haha_posed_normals(p.p, n1.data(), n1.size()), HAHA_OK);
  for (size_t i = 0; i < V; ++i) {  // R_y(90): (x, y, z) -> (z, y, -x)
    ASSERT_NEAR(n1[3 * i], n0[3 * i + 2], 1e-4) << i;
    ASSERT_NEAR(n1[3 * i + 1], n0[3 * i + 1], 1e-4) << i;
    ASSERT_NEAR(n1[3 * i + 2], -n0[3 * i], 1e-4) << i;
  }
}

// ---- rendering -----------------------------------------------------------------------------

TEST(RuntimeCApi, RenderMatchesTheCppRuntimeInEveryPixelFormat) {
  AvatarHandle a;
  a.p = load_ok(fx().lossless_path);
  PosedHandle p;
  ASSERT_EQ(haha_posed_create(a.p, &p.p), HAHA_OK);
  const std::array<float, 165> pose = random_pose(9, 0.2f);
  ASSERT_EQ(haha_repose(p.p, pose.data(), nullptr, nullptr, 0, nullptr, 0), HAHA_OK);
  const int W = 48, H = 40;
  const size_t P = size_t(W) * H;
  const haha_camera cam = front_camera(W, H);
  const float bg[3] = {0.2f, 0.4f, 0.6f};

  const AvatarLoader ref = cpp_runtime(fx().lossless);
  SmplxParams sp;
  std::copy(pose.begin(), pose.end(), sp.pose.begin());
  PosedAvatar posed;
  ref.repose(sp, posed);
  AvatarRenderOptions opt;
  std::copy(bg, bg + 3, opt.background);
  std::vector<float> want;
  ref.render(to_cpp(cam), posed, want, opt);

  std::vector<float> rgb(P * 3), rgba(P * 4);
  ASSERT_EQ(haha_render(p.p, &cam, bg, 0, HAHA_PIXEL_RGB32F, rgb.data(), rgb.size() * 4), HAHA_OK) << haha_last_error();
  EXPECT_EQ(rgb, want);
  ASSERT_EQ(haha_render(p.p, &cam, bg, 0, HAHA_PIXEL_RGBA32F, rgba.data(), rgba.size() * 4), HAHA_OK);
  std::vector<uint8_t> rgb8(P * 3), rgba8(P * 4);
  ASSERT_EQ(haha_render(p.p, &cam, bg, 0, HAHA_PIXEL_RGB8, rgb8.data(), rgb8.size()), HAHA_OK);
  ASSERT_EQ(haha_render(p.p, &cam, bg, 0, HAHA_PIXEL_RGBA8, rgba8.data(), rgba8.size()), HAHA_OK);
  int covered = 0, differs = 0;
  for (size_t i = 0; i < P; ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(rgba[i * 4 + k], want[i * 3 + k]) << i;
      ASSERT_EQ(int(rgb8[i * 3 + k]), int(std::lround(std::clamp(want[i * 3 + k], 0.0f, 1.0f) * 255))) << i;
      ASSERT_EQ(rgba8[i * 4 + k], rgb8[i * 3 + k]) << i;
      differs += std::fabs(want[i * 3 + k] - bg[k]) > 0.02f;
    }
    const float alpha = rgba[i * 4 + 3];
    ASSERT_GE(alpha, 0.0f);
    ASSERT_LE(alpha, 1.0f + 1e-6f);
    ASSERT_EQ(int(rgba8[i * 4 + 3]), int(std::lround(std::clamp(alpha, 0.0f, 1.0f) * 255))) << i;
    covered += alpha > 0.5f;
    // Where nothing covers the pixel, it shows the background.
    if (alpha == 0.0f) {  // uncovered: the background (rare here: the test Gaussians are large)
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(rgba[i * 4 + k], bg[k], 1e-6f) << i;
    }
  }
  EXPECT_GT(covered, int(P / 20)) << "the body should cover part of the image";
  EXPECT_LT(covered, int(P));
  EXPECT_GT(differs, int(P / 20));

  // Layers: nothing drawn shows the background; Gaussians only matches the C++ render.
  ASSERT_EQ(haha_render(p.p, &cam, bg, HAHA_RENDER_NO_MESH | HAHA_RENDER_NO_GAUSSIANS, HAHA_PIXEL_RGBA32F, rgba.data(),
                        rgba.size() * 4),
            HAHA_OK);
  for (size_t i = 0; i < P; ++i) {
    ASSERT_EQ(rgba[i * 4 + 3], 0.0f);
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(rgba[i * 4 + k], bg[k], 1e-6f);
  }
  opt.draw_mesh = false;
  ref.render(to_cpp(cam), posed, want, opt);
  ASSERT_EQ(haha_render(p.p, &cam, bg, HAHA_RENDER_NO_MESH, HAHA_PIXEL_RGB32F, rgb.data(), rgb.size() * 4), HAHA_OK);
  EXPECT_EQ(rgb, want);
  // Mesh only: alpha is the mesh mask, 0 beside the body, where a NULL background is black.
  opt.draw_mesh = true;
  opt.draw_gaussians = false;
  ref.render(to_cpp(cam), posed, want, opt);
  ASSERT_EQ(haha_render(p.p, &cam, bg, HAHA_RENDER_NO_GAUSSIANS, HAHA_PIXEL_RGB32F, rgb.data(), rgb.size() * 4), HAHA_OK);
  EXPECT_EQ(rgb, want);
  ASSERT_EQ(haha_render(p.p, &cam, nullptr, HAHA_RENDER_NO_GAUSSIANS, HAHA_PIXEL_RGBA8, rgba8.data(), rgba8.size()),
            HAHA_OK);
  int empty = 0, body = 0;
  for (size_t i = 0; i < P; ++i) {
    if (rgba8[i * 4 + 3] == 0) {
      ++empty;
      for (int k = 0; k < 3; ++k) ASSERT_EQ(rgba8[i * 4 + k], 0) << i;
    } else if (rgba8[i * 4 + 3] == 255) {
      ++body;
    }
  }
  EXPECT_GT(empty, int(P / 2));
  EXPECT_GT(body, int(P / 20));
}

TEST(RuntimeCApi, RenderRefusesBadBuffersAndCameras) {
  AvatarHandle a;
  a.p = load_ok(fx().lossless_path);
  PosedHandle p;
  ASSERT_EQ(haha_posed_create(a.p, &p.p), HAHA_OK);
  ASSERT_EQ(haha_repose(p.p, nullptr, nullptr, nullptr, 0, nullptr, 0), HAHA_OK);
  const haha_camera cam = front_camera(20, 10);
  std::vector<float> buf(20 * 10 * 4 + 1, -3.0f);
  auto untouched = [&] {
    for (float x : buf) ASSERT_EQ(x, -3.0f);
  };
  expect_failure(haha_render(p.p, &cam, nullptr, 0, HAHA_PIXEL_RGB8, buf.data(), 20 * 10 * 3 - 1), HAHA_ERROR_ARGUMENT,
                 {"haha_render", "capacity " + std::to_string(599), "600"});
  expect_failure(haha_render(p.p, &cam, nullptr, 0, HAHA_PIXEL_RGBA32F, buf.data(), 20 * 10 * 16 - 1),
                 HAHA_ERROR_ARGUMENT, {"capacity", "3200"});
  untouched();
  expect_failure(haha_render(p.p, &cam, nullptr, 0, HAHA_PIXEL_RGB32F,
                             reinterpret_cast<char*>(buf.data()) + 1, 20 * 10 * 12),
                 HAHA_ERROR_ARGUMENT, {"aligned"});
  expect_failure(haha_render(p.p, &cam, nullptr, 0, haha_pixel_format(17), buf.data(), buf.size() * 4),
                 HAHA_ERROR_ARGUMENT, {"pixel format 17"});
  expect_failure(haha_render(p.p, &cam, nullptr, 8u, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_ARGUMENT,
                 {"flags 8"});
  expect_failure(haha_render(p.p, nullptr, nullptr, 0, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_ARGUMENT,
                 {"camera is NULL"});
  expect_failure(haha_render(p.p, &cam, nullptr, 0, HAHA_PIXEL_RGB8, nullptr, 1000), HAHA_ERROR_ARGUMENT, {"pixels is NULL"});
  haha_camera bad = cam;
  bad.width = 0;
  expect_failure(haha_render(p.p, &bad, nullptr, 0, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_ARGUMENT,
                 {"camera size 0x10"});
  bad = cam;
  bad.fx = -1;
  expect_failure(haha_render(p.p, &bad, nullptr, 0, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_ARGUMENT,
                 {"intrinsics"});
  bad = cam;
  bad.rotation[4] = NAN;
  expect_failure(haha_render(p.p, &bad, nullptr, 0, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_ARGUMENT,
                 {"camera rotation[4]"});
  bad = cam;
  bad.near_plane = 5, bad.far_plane = 1;
  expect_failure(haha_render(p.p, &bad, nullptr, 0, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_ARGUMENT,
                 {"far_plane"});
  const float nan_bg[3] = {0, NAN, 0};
  expect_failure(haha_render(p.p, &cam, nan_bg, 0, HAHA_PIXEL_RGB8, buf.data(), buf.size() * 4), HAHA_ERROR_ARGUMENT,
                 {"background[1]"});
  untouched();
}

// ---- threads ---------------------------------------------------------------------------------

TEST(RuntimeCApi, PoseStatesOfOneAvatarRunInParallelAndErrorsArePerThread) {
  AvatarHandle a;
  a.p = load_ok(fx().lossless_path);
  const haha_camera cam = front_camera(32, 32);
  // Serial reference for 4 poses.
  auto frame = [&](haha_posed* p, uint32_t seed, std::vector<float>& verts, std::vector<float>& img) {
    const std::array<float, 165> pose = random_pose(seed, 0.3f);
    ASSERT_EQ(haha_repose(p, pose.data(), nullptr, nullptr, 0, nullptr, 0), HAHA_OK) << haha_last_error();
    verts.resize(size_t(fx().avatar.body.num_verts) * 3);
    ASSERT_EQ(haha_posed_vertices(p, verts.data(), verts.size()), HAHA_OK);
    img.resize(32 * 32 * 3);
    ASSERT_EQ(haha_render(p, &cam, nullptr, 0, HAHA_PIXEL_RGB32F, img.data(), img.size() * 4), HAHA_OK);
  };
  std::vector<std::vector<float>> want_v(4), want_i(4), got_v(4), got_i(4);
  {
    PosedHandle p;
    ASSERT_EQ(haha_posed_create(a.p, &p.p), HAHA_OK);
    for (uint32_t s = 0; s < 4; ++s) frame(p.p, s + 1, want_v[s], want_i[s]);
  }
  std::vector<std::thread> threads;
  std::vector<std::string> errors(4);
  for (uint32_t s = 0; s < 4; ++s) {
    threads.emplace_back([&, s] {
      PosedHandle p;
      if (haha_posed_create(a.p, &p.p) != HAHA_OK) return;
      for (int rep = 0; rep < 3; ++rep) frame(p.p, s + 1, got_v[s], got_i[s]);
      // An error in this thread is this thread's alone.
      if (s == 0) (void)haha_set_num_threads(-1);
      errors[s] = haha_last_error();
    });
  }
  for (auto& t : threads) t.join();
  for (uint32_t s = 0; s < 4; ++s) {
    EXPECT_EQ(got_v[s], want_v[s]) << s;
    EXPECT_EQ(got_i[s], want_i[s]) << s;
  }
  EXPECT_NE(errors[0].find("haha_set_num_threads"), std::string::npos);
  for (uint32_t s = 1; s < 4; ++s) EXPECT_EQ(errors[s], "") << s;
}

// ---- motions and PNG -------------------------------------------------------------------------

fs::path write_motion(const std::string& name, int T, bool with_trans = true) {
  std::vector<float> poses(size_t(T) * 165), trans(size_t(T) * 3);
  for (size_t i = 0; i < poses.size(); ++i) poses[i] = 0.001f * float(i % 997);
  for (size_t i = 0; i < trans.size(); ++i) trans[i] = 0.01f * float(i);
  Npz z;
  z.set("poses", NpyArray::from(poses, {T, 165}));
  if (with_trans) z.set("trans", NpyArray::from(trans, {T, 3}));
  z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{60.0}, {}));
  const fs::path p = tmp_dir() / name;
  z.write(p.string());
  return p;
}

TEST(RuntimeCApi, MotionsLoadFrameByFrame) {
  const fs::path path = write_motion("motion.npz", 4);
  haha_motion* m = nullptr;
  ASSERT_EQ(haha_motion_load(path.c_str(), &m), HAHA_OK) << haha_last_error();
  int32_t frames = 0;
  double fps = 0;
  ASSERT_EQ(haha_motion_info(m, &frames, &fps), HAHA_OK);
  EXPECT_EQ(frames, 4);
  EXPECT_EQ(fps, 60.0);
  float pose[165], transl[3];
  ASSERT_EQ(haha_motion_frame(m, 2, pose, transl), HAHA_OK);
  for (int i = 0; i < 165; ++i) ASSERT_EQ(pose[i], 0.001f * float((2 * 165 + i) % 997)) << i;
  for (int i = 0; i < 3; ++i) EXPECT_EQ(transl[i], 0.01f * float(6 + i));
  ASSERT_EQ(haha_motion_frame(m, 3, nullptr, transl), HAHA_OK);
  expect_failure(haha_motion_frame(m, 4, pose, transl), HAHA_ERROR_ARGUMENT, {"frame 4", "0..3"});
  expect_failure(haha_motion_frame(m, -1, pose, transl), HAHA_ERROR_ARGUMENT, {"frame -1"});
  expect_failure(haha_motion_info(nullptr, &frames, &fps), HAHA_ERROR_ARGUMENT, {"motion is NULL"});
  haha_motion_free(m);

  haha_motion* out = nullptr;
  const std::string missing = (tmp_dir() / "no_motion.npz").string();
  expect_failure(haha_motion_load(missing.c_str(), &out), HAHA_ERROR_IO, {"cannot open"}, missing);
  const fs::path junk = tmp_dir() / "junk_motion.npz";
  write_bytes(junk, std::vector<uint8_t>(64, 0x33));
  expect_failure(haha_motion_load(junk.c_str(), &out), HAHA_ERROR_FORMAT, {}, junk.string());
  const fs::path no_trans = write_motion("no_trans.npz", 2, false);
  expect_failure(haha_motion_load(no_trans.c_str(), &out), HAHA_ERROR_FORMAT, {"trans"}, no_trans.string());
  EXPECT_EQ(out, nullptr);
  expect_failure(haha_motion_load(nullptr, &out), HAHA_ERROR_ARGUMENT, {"path is NULL"});
}

TEST(RuntimeCApi, MotionsForAnAvatarAreTurnedUpright) {
  // The same file through haha_motion_load_for_avatar and through the C++ reader turned
  // about the avatar's rest pelvis (io/motion.h): identical frames; plain haha_motion_load
  // keeps the stored (Z-up) numbers.
  const fs::path path = write_motion("zup.npz", 3);
  AvatarHandle a;
  a.p = load_ok(fx().lossless_path);
  haha_motion* m = nullptr;
  ASSERT_EQ(haha_motion_load_for_avatar(path.c_str(), a.p, &m), HAHA_OK) << haha_last_error();
  const AvatarLoader ref = cpp_runtime(fx().lossless);
  PosedAvatar rest;
  ref.repose(SmplxParams{}, rest);
  Motion want = read_motion(path.string());
  motion_to_y_up(want, {rest.joints[0], rest.joints[1], rest.joints[2]});
  const Motion stored = read_motion(path.string());
  float pose[165], transl[3];
  for (int f = 0; f < 3; ++f) {
    ASSERT_EQ(haha_motion_frame(m, f, pose, transl), HAHA_OK);
    for (int i = 0; i < 165; ++i) EXPECT_EQ(pose[i], want.frames[size_t(f)].pose[size_t(i)]) << i;
    for (int i = 0; i < 3; ++i) EXPECT_EQ(transl[i], want.frames[size_t(f)].transl[size_t(i)]) << i;
    EXPECT_NE(transl[1], stored.frames[size_t(f)].transl[1]);
  }
  haha_motion_free(m);
  haha_motion* out = nullptr;
  expect_failure(haha_motion_load_for_avatar(path.c_str(), nullptr, &out), HAHA_ERROR_ARGUMENT, {"avatar is NULL"});
}

TEST(RuntimeCApi, AnimationsListAndSampleLikeTheCppReader) {
  Motion m;
  m.fps = 24;
  m.up = {0, 1, 0};
  for (int k = 0; k < 12; ++k) {
    SmplxParams p;
    p.pose[1] = 0.3f * float(k);
    p.pose[3 * 16 + 2] = -0.1f * float(k);
    p.transl = {0.02f * float(k), 0.0f, 0.01f};
    m.frames.push_back(p);
  }
  PackOptions o;
  o.animations = {{"turn", m}};
  const std::vector<uint8_t> bytes = pack_avatar(fx().avatar, o);
  const fs::path path = tmp_dir() / "animated.glb";
  write_bytes(path, bytes);
  AvatarHandle a, plain;
  a.p = load_ok(path);
  plain.p = load_ok(fx().lossy_path);
  int32_t count = -1, frames = 0;
  ASSERT_EQ(haha_avatar_animation_count(plain.p, &count), HAHA_OK);
  EXPECT_EQ(count, 0);
  ASSERT_EQ(haha_avatar_animation_count(a.p, &count), HAHA_OK);
  ASSERT_EQ(count, 1);
  char name[16];
  double duration = 0, fps = 0;
  ASSERT_EQ(haha_avatar_animation_info(a.p, 0, name, sizeof name, &duration, &frames, &fps), HAHA_OK) << haha_last_error();
  EXPECT_STREQ(name, "turn");
  EXPECT_EQ(frames, 12);
  EXPECT_NEAR(duration, 11 / 24.0, 1e-6);
  EXPECT_NEAR(fps, 24.0, 1e-4);
  const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "mem.glb");
  float pose[165], transl[3];
  for (double t : {-1.0, 0.0, 0.1, 0.25, 11 / 24.0, 5.0}) {
    ASSERT_EQ(haha_avatar_sample_animation(a.p, 0, t, pose, transl), HAHA_OK) << haha_last_error();
    const SmplxParams want = sample_animation(u.animations[0], t);
    for (int i = 0; i < 165; ++i) ASSERT_EQ(pose[i], want.pose[size_t(i)]) << t << " " << i;
    for (int i = 0; i < 3; ++i) ASSERT_EQ(transl[i], want.transl[size_t(i)]) << t << " " << i;
  }
  EXPECT_NEAR(transl[0], 0.22f, 1e-6);  // held at the last key after the end
  expect_failure(haha_avatar_animation_info(a.p, 0, name, 4, nullptr, nullptr, nullptr), HAHA_ERROR_ARGUMENT, {"name", "capacity 4"});
  expect_failure(haha_avatar_sample_animation(a.p, 1, 0.0, pose, transl), HAHA_ERROR_ARGUMENT, {"animation 1", "0..0"});
  expect_failure(haha_avatar_sample_animation(plain.p, 0, 0.0, pose, transl), HAHA_ERROR_ARGUMENT, {"animation 0"});
  expect_failure(haha_avatar_sample_animation(a.p, 0, NAN, pose, transl), HAHA_ERROR_ARGUMENT, {"not finite"});
  expect_failure(haha_avatar_animation_count(nullptr, &count), HAHA_ERROR_ARGUMENT, {"avatar is NULL"});
}

TEST(RuntimeCApi, WritesPng) {
  const int W = 5, H = 3;
  std::vector<uint8_t> px(size_t(W) * H * 4);
  for (size_t i = 0; i < px.size(); ++i) px[i] = uint8_t(i * 13);
  for (int c = 1; c <= 4; ++c) {
    const fs::path p = tmp_dir() / ("img" + std::to_string(c) + ".png");
    ASSERT_EQ(haha_write_png(p.c_str(), W, H, c, px.data()), HAHA_OK) << haha_last_error();
    const Image img = read_image(p.string());
    ASSERT_EQ(img.width, W);
    ASSERT_EQ(img.height, H);
    ASSERT_EQ(img.channels, c);
    for (size_t i = 0; i < img.data.size(); ++i) ASSERT_EQ(int(std::lround(img.data[i] * 255)), int(px[i])) << c << " " << i;
  }
  const std::string in_missing_dir = (tmp_dir() / "no_such_dir" / "x.png").string();
  expect_failure(haha_write_png(in_missing_dir.c_str(), W, H, 3, px.data()), HAHA_ERROR_IO, {}, in_missing_dir);
  expect_failure(haha_write_png("x.jpg", W, H, 3, px.data()), HAHA_ERROR_ARGUMENT, {"x.jpg", ".png"});
  expect_failure(haha_write_png("x.png", W, H, 5, px.data()), HAHA_ERROR_ARGUMENT, {"channels"});
  expect_failure(haha_write_png("x.png", 0, H, 3, px.data()), HAHA_ERROR_ARGUMENT, {"size 0x3"});
  expect_failure(haha_write_png("x.png", W, H, 3, nullptr), HAHA_ERROR_ARGUMENT, {"pixels is NULL"});
}

}  // namespace
}  // namespace haha
