// Readers for real data, each on tiny fixtures written here in exactly the source layout
// (images through the image writer, npz through io/npy.h, pickles from tests/fixtures/pickle
// made by scripts/make_pickle_fixtures.py): values, cameras (pixel-centre convention,
// crop, resize), masks, splits; every bad input gives an error naming the offending file;
// a conversion failing mid-way leaves no output directory.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "data/readers.h"
#include "io/motion.h"
#include "support/data_test_util.h"
#include "io/npy.h"
#include "io/pickle.h"
#include "io/smplx_params_io.h"

namespace haha {
namespace {

using namespace testutil;

std::string fixtures() {
  return (fs::path(__FILE__).parent_path().parent_path() / "fixtures" / "pickle").string();
}

constexpr int W = 8, H = 12;

// .npy of one-byte values (bool / uint8), which npy.h does not write.
void write_npy_bytes(const std::string& path, const std::string& descr, int h, int w, const std::vector<uint8_t>& v) {
  std::string hdr = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (" + std::to_string(h) + ", " +
                    std::to_string(w) + "), }";
  while ((10 + hdr.size() + 1) % 64) hdr += ' ';
  hdr += '\n';
  std::string out = std::string("\x93NUMPY\x01\x00", 8);
  out += char(hdr.size() & 0xff);
  out += char(hdr.size() >> 8);
  out += hdr;
  out.append(reinterpret_cast<const char*>(v.data()), v.size());
  write_text(path, out);
}

// Value the fixture script gives entry `idx` of key number `key` in frame `frame`.
float xh_value(int frame, int key, int idx) { return float(frame + 0.01 * key + 0.001 * idx); }

// ---------------------------------------------------------------------------------------
// X-Humans

class XHumansTest : public TempDirTest {
 protected:
  // A take with frames 1..n (n <= 3: the pickle fixtures), 8 x 12 portrait frames.
  std::string make_take(const std::string& name, int n, float tz0 = 3.0f) {
    const fs::path take = dir_ / name;
    fs::create_directories(take / "render" / "image");
    fs::create_directories(take / "render" / "depth");
    fs::create_directories(take / "SMPLX");
    std::vector<float> ext;
    for (int f = 1; f <= n; ++f) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "color_%06d.png", f);
      write_image((take / "render" / "image" / buf).string(), rgb_pattern(W, H, f));
      std::snprintf(buf, sizeof buf, "depth_%06d.tiff", f);
      write_image((take / "render" / "depth" / buf).string(), depth_pattern(f));
      std::snprintf(buf, sizeof buf, "mesh-f%05d_smplx.pkl", f);
      fs::copy_file(fs::path(fixtures()) / "xhumans" / buf, take / "SMPLX" / buf);
      const float e[16] = {1, 0, 0, 0.1f * f, 0, 1, 0, -0.2f, 0, 0, 1, tz0 + float(f), 0, 0, 0, 1};
      ext.insert(ext.end(), e, e + 16);
    }
    Npz z;
    z.set("intrinsic", NpyArray::from(std::vector<double>{10, 0, 3.5, 0, 11, 5.5, 0, 0, 1}, {3, 3}));
    z.set("extrinsic", NpyArray::from(ext, {n, 4, 4}));
    z.write((take / "render" / "cameras.npz").string());
    return take.string();
  }
  // Background at the largest depth (5000); the person 2000 closer; a patch only 500
  // closer, which the release's rule (> 700) leaves out of the mask.
  static Image depth_pattern(int frame) {
    Image d(W, H, 1, 5000.0f);
    const Image m = mask_pattern(W, H, frame);
    for (size_t i = 0; i < d.data.size(); ++i) d.data[i] = m.data[i] > 0 ? 3000.0f : 5000.0f;
    d.at(0, 0, 0) = 4500.0f;
    return d;
  }
};

TEST_F(XHumansTest, ReadsFramesCamerasFitsAndDepthMasksWithSquareCrop) {
  XHumansOptions o;
  o.train_takes = {make_take("Take1", 3)};
  Dataset ds = read_xhumans(o);
  ASSERT_EQ(ds.frames.size(), 3u);
  EXPECT_EQ(ds.fits, Fits::exact);  // registered to the scans the frames are rendered from
  EXPECT_EQ(ds.width, 8);
  EXPECT_EQ(ds.height, 8);  // centre square of 8 x 12: rows 2..9
  for (int i = 0; i < 3; ++i) {
    const DatasetFrame& f = ds.frames[size_t(i)];
    const int frame = i + 1;
    EXPECT_EQ(f.split, Split::train);
    EXPECT_EQ(f.source_index, frame);
    // cx: OpenCV 3.5 -> +0.5 pixel-edge convention -> minus crop origin 0; cy: 5.5 + 0.5 - 2.
    EXPECT_FLOAT_EQ(f.camera.fx, 10.0f);
    EXPECT_FLOAT_EQ(f.camera.fy, 11.0f);
    EXPECT_FLOAT_EQ(f.camera.cx, 4.0f);
    EXPECT_FLOAT_EQ(f.camera.cy, 4.0f);
    EXPECT_FLOAT_EQ(f.camera.t.z, 3.0f + float(frame));
    EXPECT_FLOAT_EQ(f.camera.t.x, 0.1f * float(frame));
    // Pickle keys in the fixture's order: global_orient 0, transl 1, body_pose 2,
    // left hand 3, right hand 4, jaw 5, leye 6, reye 7, expression 8, betas 9.
    const SmplxParams& p = f.params;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.pose[size_t(k)], xh_value(frame, 0, k), 1e-6);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.transl[size_t(k)], xh_value(frame, 1, k), 1e-6);
    for (int k = 0; k < 63; ++k) EXPECT_NEAR(p.pose[size_t(3 + k)], xh_value(frame, 2, k), 1e-6);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.pose[size_t(66 + k)], xh_value(frame, 5, k), 1e-6);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.pose[size_t(69 + k)], xh_value(frame, 6, k), 1e-6);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.pose[size_t(72 + k)], xh_value(frame, 7, k), 1e-6);
    for (int k = 0; k < 45; ++k) EXPECT_NEAR(p.pose[size_t(75 + k)], xh_value(frame, 3, k), 1e-6);
    for (int k = 0; k < 45; ++k) EXPECT_NEAR(p.pose[size_t(120 + k)], xh_value(frame, 4, k), 1e-6);
    ASSERT_EQ(p.expression.size(), 10u);
    ASSERT_EQ(p.betas.size(), 10u);
    EXPECT_NEAR(p.expression[9], xh_value(frame, 8, 9), 1e-6);
    EXPECT_NEAR(p.betas[4], xh_value(frame, 9, 4), 1e-6);
  }
  ds.load_all();
  for (int i = 0; i < 3; ++i) {
    const Image src = rgb_pattern(W, H, i + 1), m = mask_pattern(W, H, i + 1);
    const DatasetFrame& f = ds.frames[size_t(i)];
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        for (int c = 0; c < 3; ++c) ASSERT_FLOAT_EQ(f.image.at(x, y, c), src.at(x, y + 2, c));
        ASSERT_EQ(f.mask.at(x, y, 0), m.at(x, y + 2, 0)) << x << "," << y;
      }
  }
  // The patch only 500 units in front of the background is not the person.
  EXPECT_EQ(read_depth(ds.frames[0].mask_path).at(0, 0, 0), 4500.0f);
}

