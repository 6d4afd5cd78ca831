// 3DGS .ply reading/writing: round trips, the channel-major f_rest layout, ascii and
// big-endian files written by hand, every malformation named in the error, and the render
// of a loaded file equal to the rasterizer on the same Gaussians.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <unistd.h>

#include "core/error.h"
#include "io/ply_3dgs.h"
#include "render/sh.h"
#include "support/expect_error.h"

using namespace haha;
namespace fs = std::filesystem;

namespace {

struct TmpDir {
  fs::path path = fs::temp_directory_path() / ("haha_ply_test_" + std::to_string(::getpid()));
  TmpDir() { fs::create_directories(path); }
  ~TmpDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

fs::path tmpdir() {
  static const TmpDir d;
  return d.path;
}

std::string write_file(const std::string& name, const std::string& bytes) {
  const std::string p = (tmpdir() / name).string();
  std::ofstream f(p, std::ios::binary);
  f << bytes;
  return p;
}

GaussianPly random_ply(int n, int degree, bool normals, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-1, 1);
  GaussianPly g;
  g.sh_degree = degree;
  const int K = sh_coeff_count(degree);
  for (int i = 0; i < n; ++i) {
    g.means.insert(g.means.end(), {0.3f * U(rng), 0.3f * U(rng), 0.3f * U(rng)});
    if (normals) g.normals.insert(g.normals.end(), {U(rng), U(rng), U(rng)});
    for (int k = 0; k < 3 * K; ++k) g.sh.push_back(k < 3 ? U(rng) : 0.2f * U(rng));
    g.opacity_logit.push_back(2 * U(rng));
    g.log_scales.insert(g.log_scales.end(), {-3.5f + 0.5f * U(rng), -3.5f + 0.5f * U(rng), -4.0f + U(rng)});
    g.quats.insert(g.quats.end(), {1 + 0.3f * U(rng), U(rng), U(rng), U(rng)});
  }
  return g;
}

void expect_equal(const GaussianPly& a, const GaussianPly& b) {
  EXPECT_EQ(a.sh_degree, b.sh_degree);
  EXPECT_EQ(a.means, b.means);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.sh, b.sh);
  EXPECT_EQ(a.opacity_logit, b.opacity_logit);
  EXPECT_EQ(a.log_scales, b.log_scales);
  EXPECT_EQ(a.quats, b.quats);
}

// Expects read_ply_3dgs(path) to throw a one-line message naming the file and `what`.
void expect_error(const std::string& path, const std::string& what) {
  haha::test::expect_error_at(path, [&] { read_ply_3dgs(path); }, {what});
}

std::string header(const std::string& format, int n, const std::vector<std::string>& props,
                   const std::string& type = "float") {
  std::string h = "ply\nformat " + format + " 1.0\ncomment made by hand\nelement vertex " + std::to_string(n) + "\n";
  for (const auto& p : props) h += "property " + type + " " + p + "\n";
  return h + "end_header\n";
}

const std::vector<std::string> kDeg0 = {"x",       "y",       "z",       "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                                        "scale_0", "scale_1", "scale_2", "rot_0",  "rot_1",  "rot_2",  "rot_3"};

std::string binary_records(const std::vector<float>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
}

}  // namespace

TEST(Ply3dgs, RoundTripBinaryAndAscii) {
  for (int deg = 0; deg <= 3; ++deg)
    for (bool normals : {false, true})
      for (bool ascii : {false, true}) {
        SCOPED_TRACE(testing::Message() << "deg " << deg << " normals " << normals << " ascii " << ascii);
        const GaussianPly g = random_ply(17, deg, normals, 3 + deg);
        const std::string p = (tmpdir() / "rt.ply").string();
        write_ply_3dgs(p, g, ascii);
        GaussianPly r = read_ply_3dgs(p);
        if (!normals) {  // written as zeros
          for (float v : r.normals) EXPECT_EQ(v, 0.f);
          r.normals.clear();
        }
        expect_equal(g, r);
      }
}

TEST(Ply3dgs, FRestIsChannelMajor) {
  // Degree 1: f_rest_0..2 are coefficients 1..3 of red, 3..5 of green, 6..8 of blue.
  std::vector<std::string> props = kDeg0;
  for (int j = 0; j < 9; ++j) props.insert(props.begin() + 6 + j, "f_rest_" + std::to_string(j));
  std::vector<float> rec = {1, 2, 3, 0.1f, 0.2f, 0.3f, 10, 11, 12, 13, 14, 15, 16, 17, 18, 0.5f, -1, -2, -3, 1, 0, 0, 0};
  const std::string p = write_file("layout.ply", header("binary_little_endian", 1, props) + binary_records(rec));
  const GaussianPly g = read_ply_3dgs(p);
  ASSERT_EQ(g.sh_degree, 1);
  ASSERT_EQ(g.sh.size(), 12u);
  const float expect[12] = {0.1f, 0.2f, 0.3f, 10, 13, 16, 11, 14, 17, 12, 15, 18};  // (k, c)
  for (int i = 0; i < 12; ++i) EXPECT_EQ(g.sh[size_t(i)], expect[i]) << i;
  EXPECT_EQ(g.opacity_logit[0], 0.5f);
  EXPECT_EQ(g.log_scales, (std::vector<float>{-1, -2, -3}));
  EXPECT_EQ(g.quats, (std::vector<float>{1, 0, 0, 0}));
  EXPECT_TRUE(g.normals.empty());
}

