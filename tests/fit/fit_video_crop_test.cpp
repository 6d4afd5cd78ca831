// The crop of fit-video's dataset (fit/fit_video_crop.h): the box of known masks and
// projected points, the margin, clipping at the frame border, even sizes, empty masks, the
// shifted intrinsics (a 3D point lands on the same content pixel), and "source_crop" kept
// by the dataset writer and reader.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "fit/fit_video_crop.h"
#include "core/atomic_file.h"
#include "data/dataset.h"
#include "support/data_test_util.h"

namespace haha {
namespace {

Image rect_mask(int w, int h, int x0, int y0, int x1, int y1, float v = 1.0f) {  // [x0, x1] x [y0, y1]
  Image m(w, h, 1);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) m.at(x, y, 0) = v;
  return m;
}

TEST(FitVideoCrop, BoxOfKnownMasks) {
  EXPECT_EQ(mask_box(rect_mask(64, 48, 10, 5, 19, 44)), (CropBox{10, 5, 10, 40}));
  EXPECT_TRUE(mask_box(Image(64, 48, 1)).empty());                        // nobody
  EXPECT_TRUE(mask_box(rect_mask(64, 48, 10, 5, 19, 44, 0.5f)).empty());  // soft edge only: not > 0.5
  EXPECT_EQ(mask_box(rect_mask(64, 48, 0, 0, 0, 0)), (CropBox{0, 0, 1, 1}));
  // The union over frames; an empty box adds nothing.
  const CropBox u = box_union(mask_box(rect_mask(64, 48, 10, 5, 19, 44)), mask_box(rect_mask(64, 48, 30, 8, 33, 20)));
  EXPECT_EQ(u, (CropBox{10, 5, 24, 40}));
  EXPECT_EQ(box_union(u, CropBox{}), u);
  EXPECT_EQ(box_union(CropBox{}, u), u);
}

TEST(FitVideoCrop, MarginClippingAndEvenSizes) {
  // 10% of the larger side (40 px: 4 px) on every side, already even.
  EXPECT_EQ(dataset_crop({20, 10, 10, 40}, 100, 80), (CropBox{16, 6, 18, 48}));
  // A small box gets the minimum margin; an odd width grows by one at the end.
  EXPECT_EQ(dataset_crop({50, 50, 5, 6}, 100, 80), (CropBox{46, 46, 14, 14}));
  // At the frame border the margin is clipped; an odd width grows at the start instead.
  EXPECT_EQ(dataset_crop({0, 0, 10, 40}, 100, 80), (CropBox{0, 0, 14, 44}));
  EXPECT_EQ(dataset_crop({93, 50, 7, 20}, 100, 80), (CropBox{88, 46, 12, 28}));  // 89..100 is 11: one more at the start
  // The whole of an odd frame stays odd: nothing to grow into.
  EXPECT_EQ(dataset_crop({1, 1, 97, 77}, 99, 79), (CropBox{0, 0, 99, 79}));
  // Nobody (an empty box) or a box outside the frame: the whole frame.
  EXPECT_EQ(dataset_crop({}, 100, 80), (CropBox{0, 0, 100, 80}));
  EXPECT_EQ(dataset_crop({300, 300, 10, 10}, 100, 80), (CropBox{0, 0, 100, 80}));
  CropOptions wide;
  wide.margin = 0.5;
  EXPECT_EQ(dataset_crop({40, 30, 20, 20}, 100, 80, wide), (CropBox{30, 20, 40, 40}));
}

TEST(FitVideoCrop, ShiftedIntrinsicsKeepEveryPointOnItsContentPixel) {
  Camera cam;
  cam.width = 1280;
  cam.height = 720;
  cam.fx = cam.fy = 1100;
  cam.cx = 640;
  cam.cy = 360;
  cam.t = {0.1f, -0.2f, 3.0f};
  const CropBox box{412, 36, 360, 650};
  const Camera c = crop_camera(cam, box);
  EXPECT_EQ(c.width, 360);
  EXPECT_EQ(c.height, 650);
  EXPECT_EQ(c.fx, cam.fx);
  for (const Vec3<float> x : {Vec3<float>(0.2f, 0.5f, 0.1f), Vec3<float>(-0.3f, -0.8f, 0.4f)}) {
    const Vec2<float> full = cam.project(cam.to_camera(x)), in_crop = c.project(c.to_camera(x));
    EXPECT_NEAR(in_crop.x, full.x - box.x0, 1e-3);
    EXPECT_NEAR(in_crop.y, full.y - box.y0, 1e-3);
  }
  // The same content: a pixel drawn at a projected point of the full frame is found at
  // the projected point of the cropped camera in the crop.
  Image frame(cam.width, cam.height, 1);
  const Vec2<float> p = cam.project(cam.to_camera({0.2f, 0.5f, 0.1f}));
  frame.at(int(p.x), int(p.y), 0) = 1.0f;
  const Image cropped = crop(frame, box.x0, box.y0, box.w, box.h);
  const Vec2<float> q = c.project(c.to_camera({0.2f, 0.5f, 0.1f}));
  EXPECT_EQ(cropped.at(int(q.x), int(q.y), 0), 1.0f);
}

TEST(FitVideoCrop, ProjectedBoxOfPointsClippedToTheFrame) {
  Camera cam;
  cam.width = 100;
  cam.height = 80;
  cam.fx = cam.fy = 100;
  cam.cx = 50;
  cam.cy = 40;
  // (x, y, z) in camera = world: pixels x = 100 X / Z + 50.
  // Projected: (50, 40), (75.15, 50.25), (39.7, 10.3).
  const float pts[] = {0.0f, 0.0f, 2.0f, 0.503f, 0.205f, 2.0f, -0.103f, -0.297f, 1.0f};
  EXPECT_EQ(projected_box(cam, pts, 3), (CropBox{39, 10, 37, 41}));
  const float behind[] = {0.0f, 0.0f, -2.0f};
  EXPECT_TRUE(projected_box(cam, behind, 1).empty());
  const float outside[] = {0.0f, 0.0f, 2.0f, 5.0f, 5.0f, 1.0f};  // (50, 40) and far off the frame
  EXPECT_EQ(projected_box(cam, outside, 2), (CropBox{50, 40, 50, 40}));
}

class SourceCropDataset : public testutil::TempDirTest {};

TEST_F(SourceCropDataset, WriterAndReaderKeepIt) {
  auto write = [&](const std::string& dir, bool with_crop) {
    DatasetWriter w(dir, 6, 4, 30, "neutral", "test");
    if (with_crop) w.set_source_crop(10, 20, 6, 4);
    DatasetFrame f;
    f.camera.width = 6;
    f.camera.height = 4;
    f.camera.fx = f.camera.fy = 10;
    f.params.transl[2] = 3;
    w.add(f, Image(6, 4, 3, 0.5f), Image(6, 4, 1, 1.0f));
    w.finish();
  };
  write(path("crop"), true);
  const Dataset ds = read_dataset(path("crop"));
  EXPECT_EQ(ds.source_crop, (std::array<int, 4>{10, 20, 6, 4}));
  EXPECT_EQ(nlohmann::json::parse(read_text_file(path("crop/dataset.json")))["source_crop"],
            nlohmann::json::array({10, 20, 6, 4}));
  write_dataset(ds, path("again"));  // a copy keeps it
  EXPECT_EQ(read_dataset(path("again")).source_crop, ds.source_crop);
  write(path("plain"), false);  // none given: no key, read as none
  EXPECT_EQ(read_text_file(path("plain/dataset.json")).find("source_crop"), std::string::npos);
  EXPECT_EQ(read_dataset(path("plain")).source_crop[2], 0);

  DatasetWriter w(path("bad"), 6, 4, 30, "neutral", "test");
  testutil::expect_error([&] { w.set_source_crop(0, 0, 8, 4); }, {"source crop", "6x4"});
  testutil::expect_error([&] { w.set_source_crop(-1, 0, 6, 4); }, {"source crop"});
  const std::string json = path("crop/dataset.json"), text = read_text_file(json);
  auto with = [&](const std::string& value, const std::vector<std::string>& needles) {
    std::string t = text;
    const size_t at = t.find("[10,20,6,4]");
    ASSERT_NE(at, std::string::npos) << t;
    t.replace(at, 11, value);
    write_text_file(json, t);
    testutil::expect_error([&] { read_dataset(path("crop")); }, needles);
  };
  with("[10,20,6]", {json, "source_crop", "four"});
  with("[10,-20,6,4]", {json, "source_crop", "non-negative"});
  with("[10,20,8,4]", {json, "source_crop", "8x4", "6x4"});
}

}  // namespace
}  // namespace haha