TEST_F(XHumansTest, ResizeScalesIntrinsicsSoProjectionsFollowThePixels) {
  XHumansOptions o;
  o.train_takes = {make_take("Take1", 2)};
  o.max_side = 4;
  o.square_crop = false;
  Dataset ds = read_xhumans(o);
  EXPECT_EQ(ds.width, 3);  // 8 x 12 -> longer side 4: 2.67 -> 3 x 4
  EXPECT_EQ(ds.height, 4);
  // A point projecting to source pixel coordinate (u, v) (pixel-edge convention) lands on
  // (u * 3/8, v * 4/12) in the resized frame.
  const Vec3f X(0.3f, -0.4f, 0.0f);
  const Camera& c = ds.frames[0].camera;
  const Vec3f xc = c.to_camera(X);
  const Vec2f uv = c.project(xc);
  const float u_src = 10.0f * xc.x / xc.z + 3.5f + 0.5f, v_src = 11.0f * xc.y / xc.z + 5.5f + 0.5f;
  EXPECT_NEAR(uv.x, u_src * 3.0f / 8.0f, 1e-5f);
  EXPECT_NEAR(uv.y, v_src * 4.0f / 12.0f, 1e-5f);
  ds.load_frame(1);
  EXPECT_EQ(ds.frames[1].image.width, 3);
  EXPECT_EQ(ds.frames[1].mask.height, 4);
  for (float v : ds.frames[1].mask.data) EXPECT_TRUE(v >= 0.0f && v <= 1.0f);
}

