// The native dataset format: exact round trips (pixels, masks, cameras static and per
// frame, SMPL-X fits, true fits, splits), validation of every bad input with an error
// naming the offending file, and atomic writes (a failing write leaves nothing).
#include <gtest/gtest.h>

#include <filesystem>

#include "data/dataset.h"
#include "support/data_test_util.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"

namespace haha {
namespace {

using namespace testutil;

constexpr int W = 8, H = 12;

Dataset small_dataset(int n = 4, bool per_frame_cameras = false, bool with_truth = false) {
  Dataset ds;
  ds.width = W;
  ds.height = H;
  ds.fps = 25;
  ds.gender = "female";
  ds.source = "unit test";
  for (int i = 0; i < n; ++i) {
    DatasetFrame f;
    f.split = i == n - 1 ? Split::test : Split::train;
    f.camera = camera_pattern(W, H, per_frame_cameras ? 3.0f + 0.5f * float(i) : 3.0f);
    f.params = params_pattern(i);
    f.source_index = 10 + 2 * i;
    f.image = rgb_pattern(W, H, i);
    f.mask = mask_pattern(W, H, i);
    ds.frames.push_back(f);
    if (with_truth) {
      SmplxParams t = params_pattern(i);
      t.pose[5] += 0.25f;
      ds.params_true.push_back(t);
    }
  }
  return ds;
}

void expect_same_dataset(const Dataset& a, const Dataset& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.fps, b.fps);
  EXPECT_EQ(a.gender, b.gender);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.premultiplied, b.premultiplied);
  EXPECT_EQ(a.fits, b.fits);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t i = 0; i < a.frames.size(); ++i) {
    const DatasetFrame &fa = a.frames[i], &fb = b.frames[i];
    EXPECT_EQ(fa.split, fb.split);
    EXPECT_EQ(fa.source_index, fb.source_index);
    expect_same_camera(fa.camera, fb.camera);  // shortest round-trip decimals: exact
    expect_same_params(fa.params, fb.params);  // float32 npz: exact
    ASSERT_EQ(fa.image.data.size(), fb.image.data.size());
    for (size_t k = 0; k < fa.image.data.size(); ++k) ASSERT_FLOAT_EQ(fa.image.data[k], fb.image.data[k]);
    ASSERT_EQ(fa.mask.data.size(), fb.mask.data.size());
    for (size_t k = 0; k < fa.mask.data.size(); ++k) ASSERT_FLOAT_EQ(fa.mask.data[k], fb.mask.data[k]);
  }
  ASSERT_EQ(a.params_true.size(), b.params_true.size());
  for (size_t i = 0; i < a.params_true.size(); ++i) expect_same_params(a.params_true[i], b.params_true[i]);
}

class DatasetTest : public TempDirTest {
 protected:
  // A valid dataset on disk to break in one way per test.
  std::string good(int n = 4) {
    const std::string d = path("ds");
    write_dataset(small_dataset(n), d);
    return d;
  }
};

