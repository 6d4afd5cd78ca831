// Body model .npz and SMPL-X parameter files: round trips, the dtype / layout variants of
// real files, and bad input (missing key, wrong shape, NaN) naming file and key.
#include <gtest/gtest.h>
#include <zip.h>

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "body/lbs.h"
#include "core/error.h"
#include "support/body_synthetic_model.h"
#include "io/body_model_io.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using test::SynthOptions;
using test::add_optional_keys;
using test::make_synthetic_model;

class IoBody : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("haha_io_body_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

BodyModel small_model(int num_shape = 10, int num_expr = 10) {
  SynthOptions o;
  o.verts_per_joint = 4;
  o.num_shape = num_shape;
  o.num_expr = num_expr;
  BodyModel b = make_synthetic_model(o);
  add_optional_keys(b);
  return b;
}

void expect_same(const BodyModel& a, const BodyModel& b) {
  EXPECT_EQ(a.num_verts, b.num_verts);
  EXPECT_EQ(a.num_faces, b.num_faces);
  EXPECT_EQ(a.num_shape, b.num_shape);
  EXPECT_EQ(a.num_expr, b.num_expr);
  EXPECT_EQ(a.v_template, b.v_template);
  EXPECT_EQ(a.faces, b.faces);
  EXPECT_EQ(a.j_regressor, b.j_regressor);
  EXPECT_EQ(a.parents, b.parents);
  EXPECT_EQ(a.weights, b.weights);
  EXPECT_EQ(a.shapedirs, b.shapedirs);
  EXPECT_EQ(a.posedirs, b.posedirs);
  EXPECT_EQ(a.hands_components_l, b.hands_components_l);
  EXPECT_EQ(a.hands_components_r, b.hands_components_r);
  EXPECT_EQ(a.hands_mean_l, b.hands_mean_l);
  EXPECT_EQ(a.hands_mean_r, b.hands_mean_r);
  EXPECT_EQ(a.lmk_faces_idx, b.lmk_faces_idx);
  EXPECT_EQ(a.lmk_bary_coords, b.lmk_bary_coords);
  EXPECT_EQ(a.vt, b.vt);
  EXPECT_EQ(a.ft, b.ft);
}

// Expects load_body_model to fail with a message naming the file and `key`.
void expect_load_error(const std::string& file, const std::string& key, const std::string& also = "") {
  try {
    load_body_model(file);
    FAIL() << "expected an error for " << key;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(file + ": " + key), std::string::npos) << msg;
    if (!also.empty()) {
      EXPECT_NE(msg.find(also), std::string::npos) << msg;
    }
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
  }
}

NpyArray u32_array(const std::vector<int32_t>& v, std::vector<int64_t> shape, uint32_t root_override = 0,
                   bool override_first = false) {
  NpyArray a;
  a.dtype = DType::u32;
  a.descr = "<u4";
  a.shape = std::move(shape);
  a.bytes.resize(v.size() * 4);
  for (size_t i = 0; i < v.size(); ++i) {
    uint32_t x = uint32_t(v[i]);
    if (override_first && i == 0) x = root_override;
    std::memcpy(a.bytes.data() + 4 * i, &x, 4);
  }
  return a;
}

std::vector<double> to_double(const std::vector<float>& v) { return {v.begin(), v.end()}; }

// Adds a member holding a pickled-object array ('|O'), as real SMPL-X files have.
void add_object_array(const std::string& file, const std::string& key) {
  std::string h = "{'descr': '|O', 'fortran_order': False, 'shape': (), }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string npy = std::string("\x93NUMPY\x01\x00", 8);
  npy += char(h.size() & 0xff);
  npy += char(h.size() >> 8);
  npy += h;
  npy += "\x80\x02}q\x00.";  // some pickle bytes
  int err = 0;
  zip_t* z = zip_open(file.c_str(), 0, &err);
  ASSERT_NE(z, nullptr);
  char* buf = static_cast<char*>(std::malloc(npy.size()));
  std::memcpy(buf, npy.data(), npy.size());
  zip_source_t* src = zip_source_buffer(z, buf, npy.size(), 1);
  ASSERT_GE(zip_file_add(z, (key + ".npy").c_str(), src, ZIP_FL_OVERWRITE), 0);
  ASSERT_EQ(zip_close(z), 0);
}