TEST_F(XHumansTest, TestTakeSubsamplingAndConversionToNativeFormat) {
  XHumansOptions o;
  o.train_takes = {make_take("Take4", 3)};
  o.test_takes = {make_take("Take6", 3, 10.0f)};
  o.every = 2;  // frames 1 and 3 of each take
  Dataset ds = read_xhumans(o);
  ASSERT_EQ(ds.frames.size(), 4u);
  EXPECT_EQ(ds.indices(Split::train), (std::vector<int>{0, 1}));
  EXPECT_EQ(ds.indices(Split::test), (std::vector<int>{2, 3}));
  EXPECT_EQ(ds.frames[1].source_index, 3);
  EXPECT_FLOAT_EQ(ds.frames[3].camera.t.z, 13.0f);
  write_dataset(ds, path("out"));
  Dataset back = read_dataset(path("out"));
  ASSERT_EQ(back.frames.size(), 4u);
  EXPECT_EQ(back.fits, Fits::exact);
  EXPECT_FALSE(back.is_static_camera());
  ds.load_all();
  for (size_t i = 0; i < 4; ++i) {
    expect_same_params(ds.frames[i].params, back.frames[i].params);
    expect_same_camera(ds.frames[i].camera, back.frames[i].camera);
    for (size_t k = 0; k < ds.frames[i].image.data.size(); ++k)
      ASSERT_FLOAT_EQ(ds.frames[i].image.data[k], back.frames[i].image.data[k]);
    EXPECT_EQ(ds.frames[i].mask.data, back.frames[i].mask.data);
    EXPECT_EQ(ds.frames[i].split, back.frames[i].split);
  }
}

TEST_F(XHumansTest, GenderFromTheSubjectFolder) {
  XHumansOptions o;
  o.train_takes = {make_take("00019/train/Take5", 1)};
  write_text(path("00019/train/gender.txt"), "female\n");
  EXPECT_EQ(read_xhumans(o).gender, "female");
  o.gender = "male";  // the command line wins
  EXPECT_EQ(read_xhumans(o).gender, "male");
}

TEST_F(XHumansTest, BadInputsNameTheFile) {
  XHumansOptions o;
  const std::string take = make_take("Take1", 3);
  o.train_takes = {take};
  auto expect = [&](const std::vector<std::string>& needles) { expect_error([&] { read_xhumans(o); }, needles); };

  fs::rename(take + "/render/depth/depth_000002.tiff", path("d2.tiff"));
  expect({"render/depth/depth_000002.tiff", "missing"});
  fs::rename(path("d2.tiff"), take + "/render/depth/depth_000002.tiff");

  fs::copy_file(take + "/SMPLX/mesh-f00003_smplx.pkl", take + "/SMPLX/mesh-f00004_smplx.pkl");
  expect({"SMPLX/mesh-f00004_smplx.pkl", "color_000004.png"});
  fs::remove(take + "/SMPLX/mesh-f00004_smplx.pkl");

  fs::rename(take + "/SMPLX/mesh-f00001_smplx.pkl", path("p1.pkl"));
  expect({"SMPLX/mesh-f00001_smplx.pkl", "missing"});
  // A truncated pickle; a pickle that is not an SMPL-X fit; a (1, D) float64 fit is fine.
  const auto size = fs::file_size(path("p1.pkl"));
  fs::copy_file(path("p1.pkl"), take + "/SMPLX/mesh-f00001_smplx.pkl");
  fs::resize_file(take + "/SMPLX/mesh-f00001_smplx.pkl", size - 30);
  expect({"SMPLX/mesh-f00001_smplx.pkl", "truncated"});
  fs::copy_file(fixtures() + "/values_p2.pkl", take + "/SMPLX/mesh-f00001_smplx.pkl",
                fs::copy_options::overwrite_existing);
  expect({"SMPLX/mesh-f00001_smplx.pkl", "global_orient", "missing"});
  fs::copy_file(fixtures() + "/evil_global.pkl", take + "/SMPLX/mesh-f00001_smplx.pkl",
                fs::copy_options::overwrite_existing);
  expect({"SMPLX/mesh-f00001_smplx.pkl", "not allowed"});
  fs::copy_file(fixtures() + "/smplx_f64_lead1_p2.pkl", take + "/SMPLX/mesh-f00001_smplx.pkl",
                fs::copy_options::overwrite_existing);
  EXPECT_NEAR(read_xhumans(o).frames[0].params.pose[3], xh_value(3, 2, 0), 1e-6);
  fs::copy_file(path("p1.pkl"), take + "/SMPLX/mesh-f00001_smplx.pkl", fs::copy_options::overwrite_existing);

  {
    Npz z = Npz::read(take + "/render/cameras.npz");
    Npz bad(take + "/render/cameras.npz");
    bad.set("intrinsic", z.get("intrinsic"));
    bad.set("extrinsic", NpyArray::from(std::vector<float>(2 * 16, 0.0f), {2, 4, 4}));
    bad.write(take + "/render/cameras.npz");
    expect({"render/cameras.npz", "extrinsic", "2 cameras for 3 frames"});
    bad.set("extrinsic", z.get("extrinsic"));
    bad.set("intrinsic", NpyArray::from(std::vector<double>(6, 1.0), {2, 3}));
    bad.write(take + "/render/cameras.npz");
    expect({"render/cameras.npz", "intrinsic"});
    z.write(take + "/render/cameras.npz");
  }

  write_text(take + "/render/image/color_000003.png", "garbage");
  expect({"render/image/color_000003.png", "cannot read image"});
  write_image(take + "/render/image/color_000003.png", rgb_pattern(W, H + 2, 3));
  expect({"render/image/color_000003.png", "8x14"});
  write_image(take + "/render/image/color_000003.png", rgb_pattern(W, H, 3));
  write_image(take + "/render/depth/depth_000003.tiff", Image(W + 1, H, 1, 1.0f));
  expect({"render/depth/depth_000003.tiff", "9x12"});
  write_image(take + "/render/depth/depth_000003.tiff", depth_pattern(3));
  EXPECT_EQ(read_xhumans(o).frames.size(), 3u);

  o.train_takes = {path("nope")};
  expect({path("nope")});
}