TEST_F(DatasetTest, RoundTripStaticCamera) {
  const Dataset ds = small_dataset();
  write_dataset(ds, path("ds"));
  const Dataset back = read_dataset(path("ds"));
  expect_same_dataset(ds, back);
  EXPECT_TRUE(back.is_static_camera());
  EXPECT_EQ(back.indices(Split::train), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(back.indices(Split::test), (std::vector<int>{3}));
  // The documented layout.
  for (const char* f : {"dataset.json", "images/000000.png", "images/000003.png", "masks/000003.png",
                        "smplx/params.npz"})
    EXPECT_TRUE(fs::is_regular_file(path(std::string("ds/") + f))) << f;
  EXPECT_FALSE(fs::exists(path("ds/smplx/params_true.npz")));
  const std::string json = read_text(path("ds/dataset.json"));
  EXPECT_NE(json.find("\"camera\""), std::string::npos);
  EXPECT_EQ(json.find("\"camera\""), json.rfind("\"camera\""));  // once, at the top level
  // The params file is a standard SMPL-X fit file with (N, D) arrays.
  const Npz z = Npz::read(path("ds/smplx/params.npz"));
  EXPECT_EQ(z.get("body_pose").shape, (std::vector<int64_t>{4, 63}));
  EXPECT_EQ(z.get("left_hand_pose").shape, (std::vector<int64_t>{4, 45}));
  EXPECT_TRUE(leftovers().empty());
}

TEST_F(DatasetTest, RoundTripPerFrameCamerasAndTrueParams) {
  const Dataset ds = small_dataset(5, true, true);
  write_dataset(ds, path("ds"));
  const Dataset back = read_dataset(path("ds"));
  expect_same_dataset(ds, back);
  EXPECT_FALSE(back.is_static_camera());
  EXPECT_TRUE(fs::is_regular_file(path("ds/smplx/params_true.npz")));
}

// The third split (`haha synth --unseen`): written and read as the others, kept apart from
// the training and test frames; a dataset without it reads as before (RoundTripStaticCamera).
TEST_F(DatasetTest, UnseenSplitRoundTripsAndStaysApart) {
  Dataset ds = small_dataset(5, true, true);
  ds.frames[1].split = ds.frames[4].split = Split::unseen;
  ds.frames[3].split = Split::test;
  write_dataset(ds, path("ds"));
  const Dataset back = read_dataset(path("ds"));
  expect_same_dataset(ds, back);
  EXPECT_EQ(back.indices(Split::train), (std::vector<int>{0, 2}));
  EXPECT_EQ(back.indices(Split::test), (std::vector<int>{3}));
  EXPECT_EQ(back.indices(Split::unseen), (std::vector<int>{1, 4}));
  EXPECT_NE(read_text(path("ds/dataset.json")).find("\"split\":\"unseen\""), std::string::npos);
  for (Split s : {Split::train, Split::test, Split::unseen}) EXPECT_EQ(parse_split(split_name(s), "x"), s);
  expect_error([] { parse_split("validation", "--split"); }, {"--split", "'validation'", "unseen"});
}

TEST_F(DatasetTest, PremultipliedFlagRoundTripsAndIsAbsentWhenUnknown) {
  for (int flag : {-1, 0, 1}) {
    Dataset ds = small_dataset(2);
    ds.premultiplied = flag;
    const std::string d = path("ds" + std::to_string(flag + 1));
    write_dataset(ds, d);
    EXPECT_EQ(read_dataset(d).premultiplied, flag);
    // Unknown writes nothing: files stay as older builds wrote (and read) them.
    EXPECT_EQ(read_text(d + "/dataset.json").find("premultiplied") == std::string::npos, flag == -1);
  }
}

TEST_F(DatasetTest, FitsFlagRoundTripsAndIsAbsentWhenUnknown) {
  for (Fits fits : {Fits::unknown, Fits::exact, Fits::estimated}) {
    Dataset ds = small_dataset(2);
    ds.fits = fits;
    const std::string d = path(std::string("ds_") + (fits == Fits::unknown ? "unknown" : fits_name(fits)));
    write_dataset(ds, d);
    EXPECT_EQ(read_dataset(d).fits, fits);
    // Unknown writes nothing: files stay as older builds wrote (and read) them.
    const std::string json = read_text(d + "/dataset.json");
    EXPECT_EQ(json.find("\"fits\"") == std::string::npos, fits == Fits::unknown);
    if (fits != Fits::unknown) {
      EXPECT_NE(json.find(std::string("\"fits\": \"") + fits_name(fits) + "\""), std::string::npos);
    }
  }
}

TEST_F(DatasetTest, HeadersModeDefersDecodingButChecksFiles) {
  const std::string d = good();
  Dataset ds = read_dataset(d, LoadPixels::headers);
  for (const auto& f : ds.frames) EXPECT_TRUE(f.image.empty());
  ds.load_frame(2);
  const Image ref = small_dataset().frames[2].image;
  ASSERT_EQ(ds.frames[2].image.data.size(), ref.data.size());
  for (size_t k = 0; k < ref.data.size(); ++k) EXPECT_FLOAT_EQ(ds.frames[2].image.data[k], ref.data[k]);
  ds.unload_frame(2);
  EXPECT_TRUE(ds.frames[2].image.empty());
  fs::remove(path("ds/masks/000001.png"));
  expect_error([&] { read_dataset(d, LoadPixels::headers); }, {"masks/000001.png", "missing"});
}

TEST_F(DatasetTest, StreamingWriterMatchesWholeDatasetWriter) {
  const Dataset ds = small_dataset(3);
  {
    DatasetWriter w(path("ds"), W, H, ds.fps, ds.gender, ds.source);
    for (const auto& f : ds.frames) w.add(f, f.image, f.mask);
    EXPECT_EQ(w.num_frames(), 3);
    EXPECT_FALSE(fs::exists(path("ds")));  // nothing visible until finish()
    w.finish();
  }
  expect_same_dataset(ds, read_dataset(path("ds")));
}

TEST_F(DatasetTest, ReplacesAnExistingDatasetButNothingElse) {
  write_dataset(small_dataset(4), path("ds"));
  write_dataset(small_dataset(2), path("ds"));
  EXPECT_EQ(read_dataset(path("ds")).frames.size(), 2u);
  EXPECT_FALSE(fs::exists(path("ds/images/000003.png")));  // the old frames are gone
  fs::create_directories(path("other"));
  write_text(path("other/notes.txt"), "precious");
  expect_error([&] { write_dataset(small_dataset(2), path("other")); }, {path("other"), "refusing"});
  EXPECT_EQ(read_text(path("other/notes.txt")), "precious");
  fs::create_directories(path("empty"));
  write_dataset(small_dataset(1), path("empty"));
  EXPECT_EQ(read_dataset(path("empty")).frames.size(), 1u);
  EXPECT_TRUE(leftovers().empty());
}

TEST_F(DatasetTest, FailingWritesLeaveNothingBehind) {
  // Bad frame in the middle: non-finite parameters.
  Dataset ds = small_dataset(4);
  ds.frames[2].params.pose[7] = std::nanf("");
  expect_error([&] { write_dataset(ds, path("ds")); }, {"ds/smplx/params.npz", "frame 2", "non-finite"});
  EXPECT_FALSE(fs::exists(path("ds")));
  // Wrong image size; wrong mask channels; camera of another size.
  ds = small_dataset(4);
  ds.frames[1].image = rgb_pattern(W + 1, H, 1);
  expect_error([&] { write_dataset(ds, path("ds")); }, {"ds/images/000001.png", "9x12x3"});
  ds = small_dataset(4);
  ds.frames[3].mask = rgb_pattern(W, H, 0);
  expect_error([&] { write_dataset(ds, path("ds")); }, {"ds/masks/000003.png", "8x12x3"});
  ds = small_dataset(4);
  ds.frames[3].camera.width = 16;
  expect_error([&] { write_dataset(ds, path("ds")); }, {"ds/dataset.json", "frames[3].camera", "16x12"});
  ds = small_dataset(4);
  ds.frames[0].camera.R.a[0][0] = 2.0f;  // not a rotation
  expect_error([&] { write_dataset(ds, path("ds")); }, {"ds/dataset.json", "frames[0].camera", "orthonormal"});
  // Truth for some frames only.
  ds = small_dataset(3, false, true);
  ds.params_true.pop_back();
  expect_error([&] { write_dataset(ds, path("ds")); }, {path("ds"), "true parameter"});
  EXPECT_FALSE(fs::exists(path("ds")));
  // A failing write over an existing dataset keeps the old one intact.
  write_dataset(small_dataset(4), path("ds"));
  ds = small_dataset(2);
  ds.frames[1].image.data[0] = std::nanf("");
  expect_error([&] { write_dataset(ds, path("ds")); }, {"ds/images/000001.png", "non-finite"});
  EXPECT_EQ(read_dataset(path("ds")).frames.size(), 4u);
  EXPECT_TRUE(leftovers().empty());
}

TEST_F(DatasetTest, MissingOrUnreadableFramesNameTheFile) {
  const std::string d = good();
  fs::remove(path("ds/images/000002.png"));
  expect_error([&] { read_dataset(d); }, {"ds/images/000002.png", "missing"});
  write_text(path("ds/images/000002.png"), "not an image");
  expect_error([&] { read_dataset(d); }, {"ds/images/000002.png"});
  write_image(path("ds/images/000002.png"), rgb_pattern(W, H + 1, 0));
  expect_error([&] { read_dataset(d); }, {"ds/images/000002.png", "8x13"});
  write_image(path("ds/images/000002.png"), rgb_pattern(W, H, 2));
  fs::remove(path("ds/masks/000000.png"));
  expect_error([&] { read_dataset(d); }, {"ds/masks/000000.png", "missing"});
  // Header fine, pixel data cut: found while decoding, still naming the file.
  write_image(path("ds/masks/000000.png"), mask_pattern(W, H, 0));
  write_image(path("full.png"), rgb_pattern(W, H, 1));
  fs::copy_file(path("full.png"), path("ds/images/000001.png"), fs::copy_options::overwrite_existing);
  fs::resize_file(path("ds/images/000001.png"), fs::file_size(path("full.png")) - 20);  // into IDAT
  EXPECT_NO_THROW(read_image_info(path("ds/images/000001.png")));
  expect_error([&] { read_dataset(d); }, {"ds/images/000001.png"});
}

TEST_F(DatasetTest, ParameterCountsShapesAndValuesAreChecked) {
  const std::string d = good(4);
  const std::string npz = path("ds/smplx/params.npz");
  std::vector<SmplxParams> p;
  for (int i = 0; i < 3; ++i) p.push_back(params_pattern(i));
  write_smplx_params(npz, p);  // one frame short
  expect_error([&] { read_dataset(d); }, {npz, "3 frames", "4 frames"});
  Npz z(npz);
  {
    std::vector<float> body(4 * 62, 0.0f);
    z.set("body_pose", NpyArray::from(body, {4, 62}));
    z.set("global_orient", NpyArray::from(std::vector<float>(12, 0.0f), {4, 3}));
    z.write(npz);
  }
  expect_error([&] { read_dataset(d); }, {npz, "body_pose", "62"});
  {
    Npz nanz(npz);
    std::vector<float> t(12, 0.0f);
    t[4] = std::nanf("");
    nanz.set("transl", NpyArray::from(t, {4, 3}));
    nanz.write(npz);
  }
  expect_error([&] { read_dataset(d); }, {npz, "transl"});
  fs::remove(npz);
  expect_error([&] { read_dataset(d); }, {npz, "missing"});
}

TEST_F(DatasetTest, DatasetJsonProblemsNameTheFileAndKey) {
  const std::string d = good(2);
  const std::string json = path("ds/dataset.json");
  const std::string orig = read_text(json);
  auto with = [&](const std::string& from, const std::string& to, const std::vector<std::string>& needles) {
    write_text(json, orig);
    replace_in_file(json, from, to);
    expect_error([&] { read_dataset(d); }, needles);
  };
  with("\"split\":\"train\"", "\"split\":\"val\"", {json, "frames[0].split", "val"});
  with("\"images/000001.png\"", "\"../images/000001.png\"", {json, "frames[1].image", ".."});
  with("\"images/000001.png\"", "\"/etc/passwd\"", {json, "frames[1].image", "relative"});
  with("\"width\": 8", "\"width\": 9", {"ds/images/000000.png", "9x12"});
  with("\"version\": 1", "\"version\": 7", {json, "version"});
  with("\"gender\": \"female\"", "\"gender\": \"robot\"", {json, "gender", "robot"});
  with("\"fps\": 25", "\"fps\": -1", {json, "fps"});
  with("\"gender\": \"female\"", "\"gender\": \"female\", \"premultiplied\": \"yes\"", {json, "premultiplied", "true or false"});
  with("\"gender\": \"female\"", "\"gender\": \"female\", \"fits\": \"guessed\"", {json, "fits", "guessed", "exact"});
  with("\"gender\": \"female\"", "\"gender\": \"female\", \"fits\": true", {json, "fits", "estimated"});
  with("\"format\"", "\"formatt\"", {json, "formatt", "unknown"});
  with("\"camera\": {", "\"kamera\": {", {json, "kamera", "unknown"});
  with("\"smplx\": \"smplx/params.npz\"", "\"smplx\": \"smplx/nope.npz\"", {"smplx/nope.npz", "missing"});
  with("\"frames\": [", "\"frames\": 3, \"x\": [", {json});
  write_text(json, orig.substr(0, orig.size() / 2));
  expect_error([&] { read_dataset(d); }, {json, "invalid JSON"});
  // Camera problems name the key path inside the file.
  write_text(json, orig);
  replace_in_file(json, "\"near\":", "\"near\":-");
  expect_error([&] { read_dataset(d); }, {json, "camera", "near"});
  fs::remove(json);
  expect_error([&] { read_dataset(d); }, {json, "missing"});
  expect_error([&] { read_dataset(path("nope")); }, {path("nope")});
}

TEST_F(DatasetTest, LoaderFeedsFramesWithoutPixels) {
  // A dataset whose pixels come from a loader (what the readers produce) writes the same.
  Dataset ds = small_dataset(3);
  const Dataset ref = ds;
  for (auto& f : ds.frames) f.image = f.mask = Image();
  ds.loader = [](int i, Image& rgb, Image& mask) {
    rgb = rgb_pattern(W, H, i);
    mask = mask_pattern(W, H, i);
  };
  write_dataset(ds, path("ds"));
  expect_same_dataset(ref, read_dataset(path("ds")));
  // load_all checks what the loader produced against the dataset size.
  ds.loader = [](int i, Image& rgb, Image& mask) {
    rgb = rgb_pattern(W, i == 1 ? H - 1 : H, i);
    mask = mask_pattern(W, H, i);
  };
  ds.frames[1].image_path = "src/frame1.png";
  expect_error([&] { ds.load_all(); }, {"src/frame1.png", "8x11x3"});
}

}  // namespace
}  // namespace haha
