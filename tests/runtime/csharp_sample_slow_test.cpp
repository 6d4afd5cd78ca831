// samples/csharp (the C# P/Invoke binding Haha.cs and the console Sample.cs), built with
// Debian's Mono compiler (mcs) and run with mono against the built libhaha_runtime.so
// (LD_LIBRARY_PATH), as samples/csharp/README.md says. Skipped, with the reason, where mcs
// or mono is missing (apt-get install --no-install-recommends mono-mcs mono-runtime).
//   - Sample.exe on a small avatar and a 3-frame motion: frame 2's posed vertices, normals,
//     joints and all five Gaussian arrays (plus faces, face UVs, texture) as the sample read
//     them through the binding are byte for byte what the C API gives here for that frame;
//     its render is what haha_render gives for the sample's camera, and its PNG frames decode
//     to the pixels of samples/c's (built with cc against the same library), frame by frame.
//   - tests/runtime/csharp/BindingChecks.cs: the binding's errors, capacities, handle
//     lifetimes, threads and float renders.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "format/avatar_pack.h"
#include "haha/haha_runtime.h"
#include "io/image.h"
#include "io/npy.h"
#include "support/runtime_sample_inputs.h"

namespace fs = std::filesystem;

namespace haha {
namespace {

using test::q;
using test::sh;

// Why the C# tests cannot run here, or "" when mcs and mono are on the PATH.
std::string missing_mono() {
  std::string out;
  for (const char* tool : {"mcs", "mono"})
    if (sh(std::string("command -v ") + tool, &out) != 0)
      return std::string(tool) + " is not installed (Debian: apt-get install --no-install-recommends mono-mcs mono-runtime)";
  return "";
}

using SampleTempDir = test::SampleTempDir;

// Compiles C# sources (paths relative to the source tree) into an .exe with mcs.
void build_cs(const std::vector<std::string>& sources, const fs::path& exe) {
  std::string cmd = "cd " + q(HAHA_SOURCE_DIR) + " && mcs -unsafe -warnaserror -out:" + q(exe);
  for (const std::string& s : sources) cmd += " " + s;
  std::string out;
  ASSERT_EQ(sh(cmd, &out), 0) << cmd << "\n" << out;
}

// Runs a Mono program with the built libhaha_runtime.so on the loader's path.
int run_mono(const fs::path& exe, const std::string& args, std::string* out) {
  const fs::path lib_dir = fs::path(HAHA_RUNTIME_SO).parent_path();
  return sh("LD_LIBRARY_PATH=" + q(lib_dir) + "${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH} mono " + q(exe) + " " + args, out);
}

std::vector<uint8_t> read_bytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// The file the C# sample dumped equals `expected` byte for byte (else: the first difference).
template <typename T>
void expect_dump(const fs::path& dir, const std::string& name, const std::vector<T>& expected) {
  const fs::path p = dir / ("dump_" + name + ".bin");
  ASSERT_TRUE(fs::exists(p)) << p;
  const std::vector<uint8_t> got = read_bytes(p);
  ASSERT_EQ(got.size(), expected.size() * sizeof(T)) << name;
  ASSERT_FALSE(expected.empty()) << name;
  if (std::memcmp(got.data(), expected.data(), got.size()) == 0) return;
  for (size_t i = 0; i < expected.size(); ++i) {
    T v;
    std::memcpy(&v, got.data() + i * sizeof(T), sizeof(T));
    if (std::memcmp(&v, &expected[i], sizeof(T)) != 0) {
      ADD_FAILURE() << name << "[" << i << "]: C# " << +v << ", C API " << +expected[i];
      return;
    }
  }
}

// A PNG's pixels as 8-bit values.
std::vector<uint8_t> png_pixels(const fs::path& p, int* w, int* h) {
  const Image img = read_image(p.string());
  *w = img.width;
  *h = img.height;
  std::vector<uint8_t> px(img.data.size());
  for (size_t i = 0; i < px.size(); ++i) px[i] = uint8_t(std::lround(img.data[i] * 255.0f));
  return px;
}

#define ASSERT_HAHA_OK(call) ASSERT_EQ((call), HAHA_OK) << #call << ": " << haha_last_error()

TEST(CSharpSample, BuildsWithMcsAndReadsBackWhatTheCApiGives) {
  const std::string why = missing_mono();
  if (!why.empty()) GTEST_SKIP() << why;
  SampleTempDir tmp("haha_csharp_sample");
  const fs::path glb = tmp.path / "avatar.glb", motion = tmp.path / "motion.npz";
  test::write_sample_inputs(glb, motion);
  const fs::path exe = tmp.path / "Sample.exe", frames = tmp.path / "frames_cs";
  build_cs({"samples/csharp/Haha.cs", "samples/csharp/Sample.cs"}, exe);
  if (HasFatalFailure()) return;

  std::string out;
  ASSERT_EQ(run_mono(exe, q(glb) + " " + q(motion) + " " + q(frames) + " --size 64 --dump-frame 2", &out), 0) << out;
  EXPECT_NE(out.find("haha runtime " + std::string(haha_version_string()) + " (C# binding"), std::string::npos) << out;
  EXPECT_NE(out.find("300 Gaussians"), std::string::npos) << out;
  EXPECT_NE(out.find("frame     2: repose"), std::string::npos) << out;
  EXPECT_NE(out.find("3 frames 64x64: mean repose"), std::string::npos) << out;
  std::printf("%s", out.c_str());  // the C# sample's timings in the test log

  // Frame 2 through the C API directly.
  haha_avatar* avatar = nullptr;
  haha_posed* posed = nullptr;
  haha_motion* mo = nullptr;
  ASSERT_HAHA_OK(haha_avatar_load(glb.c_str(), nullptr, &avatar));
  ASSERT_HAHA_OK(haha_posed_create(avatar, &posed));
  ASSERT_HAHA_OK(haha_motion_load_for_avatar(motion.c_str(), avatar, &mo));
  haha_avatar_info info;
  ASSERT_HAHA_OK(haha_avatar_get_info(avatar, &info));
  const size_t V = size_t(info.num_vertices), F = size_t(info.num_faces), N = size_t(info.num_gaussians);
  float pose[HAHA_NUM_POSE_VALUES], transl[3];
  ASSERT_HAHA_OK(haha_motion_frame(mo, 2, pose, transl));
  ASSERT_HAHA_OK(haha_repose(posed, pose, transl, nullptr, 0, nullptr, 0));
  std::vector<float> verts(3 * V), normals(3 * V), joints(3 * HAHA_NUM_JOINTS), means(3 * N), rots(4 * N), scales(3 * N),
      colors(3 * N), opac(N), uvs(6 * F);
  std::vector<uint32_t> faces(3 * F);
  std::vector<uint8_t> texture(3 * size_t(info.texture_width) * size_t(info.texture_height));
  ASSERT_HAHA_OK(haha_posed_vertices(posed, verts.data(), verts.size()));
  ASSERT_HAHA_OK(haha_posed_normals(posed, normals.data(), normals.size()));
  ASSERT_HAHA_OK(haha_posed_joints(posed, joints.data(), joints.size()));
  const haha_gaussian_arrays g{N, means.data(), rots.data(), scales.data(), colors.data(), opac.data()};
  ASSERT_HAHA_OK(haha_posed_gaussians(posed, &g));
  ASSERT_HAHA_OK(haha_avatar_faces(avatar, faces.data(), faces.size()));
  ASSERT_HAHA_OK(haha_avatar_face_uvs(avatar, uvs.data(), uvs.size()));
  ASSERT_HAHA_OK(haha_avatar_texture(avatar, texture.data(), texture.size()));
  expect_dump(frames, "vertices", verts);
  expect_dump(frames, "normals", normals);
  expect_dump(frames, "joints", joints);
  expect_dump(frames, "means", means);
  expect_dump(frames, "rotations", rots);
  expect_dump(frames, "scales", scales);
  expect_dump(frames, "colors", colors);
  expect_dump(frames, "opacities", opac);
  expect_dump(frames, "faces", faces);
  expect_dump(frames, "face_uvs", uvs);
  expect_dump(frames, "texture", texture);

  // The render: haha_render with the camera the sample used (dumped as 20 floats).
  const std::vector<uint8_t> cam_bytes = read_bytes(frames / "dump_camera.bin");
  ASSERT_EQ(cam_bytes.size(), 20 * sizeof(float));
  float c[20];
  std::memcpy(c, cam_bytes.data(), sizeof c);
  haha_camera cam{};
  cam.width = int32_t(c[0]);
  cam.height = int32_t(c[1]);
  ASSERT_EQ(cam.width, 64);
  ASSERT_EQ(cam.height, 64);
  cam.fx = c[2], cam.fy = c[3], cam.cx = c[4], cam.cy = c[5];
  std::memcpy(cam.rotation, c + 6, sizeof cam.rotation);
  std::memcpy(cam.translation, c + 15, sizeof cam.translation);
  cam.near_plane = c[18], cam.far_plane = c[19];
  const float white[3] = {1, 1, 1};
  std::vector<uint8_t> rgb(3 * 64 * 64);
  ASSERT_HAHA_OK(haha_render(posed, &cam, white, 0, HAHA_PIXEL_RGB8, rgb.data(), rgb.size()));
  expect_dump(frames, "render", rgb);
  int w = 0, h = 0;
  EXPECT_EQ(png_pixels(frames / "frame_00002.png", &w, &h), rgb) << "frame_00002.png is not the render";
  EXPECT_EQ(w, 64);
  EXPECT_EQ(h, 64);
  int body = 0;
  for (uint8_t v : rgb) body += v < 243;  // the background is white
  EXPECT_GT(body, 64 * 64 / 50) << "the frame shows no body";
  haha_posed_free(posed);
  haha_motion_free(mo);
  haha_avatar_free(avatar);

  // samples/c on the same inputs (built with cc against the same library): the same frames.
  const fs::path sample_c = tmp.path / "haha_sample_c", lib_dir = fs::path(HAHA_RUNTIME_SO).parent_path();
  const std::string build_c = "cc -std=c99 -O2 " + q(fs::path(HAHA_SOURCE_DIR) / "samples/c/haha_sample_c.c") + " -I" +
                              q(fs::path(HAHA_SOURCE_DIR) / "runtime/include") + " -L" + q(lib_dir) +
                              " -lhaha_runtime -Wl,-rpath," + q(lib_dir) + " -o " + q(sample_c);
  ASSERT_EQ(sh(build_c, &out), 0) << build_c << "\n" << out;
  ASSERT_EQ(sh(q(sample_c) + " " + q(glb) + " " + q(motion) + " " + q(tmp.path / "frames_c") + " 64", &out), 0) << out;
  for (int f = 0; f < 3; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.png", f);
    int wc = 0, hc = 0;
    EXPECT_EQ(png_pixels(frames / name, &w, &h), png_pixels(tmp.path / "frames_c" / name, &wc, &hc))
        << name << ": the C# and C samples differ";
  }
  EXPECT_FALSE(fs::exists(frames / "frame_00003.png"));

  // Bad input: the HahaException's line (status and the library's message), exit 1.
  EXPECT_EQ(run_mono(exe, q(motion) + " " + q(motion) + " " + q(tmp.path / "bad"), &out), 1 << 8) << out;
  EXPECT_NE(out.find("Sample: haha_avatar_load: HAHA_ERROR_FORMAT: " + motion.string() + ": "), std::string::npos) << out;
  EXPECT_EQ(out.find("Unhandled"), std::string::npos) << out;
}

TEST(CSharpSample, BindingChecks) {
  const std::string why = missing_mono();
  if (!why.empty()) GTEST_SKIP() << why;
  SampleTempDir tmp("haha_csharp_binding");
  const fs::path glb = tmp.path / "avatar.glb", motion = tmp.path / "motion.npz";
  test::write_sample_inputs(glb, motion);
  const fs::path exe = tmp.path / "BindingChecks.exe";
  build_cs({"samples/csharp/Haha.cs", "tests/runtime/csharp/BindingChecks.cs"}, exe);
  if (HasFatalFailure()) return;
  std::string out;
  EXPECT_EQ(run_mono(exe, q(glb) + " " + q(motion) + " " + q(tmp.path / "out"), &out), 0) << out;
  EXPECT_NE(out.find(" passed, 0 failed"), std::string::npos) << out;
  std::printf("%s", out.c_str());
}

}  // namespace
}  // namespace haha