// ---- body model ----

TEST_F(IoBody, RoundTripKeepsEveryArray) {
  const BodyModel b = small_model();
  save_body_model(b, path("m.npz"));
  const BodyModel c = load_body_model(path("m.npz"));
  EXPECT_EQ(c.source, path("m.npz"));
  expect_same(b, c);
  // no temporary left behind
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(IoBody, FourHundredColumnLayout) {
  SynthOptions o;
  o.verts_per_joint = 3;
  o.num_shape = 300;
  o.num_expr = 100;
  const BodyModel b = make_synthetic_model(o);
  save_body_model(b, path("m.npz"));
  const BodyModel c = load_body_model(path("m.npz"));
  EXPECT_EQ(c.num_shape, 300);
  EXPECT_EQ(c.num_expr, 100);
  expect_same(b, c);
}

TEST_F(IoBody, SmallerColumnCountsArePaddedWithoutChangingTheBody) {
  const BodyModel b = small_model(4, 2);
  save_body_model(b, path("m.npz"));
  const BodyModel c = load_body_model(path("m.npz"));
  EXPECT_EQ(c.num_shape, 10);
  EXPECT_EQ(c.num_expr, 10);
  SmplxParams p;
  p.pose[5] = 0.4f;
  p.betas = {0.5f, -1.0f, 0.3f, 0.2f};
  p.expression = {1.0f, -0.5f};
  std::vector<float> v1(3 * b.num_verts), v2(3 * b.num_verts);
  Lbs<float>(b).forward(p, v1.data(), nullptr, nullptr);
  Lbs<float>(c).forward(p, v2.data(), nullptr, nullptr);
  EXPECT_EQ(v1, v2);
}

TEST_F(IoBody, AcceptsFloat64Uint32FacesAndRootParentAsMaxUint) {
  const BodyModel b = small_model();
  save_body_model(b, path("m.npz"));
  Npz z = Npz::read(path("m.npz"));
  const int64_t V = b.num_verts, F = b.num_faces;
  z.set("v_template", NpyArray::from(to_double(b.v_template), {V, 3}));
  z.set("J_regressor", NpyArray::from(to_double(b.j_regressor), {kNumJoints, V}));
  z.set("weights", NpyArray::from(to_double(b.weights), {V, kNumJoints}));
  z.set("shapedirs", NpyArray::from(to_double(b.shapedirs), {V, 3, 20}));
  z.set("posedirs", NpyArray::from(to_double(b.posedirs), {V, 3, kNumPoseFeatures}));
  z.set("f", u32_array(b.faces, {F, 3}));
  std::vector<int32_t> kt(2 * kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) kt[j] = b.parents[j], kt[kNumJoints + j] = j;
  z.set("kintree_table", u32_array(kt, {2, kNumJoints}, 0xFFFFFFFFu, true));
  std::vector<int64_t> ft64(b.ft.begin(), b.ft.end());
  z.set("ft", NpyArray::from(ft64, {F, 3}));
  z.write(path("f64.npz"));
  add_object_array(path("f64.npz"), "joint2num");  // skipped: not needed
  const BodyModel c = load_body_model(path("f64.npz"));
  expect_same(b, c);
}

TEST_F(IoBody, OptionalKeysMayBeAbsent) {
  SynthOptions o;
  o.verts_per_joint = 3;
  o.with_posedirs = false;
  const BodyModel b = make_synthetic_model(o);
  save_body_model(b, path("m.npz"));
  const BodyModel c = load_body_model(path("m.npz"));
  EXPECT_TRUE(c.posedirs.empty() && c.vt.empty() && c.hands_mean_l.empty() && c.lmk_faces_idx.empty());
  expect_same(b, c);
}

TEST_F(IoBody, BadInputNamesFileAndKey) {
  const BodyModel b = small_model();
  save_body_model(b, path("good.npz"));
  const int64_t V = b.num_verts, F = b.num_faces;
  int n = 0;
  // Rewrites good.npz with one change and expects the error to name the key.
  auto variant = [&](auto&& change, const std::string& key, const std::string& also = "") {
    Npz z = Npz::read(path("good.npz"));
    Npz out;
    for (const std::string& k : z.keys()) out.set(k, z.get(k));
    change(out);
    const std::string file = path("bad" + std::to_string(n++) + ".npz");
    out.write(file);
    expect_load_error(file, key, also);
  };
  auto drop = [&](const std::string& key) {
    Npz z = Npz::read(path("good.npz"));
    Npz out;
    for (const std::string& k : z.keys())
      if (k != key) out.set(k, z.get(k));
    const std::string file = path("bad" + std::to_string(n++) + ".npz");
    out.write(file);
    expect_load_error(file, key, "missing");
  };
  drop("v_template");
  drop("f");
  drop("weights");
  drop("J_regressor");
  drop("kintree_table");
  drop("shapedirs");
  drop("lmk_bary_coords");  // only together with lmk_faces_idx
  drop("ft");               // only together with vt

  variant([&](Npz& z) { z.set("J_regressor", NpyArray::from(std::vector<float>(size_t(54) * V), {54, V})); },
          "J_regressor", "wrong shape");
  variant([&](Npz& z) { z.set("weights", NpyArray::from(std::vector<float>(size_t(V - 1) * 55), {V - 1, 55})); },
          "weights", "wrong shape");
  variant([&](Npz& z) { z.set("posedirs", NpyArray::from(std::vector<float>(size_t(V) * 3 * 10), {V, 3, 10})); },
          "posedirs", "wrong shape");
  variant([&](Npz& z) { z.set("shapedirs", NpyArray::from(std::vector<float>(size_t(V) * 3 * 16), {V, 3, 16})); },
          "shapedirs", "16 columns");
  variant([&](Npz& z) { z.set("f", NpyArray::from(std::vector<int32_t>(size_t(F) * 3, int32_t(V)), {F, 3})); }, "f",
          "outside");
  variant([&](Npz& z) { z.set("f", NpyArray::from(std::vector<float>(size_t(F) * 3, 0.0f), {F, 3})); }, "f",
          "expected integers");
  variant(
      [&](Npz& z) {
        std::vector<float> v = b.v_template;
        v[7] = std::numeric_limits<float>::quiet_NaN();
        z.set("v_template", NpyArray::from(v, {V, 3}));
      },
      "v_template", "non-finite");
  variant(
      [&](Npz& z) {
        std::vector<double> v = to_double(b.shapedirs);
        v[3] = std::numeric_limits<double>::infinity();
        z.set("shapedirs", NpyArray::from(v, {V, 3, 20}));
      },
      "shapedirs", "non-finite");
  variant(
      [&](Npz& z) {
        std::vector<int32_t> kt(2 * kNumJoints);
        for (int j = 0; j < kNumJoints; ++j) kt[j] = j == 0 ? -1 : b.parents[j], kt[kNumJoints + j] = j;
        kt[10] = 30;
        z.set("kintree_table", NpyArray::from(kt, {2, kNumJoints}));
      },
      "kintree_table", "joint 10");
  variant([&](Npz& z) { z.set("hands_meanl", NpyArray::from(std::vector<float>(44), {44})); }, "hands_meanl",
          "wrong shape");
  variant([&](Npz& z) { z.set("lmk_faces_idx", NpyArray::from(std::vector<int32_t>(5, int32_t(F)), {5})); },
          "lmk_faces_idx", "outside");

  // A needed key stored as an object array.
  {
    Npz z = Npz::read(path("good.npz"));
    Npz out;
    for (const std::string& k : z.keys())
      if (k != "weights") out.set(k, z.get(k));
    out.write(path("obj.npz"));
    add_object_array(path("obj.npz"), "weights");
    expect_load_error(path("obj.npz"), "weights", "unsupported dtype");
  }
  // Not an archive at all.
  {
    std::FILE* f = std::fopen(path("junk.npz").c_str(), "wb");
    std::fputs("not a zip", f);
    std::fclose(f);
    try {
      load_body_model(path("junk.npz"));
      FAIL();
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path("junk.npz")), std::string::npos) << e.what();
    }
  }
}