TEST(Ply3dgs, ReadsHandWrittenAsciiWithExtraPropertiesAndDoubles) {
  std::vector<std::string> props = kDeg0;
  props.push_back("red");  // unknown properties are ignored
  std::string text = header("ascii", 2, props, "double");
  text += "1 2 3 0.5 0.25 0.125 -0.5 -4 -4.5 -5 1 0 0 0 nan\n";  // NaN in an ignored property is fine
  text += "  -1e-3\t0 4   0 0 0 3 -3 -3 -3 0.7 0.1 0.1 0.1 7\r\n";
  const GaussianPly g = read_ply_3dgs(write_file("ascii.ply", text));
  ASSERT_EQ(g.size(), 2);
  EXPECT_EQ(g.means, (std::vector<float>{1, 2, 3, -1e-3f, 0, 4}));
  EXPECT_EQ(g.sh[0], 0.5f);
  EXPECT_EQ(g.opacity_logit[1], 3.f);
  EXPECT_EQ(g.quats[4], 0.7f);
}

TEST(Ply3dgs, ReadsBigEndianAndMixedTypes) {
  std::string h = "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty double x\nproperty float y\n"
                  "property float z\nproperty uchar flags\n";
  for (size_t k = 3; k < kDeg0.size(); ++k) h += "property float " + kDeg0[k] + "\n";
  h += "end_header\n";
  auto be = [](auto v) {
    std::string s(reinterpret_cast<const char*>(&v), sizeof v);
    return std::string(s.rbegin(), s.rend());
  };
  std::string data = be(1.5) + be(2.5f) + be(3.5f) + std::string(1, '\x07');
  for (float v : {0.1f, 0.2f, 0.3f, 0.f, -2.f, -2.f, -2.f, 1.f, 0.f, 0.f, 0.f}) data += be(v);
  const GaussianPly g = read_ply_3dgs(write_file("be.ply", h + data + "trailing element data is ignored"));
  EXPECT_EQ(g.means, (std::vector<float>{1.5f, 2.5f, 3.5f}));
  EXPECT_EQ(g.sh, (std::vector<float>{0.1f, 0.2f, 0.3f}));
  EXPECT_EQ(g.quats, (std::vector<float>{1, 0, 0, 0}));
}

TEST(Ply3dgs, EmptySceneIsValid) {
  const GaussianPly g = read_ply_3dgs(write_file("empty.ply", header("binary_little_endian", 0, kDeg0)));
  EXPECT_EQ(g.size(), 0);
  const std::vector<float> img = render_ply_image(g, [] {
    Camera c;
    c.width = 4, c.height = 3, c.fx = c.fy = 4, c.cx = 2, c.cy = 1.5f;
    return c;
  }(), Vec3f(0.25f, 0.5f, 1.f));
  for (size_t i = 0; i < img.size(); ++i) EXPECT_EQ(img[i], (i % 3 == 0 ? 0.25f : i % 3 == 1 ? 0.5f : 1.f));
}