TEST_F(XHumansTest, ConversionFailingMidwayLeavesNoOutput) {
  XHumansOptions o;
  const std::string take = make_take("Take1", 3);
  o.train_takes = {take};
  const Dataset ds = read_xhumans(o);
  fs::remove(take + "/render/image/color_000003.png");  // vanishes after validation
  expect_error([&] { write_dataset(ds, path("out")); }, {"render/image/color_000003.png"});
  EXPECT_FALSE(fs::exists(path("out")));
  EXPECT_TRUE(leftovers().empty());
}

// ---------------------------------------------------------------------------------------
// PeopleSnapshot (InstantAvatar)

class PeopleSnapshotTest : public TempDirTest {
 protected:
  // 10 frames; train 0:6:2 (3 rows), test 6:10:2 (2 rows). Masks of several dtypes.
  std::string make(int train_rows = 3, int test_rows = 2) {
    const fs::path d = dir_ / "male-3-casual";
    fs::create_directories(d / "images");
    fs::create_directories(d / "masks");
    fs::create_directories(d / "poses");
    for (int i = 0; i < 10; ++i) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "image_%04d.png", i);
      write_image((d / "images" / buf).string(), rgb_pattern(W, H, i));
      std::snprintf(buf, sizeof buf, "mask_%04d.npy", i);
      const Image m = mask_pattern(W, H, i);
      const std::string mp = (d / "masks" / buf).string();
      if (i < 4 || i >= 7) {
        std::vector<uint8_t> v(m.data.size());
        for (size_t k = 0; k < v.size(); ++k) v[k] = uint8_t(m.data[k] > 0 ? (i < 4 ? 1 : 255) : 0);
        write_npy_bytes(mp, i < 4 ? "|b1" : "|u1", H, W, v);
      } else {
        write_npy(mp, NpyArray::from(m.data, {H, W}));  // float32
      }
    }
    Npz cams;
    cams.set("intrinsic", NpyArray::from(std::vector<double>{20, 0, 3.5, 0, 20, 5.5, 0, 0, 1}, {3, 3}));
    cams.set("extrinsic", NpyArray::from(std::vector<float>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 0, 0, 0, 1}, {4, 4}));
    cams.set("height", NpyArray::from(std::vector<int64_t>{H}, {}));
    cams.set("width", NpyArray::from(std::vector<int64_t>{W}, {}));
    cams.write((d / "cameras.npz").string());
    write_poses((d / "poses" / "anim_nerf_train.npz").string(), train_rows, 0);
    write_poses((d / "poses" / "anim_nerf_test.npz").string(), test_rows, 100);
    return d.string();
  }
  static float pose_value(int row, int k, int base) { return 0.001f * float(k) + 0.1f * float(row + base); }
  static void write_poses(const std::string& path, int n, int base, int body_width = 69) {
    std::vector<float> orient, body, transl;
    for (int r = 0; r < n; ++r) {
      for (int k = 0; k < 3; ++k) orient.push_back(pose_value(r, k, base) + 1.0f);
      for (int k = 0; k < body_width; ++k) body.push_back(pose_value(r, k, base));
      for (int k = 0; k < 3; ++k) transl.push_back(pose_value(r, k, base) - 1.0f);
    }
    Npz z;
    z.set("betas", NpyArray::from(std::vector<float>(10, 0.5f), {1, 10}));
    z.set("global_orient", NpyArray::from(orient, {n, 3}));
    z.set("body_pose", NpyArray::from(body, {n, body_width}));
    z.set("transl", NpyArray::from(transl, {n, 3}));
    z.write(path);
  }
  // The fit stands in for fit/smpl_fit.h: it records what it was given and marks its
  // output (betas {7}, transl + 10) so the dataset provably holds the fit's result.
  PeopleSnapshotOptions opts(const std::string& d) {
    PeopleSnapshotOptions o;
    o.dir = d;
    o.train = {0, 6, 2};
    o.test = {6, 10, 2};
    o.fit_smpl = [this](const std::vector<SmplxParams>& smpl, const std::vector<int>& source) {
      given_ = smpl;
      given_source_ = source;
      std::vector<SmplxParams> out = smpl;
      for (SmplxParams& p : out) {
        p.betas = {7.0f};
        for (float& t : p.transl) t += 10.0f;
      }
      return out;
    };
    return o;
  }
  std::vector<SmplxParams> given_;
  std::vector<int> given_source_;
};