// ---- SMPL-X parameters ----

std::vector<SmplxParams> random_frames(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<SmplxParams> f(n);
  for (auto& p : f) {
    for (auto& x : p.pose) x = u(rng);
    p.betas.resize(10);
    p.expression.resize(10);
    for (auto& x : p.betas) x = u(rng);
    for (auto& x : p.expression) x = u(rng);
    for (auto& x : p.transl) x = u(rng);
  }
  return f;
}

void expect_same(const SmplxParams& a, const SmplxParams& b) {
  EXPECT_EQ(a.pose, b.pose);
  EXPECT_EQ(a.betas, b.betas);
  EXPECT_EQ(a.expression, b.expression);
  EXPECT_EQ(a.transl, b.transl);
}

void expect_params_error(const std::string& file, const std::string& key, const std::string& also,
                         const BodyModel* model = nullptr, bool flat = true) {
  try {
    read_smplx_params(file, model, flat);
    FAIL() << "expected an error for " << key;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(file + (key.empty() ? "" : ": " + key)), std::string::npos) << msg;
    EXPECT_NE(msg.find(also), std::string::npos) << msg;
  }
}

TEST_F(IoBody, ParamsRoundTrip) {
  const auto frames = random_frames(3, 1);
  write_smplx_params(path("p.npz"), frames);
  const auto back = read_smplx_params(path("p.npz"));
  ASSERT_EQ(back.size(), 3u);
  for (int i = 0; i < 3; ++i) expect_same(frames[i], back[i]);
}