TEST(Ply3dgs, MalformedFilesNameFileAndProblem) {
  const std::vector<float> rec = {0, 0, 1, 0.1f, 0.2f, 0.3f, 0, -3, -3, -3, 1, 0, 0, 0};
  expect_error((tmpdir() / "does_not_exist.ply").string(), "cannot open");
  expect_error(write_file("notply.ply", "PLY?\n"), "not a PLY");
  expect_error(write_file("noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"), "end_header");
  expect_error(write_file("fmt.ply", "ply\nformat binary_middle_endian 1.0\nelement vertex 0\nend_header\n"),
               "unknown format");
  for (const std::string missing : {"opacity", "rot_3", "f_dc_1", "x", "scale_2"}) {
    std::vector<std::string> props;
    std::vector<float> r;
    for (size_t k = 0; k < kDeg0.size(); ++k)
      if (kDeg0[k] != missing) props.push_back(kDeg0[k]), r.push_back(rec[k]);
    expect_error(write_file("missing_" + missing + ".ply", header("binary_little_endian", 1, props) + binary_records(r)),
                 "missing vertex property '" + missing + "'");
  }
  // Truncated binary: two vertices announced, one and a half present.
  std::string two = header("binary_little_endian", 2, kDeg0) + binary_records(rec) + binary_records(rec);
  expect_error(write_file("trunc.ply", two.substr(0, two.size() - 7 * 4)), "truncated");
  // Truncated ascii.
  expect_error(write_file("trunc_ascii.ply", header("ascii", 2, kDeg0) + "0 0 1 0 0 0 0 -3 -3 -3 1 0 0 0\n0 0 1\n"),
               "truncated");
  // A hostile count over a small body is refused before anything is allocated for it
  // (2e9 records would need hundreds of GB): one line naming the file and the field.
  const std::string body_1k(1024, '\0');
  for (const char* fmt : {"binary_little_endian", "ascii"})
    expect_error(write_file("huge.ply", header(fmt, 2'000'000'000, kDeg0) + body_1k),
                 "element vertex: 2000000000 vertices cannot fit in the 1024 bytes");
  // NaN / Inf in a used property, binary and ascii.
  for (int k : {0, 6, 13}) {
    auto r = rec;
    r[size_t(k)] = k == 6 ? INFINITY : NAN;
    expect_error(write_file("nan.ply", header("binary_little_endian", 1, kDeg0) + binary_records(r)),
                 "vertex 0: property '" + kDeg0[size_t(k)] + "' is not finite");
  }
  expect_error(write_file("nan_ascii.ply", header("ascii", 1, kDeg0) + "0 0 1 0 0 0 nan -3 -3 -3 1 0 0 0\n"),
               "property 'opacity' is not finite");
  expect_error(write_file("word.ply", header("ascii", 1, kDeg0) + "0 0 one 0 0 0 0 -3 -3 -3 1 0 0 0\n"),
               "property 'z': not a number 'one'");
  // SH coefficient counts that are no degree, and gaps in the numbering.
  auto with_rest = [&](const std::vector<int>& idx) {
    std::vector<std::string> props = kDeg0;
    for (int j : idx) props.push_back("f_rest_" + std::to_string(j));
    return header("ascii", 0, props);
  };
  expect_error(write_file("rest5.ply", with_rest({0, 1, 2, 3, 4})), "expected 0, 9, 24 or 45");
  expect_error(write_file("restgap.ply", with_rest({0, 1, 2, 3, 4, 5, 6, 7, 9})), "f_rest_9");
  expect_error(write_file("list.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar int idx\n"
                                      "end_header\n"),
               "list property");
  expect_error(write_file("face_first.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty float a\n"
                                            "element vertex 1\nend_header\n"),
               "first element must be 'vertex'");
  expect_error(write_file("badtype.ply", header("ascii", 1, {"x"}, "float128")), "unknown property type");
  expect_error(write_file("count.ply", "ply\nformat ascii 1.0\nelement vertex -3\nend_header\n"), "bad vertex count");
}

TEST(Ply3dgs, WriterRejectsInconsistentArrays) {
  GaussianPly g = random_ply(3, 1, false, 1);
  g.quats.pop_back();
  EXPECT_THROW(write_ply_3dgs((tmpdir() / "bad.ply").string(), g), Error);
  EXPECT_FALSE(fs::exists(tmpdir() / "bad.ply"));
}

TEST(Ply3dgs, RenderOfLoadedFileEqualsRasterizerOnSameGaussians) {
  // Gaussians written to a .ply and read back render exactly like the rasterizer called
  // with the activations computed here (sigmoid, exp) and the same SH coefficients.
  const int n = 300;
  for (int deg : {0, 3}) {
    const GaussianPly g = random_ply(n, deg, true, 11);
    const std::string p = (tmpdir() / "scene.ply").string();
    write_ply_3dgs(p, g);
    const GaussianPly r = read_ply_3dgs(p);
    Camera cam;
    cam.width = 80, cam.height = 60, cam.fx = cam.fy = 90, cam.cx = 40, cam.cy = 30;
    cam.t = Vec3f(0, 0, 1.5f);
    const Vec3f bg(0.2f, 0.3f, 0.4f);
    const std::vector<float> img = render_ply_image(r, cam, bg);

    std::vector<float> opac(n), scales(3 * n);
    for (int i = 0; i < n; ++i) opac[size_t(i)] = 1 / (1 + std::exp(-g.opacity_logit[size_t(i)]));
    for (int i = 0; i < 3 * n; ++i) scales[size_t(i)] = std::exp(g.log_scales[size_t(i)]);
    GaussianInputs<float> in;
    in.count = n, in.means = g.means.data(), in.quats = g.quats.data(), in.scales = scales.data();
    in.opacities = opac.data(), in.sh = g.sh.data(), in.sh_degree = deg;
    GaussianRasterSettings<float> settings;
    settings.background_color = bg;
    std::vector<float> expect(img.size()), alpha(size_t(cam.width) * cam.height);
    GaussianRasterState<float> st;
    rasterize_gaussians(in, cam, settings, st, {nullptr, alpha.data(), nullptr, expect.data()});
    EXPECT_EQ(img, expect);
    int covered = 0;
    for (float a : alpha) covered += a > 0.1f;
    EXPECT_GT(covered, 1000) << "the scene must be visible";
  }
}