TEST_F(PeopleSnapshotTest, SmplBodyMappedOntoSmplxHandsAtRest) {
  Dataset ds = read_peoplesnapshot(opts(make()));
  ASSERT_EQ(ds.frames.size(), 5u);
  EXPECT_EQ(ds.fits, Fits::estimated);  // fitted to the monocular video
  EXPECT_EQ(ds.indices(Split::train), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(ds.indices(Split::test), (std::vector<int>{3, 4}));
  const int source[5] = {0, 2, 4, 6, 8};
  for (int i = 0; i < 5; ++i) {
    const DatasetFrame& f = ds.frames[size_t(i)];
    EXPECT_EQ(f.source_index, source[i]);
    const int row = i < 3 ? i : i - 3, base = i < 3 ? 0 : 100;
    // The fit received SMPL's 24 joints (22/23 in slots 25/40), transl and betas...
    const SmplxParams& g = given_.at(size_t(i));
    EXPECT_EQ(given_source_.at(size_t(i)), source[i]);
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(g.pose[size_t(k)], pose_value(row, k, base) + 1.0f);
    for (int k = 0; k < 63; ++k) EXPECT_FLOAT_EQ(g.pose[size_t(3 + k)], pose_value(row, k, base));
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(g.pose[size_t(3 * 25 + k)], pose_value(row, 63 + k, base));
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(g.pose[size_t(3 * 40 + k)], pose_value(row, 66 + k, base));
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(g.transl[size_t(k)], pose_value(row, k, base) - 1.0f);
    EXPECT_EQ(g.betas, std::vector<float>(10, 0.5f));
    // ... and the dataset holds what the fit returned.
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(f.params.transl[size_t(k)], pose_value(row, k, base) + 9.0f);
    EXPECT_EQ(f.params.betas, std::vector<float>{7.0f});
    EXPECT_FLOAT_EQ(f.camera.cx, 4.0f);
    EXPECT_FLOAT_EQ(f.camera.cy, 6.0f);
    EXPECT_FLOAT_EQ(f.camera.t.z, 4.0f);
  }
  ds.load_all();
  for (int i = 0; i < 5; ++i) {  // bool, uint8 (0/255) and float32 masks all read as 0/1
    const Image m = mask_pattern(W, H, source[i]);
    EXPECT_EQ(ds.frames[size_t(i)].mask.data, m.data) << i;
  }
  EXPECT_EQ(ds.frames[4].image.width, W);
}

TEST_F(PeopleSnapshotTest, BadInputsNameTheFile) {
  const std::string d = make();
  PeopleSnapshotOptions o = opts(d);
  o.train = {0, 8, 2};  // 4 frames, the npz has 3 rows
  expect_error([&] { read_peoplesnapshot(o); }, {"poses/anim_nerf_train.npz", "3 pose rows", "0:8:2"});
  o = opts(d);
  o.test = {4, 8, 2};  // frames 4, 6: 4 is also a training frame
  expect_error([&] { read_peoplesnapshot(o); }, {"image_0004.png", "both"});

  o = opts(d);
  write_poses(d + "/poses/anim_nerf_test.npz", 2, 100, 72);
  expect_error([&] { read_peoplesnapshot(o); }, {"poses/anim_nerf_test.npz", "body_pose"});
  write_poses(d + "/poses/anim_nerf_test.npz", 2, 100, 63);  // 21 body joints, SMPL hands at rest: fine
  EXPECT_FLOAT_EQ(read_peoplesnapshot(o).frames[4].params.pose[3 + 62], pose_value(1, 62, 100));
  EXPECT_EQ(given_[4].pose[3 * 25], 0.0f);
  // Without a fit (no SMPL model) nothing is copied: a clear refusal.
  o.fit_smpl = nullptr;
  expect_error([&] { read_peoplesnapshot(o); }, {"SMPL body model", "--smpl-model"});
  o = opts(d);
  write_poses(d + "/poses/anim_nerf_test.npz", 2, 100);

  fs::rename(d + "/masks/mask_0003.npy", path("m3.npy"));
  expect_error([&] { read_peoplesnapshot(o); }, {"masks/mask_0003.npy", "missing"});
  fs::rename(path("m3.npy"), d + "/masks/mask_0003.npy");

  fs::rename(d + "/images/image_0005.png", path("i5.png"));
  fs::rename(d + "/masks/mask_0005.npy", path("m5.npy"));
  expect_error([&] { read_peoplesnapshot(o); }, {"images/image_0005.png", "missing"});
  fs::rename(path("i5.png"), d + "/images/image_0005.png");
  fs::rename(path("m5.npy"), d + "/masks/mask_0005.npy");

  fs::remove(d + "/cameras.npz");
  expect_error([&] { read_peoplesnapshot(o); }, {"cameras.npz", "missing"});
  make();

  // A mask of the wrong size is found when the frame's pixels are read.
  write_npy_bytes(d + "/masks/mask_0002.npy", "|u1", H + 1, W, std::vector<uint8_t>((H + 1) * W, 1));
  Dataset ds = read_peoplesnapshot(o);
  expect_error([&] { ds.load_frame(1); }, {"masks/mask_0002.npy", "8x13"});
  write_npy_bytes(d + "/masks/mask_0002.npy", "<U1", H, W, std::vector<uint8_t>(H * W * 4, 1));
  expect_error([&] { ds.load_frame(1); }, {"masks/mask_0002.npy", "dtype"});
  expect_error([&] { write_dataset(ds, path("out")); }, {"masks/mask_0002.npy"});
  EXPECT_FALSE(fs::exists(path("out")));
  EXPECT_TRUE(leftovers().empty());
}

// ---------------------------------------------------------------------------------------
// SMPLify-X

class SmplifyxTest : public TempDirTest {
 protected:
  std::string make(bool results_tree = true) {
    const fs::path d = dir_ / "fits";
    fs::create_directories(d / "images");
    fs::create_directories(d / "masks");
    for (int i = 0; i < 3; ++i) {
      char stem[16];
      std::snprintf(stem, sizeof stem, "%05d", i);
      write_image((d / "images" / (std::string(stem) + ".png")).string(), rgb_pattern(W, H, i));
      write_image((d / "masks" / (std::string(stem) + ".png")).string(), mask_pattern(W, H, i));
      const fs::path src = fs::path(fixtures()) / "smplifyx" / stem / "000.pkl";
      if (results_tree) {
        fs::create_directories(d / "results" / stem);
        fs::copy_file(src, d / "results" / stem / "000.pkl");
      } else {
        fs::create_directories(d / "smplx");
        fs::copy_file(src, d / "smplx" / (std::string(stem) + ".pkl"));
      }
    }
    return d.string();
  }
  // Hand PCA components: not orthonormal on purpose, so a wrong index order shows.
  static BodyModel hand_model() {
    BodyModel m;
    m.num_shape = 300;
    m.num_expr = 100;
    m.hands_components_l.resize(45 * 45);
    m.hands_components_r.resize(45 * 45);
    m.hands_mean_l.resize(45);
    m.hands_mean_r.resize(45);
    for (int q = 0; q < 45; ++q) {
      for (int c = 0; c < 45; ++c) {
        m.hands_components_l[size_t(q * 45 + c)] = (q == c ? 1.0f : 0.0f) + 0.01f * float(q) - 0.002f * float(c);
        m.hands_components_r[size_t(q * 45 + c)] = (q == c ? -1.0f : 0.0f) + 0.003f * float(c);
      }
      m.hands_mean_l[size_t(q)] = 0.1f * float(q);
      m.hands_mean_r[size_t(q)] = -0.05f * float(q);
    }
    return m;
  }
};

TEST_F(SmplifyxTest, PcaHandsHandMeanAndCameraKeys) {
  const BodyModel model = hand_model();
  SmplifyxOptions o;
  o.dir = make();
  o.model = &model;
  o.flat_hand_mean = false;  // SMPLify-X's default
  Dataset ds = read_smplifyx(o);
  ASSERT_EQ(ds.frames.size(), 3u);
  EXPECT_EQ(ds.fits, Fits::estimated);  // fitted to each image's keypoints
  EXPECT_EQ(ds.width, W);
  for (int i = 0; i < 3; ++i) {
    const DatasetFrame& f = ds.frames[size_t(i)];
    // Fixture: camera_translation (0.1 i, -0.2, 5 + i), identity rotation; focal 5000 and
    // the image centre (SMPLify-X's assumptions), + 0.5 for the pixel-edge convention.
    EXPECT_FLOAT_EQ(f.camera.fx, 5000.0f);
    EXPECT_FLOAT_EQ(f.camera.cx, W * 0.5f + 0.5f);
    EXPECT_FLOAT_EQ(f.camera.cy, H * 0.5f + 0.5f);
    EXPECT_NEAR(f.camera.t.x, 0.1f * float(i), 1e-6f);
    EXPECT_FLOAT_EQ(f.camera.t.z, 5.0f + float(i));
    EXPECT_FLOAT_EQ(f.params.pose[0], float(M_PI));
    EXPECT_NEAR(f.params.pose[2], 0.1f * float(i), 1e-6f);
    for (int k = 0; k < 63; ++k) EXPECT_NEAR(f.params.pose[size_t(3 + k)], 0.001f * float(k) * float(i + 1), 1e-6f);
    EXPECT_NEAR(f.params.pose[size_t(3 * kJaw)], 0.2f, 1e-6f);
    for (int c = 0; c < 45; ++c) {
      double l = model.hands_mean_l[size_t(c)], r = model.hands_mean_r[size_t(c)];
      for (int q = 0; q < 12; ++q) {
        l += 0.05 * (q + i) * model.hands_components_l[size_t(q * 45 + c)];
        r += -0.05 * (q + i) * model.hands_components_r[size_t(q * 45 + c)];
      }
      EXPECT_NEAR(f.params.pose[size_t(3 * kLeftHandFirst + c)], l, 1e-5) << c;
      EXPECT_NEAR(f.params.pose[size_t(3 * kRightHandFirst + c)], r, 1e-5) << c;
    }
    ASSERT_EQ(f.params.betas.size(), 10u);
    EXPECT_NEAR(f.params.betas[0], -0.3f, 1e-6f);
    EXPECT_EQ(f.params.transl[0], 0.0f);  // SMPLify-X keeps translation in the camera
  }
  ds.load_all();
  EXPECT_EQ(ds.frames[2].mask.data, mask_pattern(W, H, 2).data);
}

TEST_F(SmplifyxTest, FlatFolderLayoutAndSplits) {
  const BodyModel model = hand_model();
  SmplifyxOptions o;
  o.dir = make(false);
  o.model = &model;
  o.train = {0, 2, 1};
  o.test = {2, 3, 1};
  const Dataset ds = read_smplifyx(o);
  ASSERT_EQ(ds.frames.size(), 3u);
  EXPECT_EQ(ds.indices(Split::test), (std::vector<int>{2}));
  // Flat hand mean: PCA only.
  double l0 = 0;
  for (int q = 0; q < 12; ++q) l0 += 0.05 * q * model.hands_components_l[size_t(q * 45)];
  EXPECT_NEAR(ds.frames[0].params.pose[size_t(3 * kLeftHandFirst)], l0, 1e-5);
}

TEST_F(SmplifyxTest, BadInputsNameTheFile) {
  const BodyModel model = hand_model();
  SmplifyxOptions o;
  o.dir = make();
  expect_error([&] { read_smplifyx(o); }, {"results/00000/000.pkl", "left_hand_pose", "PCA"});
  o.model = &model;
  o.flat_hand_mean = false;
  BodyModel no_mean = model;
  no_mean.hands_mean_l.clear();
  o.model = &no_mean;
  expect_error([&] { read_smplifyx(o); }, {"results/00000/000.pkl", "hand mean"});
  o.model = &model;
  fs::rename(o.dir + "/results/00001/000.pkl", path("x.pkl"));
  expect_error([&] { read_smplifyx(o); }, {"results/00001/000.pkl", "missing"});
  fs::rename(path("x.pkl"), o.dir + "/results/00001/000.pkl");
  fs::remove(o.dir + "/masks/00002.png");
  expect_error([&] { read_smplifyx(o); }, {"masks/00002.png", "missing"});
  write_image(o.dir + "/masks/00002.png", mask_pattern(W, H, 2));
  write_image(o.dir + "/masks/00007.png", mask_pattern(W, H, 2));
  expect_error([&] { read_smplifyx(o); }, {"masks/00007.png", "no matching image"});
  fs::remove(o.dir + "/masks/00007.png");
  fs::copy_file(fixtures() + "/values_p3.pkl", o.dir + "/results/00002/000.pkl", fs::copy_options::overwrite_existing);
  expect_error([&] { read_smplifyx(o); }, {"results/00002/000.pkl", "global_orient"});
  EXPECT_NO_THROW(read_smplifyx([&] { SmplifyxOptions p = o; p.train = {0, 2, 1}; return p; }()));
}

// ---------------------------------------------------------------------------------------
// AMASS motions

class AmassTest : public TempDirTest {};

TEST_F(AmassTest, SmplxStageIiMotion) {
  const int T = 4;
  std::vector<double> poses(T * 165), trans(T * 3);
  for (size_t i = 0; i < poses.size(); ++i) poses[i] = 0.001 * double(i % 165) + double(i / 165);
  for (size_t i = 0; i < trans.size(); ++i) trans[i] = 0.5 * double(i);
  Npz z;
  z.set("poses", NpyArray::from(poses, {T, 165}));
  z.set("trans", NpyArray::from(trans, {T, 3}));
  z.set("betas", NpyArray::from(std::vector<double>(16, 0.25), {16}));
  z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{120.0}, {}));
  z.write(path("a_stageii.npz"));
  const Motion m = read_amass(path("a_stageii.npz"));
  ASSERT_EQ(m.frames.size(), size_t(T));
  EXPECT_EQ(m.fps, 120.0);
  for (int f = 0; f < T; ++f) {
    for (int k = 0; k < 165; ++k) EXPECT_FLOAT_EQ(m.frames[size_t(f)].pose[size_t(k)], float(0.001 * k + f));
    EXPECT_FLOAT_EQ(m.frames[size_t(f)].transl[2], float(0.5 * (3 * f + 2)));
    EXPECT_EQ(m.frames[size_t(f)].betas.size(), 16u);
  }
  EXPECT_EQ(read_motion(path("a_stageii.npz")).frames.size(), size_t(T));
}

