// `haha unpack` of an avatar with a garment gives a run directory that `haha pack` turns
// into the same avatar again: the garment primitive, where it starts, and the Gaussians on
// its faces (`haha info` shows the same garment line, and `haha info --json` the garment).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/glb.h"
#include "support/format_test_avatar.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

int haha_cli(const std::string& args, const fs::path& dir, std::string* out) { return test::run_haha(args, dir, out); }
std::string q(const fs::path& p) { return test::quoted(p); }

// The `garment` line of `haha info`.
std::string garment_line(const fs::path& glb, const fs::path& dir) {
  std::string out;
  EXPECT_EQ(haha_cli("info " + q(glb), dir, &out), 0) << out;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("  garment ", 0) == 0) return line;
  return "";
}

TEST(UnpackGarment, PackUnpackPackKeepsTheGarment) {
  if (!fs::exists(test::kHaha)) GTEST_SKIP() << "the haha executable is not built at " << test::kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-unpack-garment-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const Avatar a = test::with_test_garment(test::without_degenerate_face(test::make_test_avatar(120)), 7);
  for (const char* compression : {"draco", "none"}) {
    SCOPED_TRACE(compression);
    PackOptions opt;
    opt.mesh_compression = std::string(compression) == "draco" ? MeshCompression::draco : MeshCompression::none;
    write_avatar_glb(a, (dir / "first.glb").string(), opt);
    std::string out;
    fs::remove_all(dir / "unpacked");
    ASSERT_EQ(haha_cli("unpack " + q(dir / "first.glb") + " --out " + q(dir / "unpacked"), dir, &out), 0) << out;
    ASSERT_EQ(haha_cli("pack " + q(dir / "unpacked") + " --out " + q(dir / "again.glb") + " --mesh-compression " + compression, dir, &out), 0) << out;
    const std::string first = garment_line(dir / "first.glb", dir);
    EXPECT_NE(first.find("carrying 7 Gaussians"), std::string::npos) << first;
    EXPECT_EQ(garment_line(dir / "again.glb", dir), first);
    const std::vector<uint8_t> bytes = test::slurp_bytes(dir / "again.glb");
    const glb::Glb g = glb::parse_glb(bytes.data(), bytes.size(), "again.glb");
    EXPECT_EQ(g.json["meshes"][0]["primitives"].size(), 2u);
    const UnpackedAvatar u = unpack_avatar(bytes.data(), bytes.size(), "again.glb");
    EXPECT_EQ(u.avatar.body.num_verts, a.body.num_verts);
    EXPECT_EQ(u.avatar.body.num_faces, a.body.num_faces);
    EXPECT_EQ(u.avatar.gaussians.size(), a.gaussians.size());
    EXPECT_NEAR(u.avatar.body.garment_chart, a.body.garment_chart, 1e-6f);
    ASSERT_EQ(haha_cli("info --json " + q(dir / "again.glb"), dir, &out), 0) << out;
    const nlohmann::json j = nlohmann::json::parse(out);
    ASSERT_TRUE(j["garment"].is_object()) << out;
    EXPECT_EQ(j["garment"]["firstVertex"], a.body.garment_first_vert);
    EXPECT_EQ(j["garment"]["vertices"], a.body.num_verts - a.body.garment_first_vert);
    EXPECT_EQ(j["garment"]["faces"], a.body.num_faces - a.body.num_body_faces());
    EXPECT_EQ(j["garment"]["gaussians"], 7);
  }
  write_avatar_glb(test::without_degenerate_face(test::make_test_avatar(120)), (dir / "bare.glb").string(), PackOptions{});
  std::string out;
  ASSERT_EQ(haha_cli("info --json " + q(dir / "bare.glb"), dir, &out), 0) << out;
  EXPECT_TRUE(nlohmann::json::parse(out)["garment"].is_null()) << out;
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace haha