TEST_F(IoBody, ParamsOneFrameMissingArraysAndSharedBetas) {
  Npz z;
  std::vector<float> go = {0.1f, 0.2f, 0.3f}, body(63, 0.05f), betas(10, 0.5f);
  z.set("global_orient", NpyArray::from(go, {3}));
  z.set("body_pose", NpyArray::from(body, {63}));
  z.set("betas", NpyArray::from(betas, {1, 10}));
  z.write(path("one.npz"));
  const auto p = read_smplx_params(path("one.npz"));
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].pose[0], 0.1f);
  EXPECT_EQ(p[0].pose[3], 0.05f);
  EXPECT_EQ(p[0].pose[65], 0.05f);
  for (int i = 66; i < kNumPoseValues; ++i) EXPECT_EQ(p[0].pose[i], 0.0f);
  EXPECT_EQ(p[0].betas, betas);
  EXPECT_TRUE(p[0].expression.empty());
  EXPECT_EQ(p[0].transl, (std::array<float, 3>{0, 0, 0}));

  // N frames with shared (1, D) betas.
  Npz y;
  y.set("transl", NpyArray::from(std::vector<float>(12, 1.0f), {4, 3}));
  y.set("betas", NpyArray::from(betas, {1, 10}));
  y.set("body_pose", NpyArray::from(std::vector<float>(4 * 69, 0.2f), {4, 69}));  // SMPL: 23 joints
  y.write(path("shared.npz"));
  const auto q = read_smplx_params(path("shared.npz"));
  ASSERT_EQ(q.size(), 4u);
  for (const auto& f : q) {
    EXPECT_EQ(f.betas, betas);
    EXPECT_EQ(f.pose[65], 0.2f);
    EXPECT_EQ(f.pose[66], 0.0f);  // SMPL's two extra joints are not SMPL-X's jaw
  }
}