TEST_F(AmassTest, SmplhMotionHasHandsAndNoFace) {
  const int T = 3;
  std::vector<float> poses(T * 156), trans(T * 3, 1.0f);
  for (size_t i = 0; i < poses.size(); ++i) poses[i] = 0.01f * float(i % 156) + 1.0f;
  Npz z;
  z.set("poses", NpyArray::from(poses, {T, 156}));
  z.set("trans", NpyArray::from(trans, {T, 3}));
  z.set("betas", NpyArray::from(std::vector<float>(16, 0.5f), {16}));
  z.set("mocap_framerate", NpyArray::from(std::vector<double>{60.0}, {}));
  z.write(path("smplh.npz"));
  const Motion m = read_amass(path("smplh.npz"));
  ASSERT_EQ(m.frames.size(), size_t(T));
  EXPECT_EQ(m.fps, 60.0);
  const SmplxParams& p = m.frames[1];
  for (int k = 0; k < 66; ++k) EXPECT_FLOAT_EQ(p.pose[size_t(k)], 0.01f * float(k) + 1.0f);
  for (int k = 66; k < 75; ++k) EXPECT_EQ(p.pose[size_t(k)], 0.0f);  // jaw, eyes
  for (int k = 0; k < 90; ++k) EXPECT_FLOAT_EQ(p.pose[size_t(75 + k)], 0.01f * float(66 + k) + 1.0f);
  EXPECT_TRUE(p.betas.empty());  // SMPL+H shape space
}

TEST_F(AmassTest, BadMotionsNameTheFileAndKey) {
  Npz z;
  z.set("poses", NpyArray::from(std::vector<float>(4 * 165, 0.0f), {4, 165}));
  z.set("trans", NpyArray::from(std::vector<float>(3 * 3, 0.0f), {3, 3}));
  z.set("mocap_frame_rate", NpyArray::from(std::vector<double>{30.0}, {}));
  z.write(path("m.npz"));
  expect_error([&] { read_amass(path("m.npz")); }, {path("m.npz"), "trans", "3 frames"});
  z.set("trans", NpyArray::from(std::vector<float>(4 * 3, 0.0f), {4, 3}));
  z.set("poses", NpyArray::from(std::vector<float>(4 * 100, 0.0f), {4, 100}));
  z.write(path("m.npz"));
  expect_error([&] { read_amass(path("m.npz")); }, {path("m.npz"), "poses", "165"});
  std::vector<float> nan_poses(4 * 165, 0.0f);
  nan_poses[200] = std::nanf("");
  z.set("poses", NpyArray::from(nan_poses, {4, 165}));
  z.write(path("m.npz"));
  expect_error([&] { read_amass(path("m.npz")); }, {path("m.npz"), "poses", "non-finite"});
  Npz nofps;
  nofps.set("poses", NpyArray::from(std::vector<float>(165, 0.0f), {1, 165}));
  nofps.set("trans", NpyArray::from(std::vector<float>(3, 0.0f), {1, 3}));
  nofps.write(path("n.npz"));
  expect_error([&] { read_amass(path("n.npz")); }, {path("n.npz"), "frame rate"});
}