TEST_F(IoBody, ParamsPcaHandsAndHandMean) {
  BodyModel b = small_model();
  Npz z;
  std::vector<float> c = {1.0f, -0.5f, 0.25f};
  z.set("left_hand_pose", NpyArray::from(c, {1, 3}));
  z.set("right_hand_pose", NpyArray::from(std::vector<float>(45, 0.0f), {1, 45}));
  z.write(path("pca.npz"));
  const auto p = read_smplx_params(path("pca.npz"), &b);
  for (int k = 0; k < 45; ++k) {
    const float want = c[0] * b.hands_components_l[k] + c[1] * b.hands_components_l[45 + k] + c[2] * b.hands_components_l[90 + k];
    EXPECT_NEAR(p[0].pose[3 * kLeftHandFirst + k], want, 1e-6);
    EXPECT_EQ(p[0].pose[3 * kRightHandFirst + k], 0.0f);
  }
  const auto m = read_smplx_params(path("pca.npz"), &b, /*flat_hand_mean=*/false);
  for (int k = 0; k < 45; ++k) {
    EXPECT_NEAR(m[0].pose[3 * kLeftHandFirst + k], p[0].pose[3 * kLeftHandFirst + k] + b.hands_mean_l[k], 1e-6);
    EXPECT_EQ(m[0].pose[3 * kRightHandFirst + k], b.hands_mean_r[k]);
  }
  expect_params_error(path("pca.npz"), "left_hand_pose", "PCA");  // no model
}

TEST_F(IoBody, ParamsBadInput) {
  int n = 0;
  auto file_with = [&](std::initializer_list<std::pair<const char*, NpyArray>> arrays) {
    Npz z;
    for (auto& [k, a] : arrays) z.set(k, a);
    const std::string f = path("bad" + std::to_string(n++) + ".npz");
    z.write(f);
    return f;
  };
  std::vector<float> nan3 = {0.0f, std::numeric_limits<float>::quiet_NaN(), 0.0f};
  expect_params_error(file_with({{"jaw_pose", NpyArray::from(nan3, {1, 3})}}), "jaw_pose", "non-finite");
  expect_params_error(file_with({{"body_pose", NpyArray::from(std::vector<float>(120), {2, 60})}}), "body_pose",
                      "60 values");
  expect_params_error(file_with({{"global_orient", NpyArray::from(std::vector<float>(12), {4, 3})},
                                 {"transl", NpyArray::from(std::vector<float>(9), {3, 3})}}),
                      "transl", "3 frames");
  expect_params_error(file_with({{"transl", NpyArray::from(std::vector<float>(8), {2, 4})}}), "transl", "expected 3");
  expect_params_error(file_with({{"body_pose", NpyArray::from(std::vector<float>(63), {1, 21, 3})}}), "body_pose",
                      "wrong shape");
  expect_params_error(file_with({{"something_else", NpyArray::from(std::vector<float>(3), {3})}}), "",
                      "no SMPL-X parameter arrays");
  const BodyModel b = small_model();
  expect_params_error(file_with({{"betas", NpyArray::from(std::vector<float>(11), {11})}}), "betas", "11 values", &b);
  expect_params_error(file_with({{"transl", NpyArray::from(std::vector<float>(3), {3})}}), "", "hands_mean", nullptr,
                      false);
  // Writing NaN parameters is refused too.
  auto frames = random_frames(2, 3);
  frames[1].transl[2] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(write_smplx_params(path("w.npz"), frames), Error);
  EXPECT_FALSE(fs::exists(path("w.npz")));
}

}  // namespace
}  // namespace haha