TEST_F(AmassTest, NativeParameterFilesAreMotionsToo) {
  std::vector<SmplxParams> p = {params_pattern(0), params_pattern(1)};
  write_smplx_params(path("p.npz"), p);
  const Motion m = read_motion(path("p.npz"));
  ASSERT_EQ(m.frames.size(), 2u);
  EXPECT_EQ(m.fps, 30.0);
  expect_same_params(m.frames[1], p[1]);
}

TEST(FrameRangeTest, PythonSliceSemantics) {
  EXPECT_EQ(parse_frame_range("0:10:4", "x").indices(100), (std::vector<int>{0, 4, 8}));
  EXPECT_EQ(parse_frame_range("5:", "x").indices(8), (std::vector<int>{5, 6, 7}));
  EXPECT_EQ(parse_frame_range("2:100", "x").indices(4), (std::vector<int>{2, 3}));
  EXPECT_EQ(parse_frame_range("456:676:4", "x").indices(676).size(), 55u);
  expect_error([] { parse_frame_range("1:2:0", "--test-frames"); }, {"--test-frames"});
  expect_error([] { parse_frame_range("a:b", "--train-frames"); }, {"--train-frames", "a:b"});
  expect_error([] { parse_frame_range("7", "--train-frames"); }, {"--train-frames"});
}

}  // namespace
}  // namespace haha
