// Image files through OpenImageIO: exact 8-bit round trips, float formats, raw integer
// depth, clear one-line errors naming the file, atomic writes. (Resampling and crops in
// memory: tests/core/image_test.cpp.)
#include <gtest/gtest.h>
#include <unistd.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.h"
#include "io/image.h"
#include "support/image_pattern.h"
#include "support/expect_error.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

class ImageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("haha_image_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  // No temporary files left next to the outputs.
  void expect_no_temporaries() const {
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  }
  fs::path dir_;
};

using haha::test::expect_error;

using haha::test::pattern;

TEST_F(ImageTest, Png8BitRoundTripIsExactForEveryChannelCount) {
  for (int c : {1, 2, 3, 4}) {
    const Image img = pattern(8, 12, c);
    const std::string p = path("p" + std::to_string(c) + ".png");
    write_image(p, img);
    const ImageInfo info = read_image_info(p);
    EXPECT_EQ(info.width, 8);
    EXPECT_EQ(info.height, 12);
    EXPECT_EQ(info.channels, c);
    const Image back = read_image(p);
    ASSERT_EQ(back.data.size(), img.data.size());
    for (size_t i = 0; i < img.data.size(); ++i) EXPECT_FLOAT_EQ(back.data[i], img.data[i]) << i;
  }
  expect_no_temporaries();
}

TEST_F(ImageTest, PngClampsOutOfRangeValues) {
  Image img(2, 1, 1);
  img.data = {-0.5f, 7.0f};
  write_image(path("c.png"), img);
  const Image back = read_image(path("c.png"));
  EXPECT_EQ(back.data[0], 0.0f);
  EXPECT_EQ(back.data[1], 1.0f);
}

TEST_F(ImageTest, FloatFormatsKeepValuesBeyondOne) {
  Image img(8, 12, 3);
  for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = float(i) * 0.37f - 5.0f;
  write_image(path("f.exr"), img, true);
  const Image exr = read_image(path("f.exr"));
  EXPECT_EQ(exr.data, img.data);
  write_image(path("h.exr"), img);  // half: 11-bit mantissa
  const Image half = read_image(path("h.exr"));
  for (size_t i = 0; i < img.data.size(); ++i) EXPECT_NEAR(half.data[i], img.data[i], 1e-3 * std::fabs(img.data[i]) + 1e-3);
  Image depth(8, 12, 1);
  for (size_t i = 0; i < depth.data.size(); ++i) depth.data[i] = 1000.0f + float(i) * 12.5f;
  write_image(path("d.tiff"), depth);
  EXPECT_EQ(read_depth(path("d.tiff")).data, depth.data);
  EXPECT_EQ(read_image(path("d.tiff")).data, depth.data);
}

TEST_F(ImageTest, JpegIsCloseAndRejectsAlpha) {
  const Image img = pattern(16, 16, 3);
  write_image(path("j.jpg"), img);
  const Image back = read_image(path("j.jpg"));
  double err = 0;
  for (size_t i = 0; i < img.data.size(); ++i) err += std::fabs(back.data[i] - img.data[i]);
  EXPECT_LT(err / double(img.data.size()), 0.2);  // a noisy pattern; just the same picture
  expect_error([&] { write_image(path("a.jpg"), pattern(4, 4, 4)); }, "a.jpg");
}

TEST_F(ImageTest, IntegerDepthIsReadWithoutNormalisation) {
  // 16-bit depth in millimetres, as depth sensors and renderers store it.
  const std::string p = path("d16.png");
  std::vector<uint16_t> v(6 * 4);
  for (size_t i = 0; i < v.size(); ++i) v[i] = uint16_t(500 + 1000 * i);
  auto out = OIIO::ImageOutput::create(p);
  ASSERT_TRUE(out);
  ASSERT_TRUE(out->open(p, OIIO::ImageSpec(6, 4, 1, OIIO::TypeDesc::UINT16)));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT16, v.data()));
  out->close();
  const Image d = read_depth(p);
  ASSERT_EQ(d.data.size(), v.size());
  for (size_t i = 0; i < v.size(); ++i) EXPECT_EQ(d.data[i], float(v[i]));
  // read_image normalises the same file.
  EXPECT_FLOAT_EQ(read_image(p).data[1], 1500.0f / 65535.0f);
}

TEST_F(ImageTest, UnreadableFilesAreOneLineErrorsNamingThem) {
  expect_error([&] { read_image(path("missing.png")); }, path("missing.png"));
  expect_error([&] { read_image_info(path("missing.png")); }, path("missing.png"));
  {
    std::ofstream f(path("garbage.png"), std::ios::binary);
    f << "this is not a png at all";
  }
  expect_error([&] { read_image(path("garbage.png")); }, path("garbage.png"));
  // A truncated PNG: header fine, pixels missing.
  write_image(path("full.png"), pattern(64, 64, 3));
  const auto size = fs::file_size(path("full.png"));
  fs::copy_file(path("full.png"), path("cut.png"));
  fs::resize_file(path("cut.png"), size / 2);
  expect_error([&] { read_image(path("cut.png")); }, path("cut.png"));
}

// A PNG whose header declares 30000 x 30000 RGB (2.7e9 float values) over a few bytes:
// refused from the header, before any pixel buffer exists.
TEST_F(ImageTest, HugeDeclaredSizeIsRefusedBeforeDecoding) {
  auto crc32 = [](const std::string& s) {
    uint32_t c = 0xFFFFFFFFu;
    for (unsigned char ch : s) {
      c ^= ch;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return c ^ 0xFFFFFFFFu;
  };
  auto be32 = [](uint32_t v) {
    return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
  };
  auto chunk = [&](const std::string& type, const std::string& data) {
    return be32(uint32_t(data.size())) + type + data + be32(crc32(type + data));
  };
  const std::string ihdr = be32(30000) + be32(30000) + std::string{8, 2, 0, 0, 0};  // 8-bit RGB
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) +
                          chunk("IDAT", std::string("\x78\x9c\x03\x00\x00\x00\x00\x01", 8)) + chunk("IEND", "");
  {
    std::ofstream f(path("huge.png"), std::ios::binary);
    f << png;
  }
  expect_error([&] { read_image(path("huge.png")); }, path("huge.png"), "image too large: 30000 x 30000 x 3");
}

TEST_F(ImageTest, FailedWritesLeaveNothing) {
  Image bad = pattern(4, 4, 3);
  bad.data[5] = std::nanf("");
  expect_error([&] { write_image(path("nan.png"), bad); }, path("nan.png"));
  EXPECT_FALSE(fs::exists(path("nan.png")));
  expect_error([&] { write_image(path("x.bmpx"), pattern(4, 4, 3)); }, "x.bmpx");
  expect_error([&] { write_image(path("no/such/dir/x.png"), pattern(4, 4, 3)); }, "x.png");
  Image wrong(4, 4, 3);
  wrong.data.resize(5);
  expect_error([&] { write_image(path("w.png"), wrong); }, path("w.png"));
  expect_no_temporaries();
  EXPECT_TRUE(fs::is_empty(dir_));
}

// Pixels handed over in memory instead of through a PNG (train_bench's frames) are the ones
// the file would give back: every 8-bit code, both sides of each rounding boundary, the
// clamped ends.
TEST_F(ImageTest, RoundTo8BitEqualsAPngRoundTrip) {
  std::vector<float> values = {-1.0f, -0.0f, 0.0f, 1.0f, 1.5f, 1e-9f, 0.99999f};
  for (int k = 0; k < 256; ++k) {
    values.push_back(k / 255.0f);
    const float edge = (k + 0.5f) / 255.0f;
    for (float v : {edge, std::nextafter(edge, 0.0f), std::nextafter(edge, 1.0f)}) values.push_back(v);
  }
  for (int i = 0; i < 4000; ++i) values.push_back(float((i * 2654435761u) % 1000003u) / 1000003.0f);
  Image img(int(values.size()), 1, 1);
  img.data = values;
  write_image(path("r.png"), img);
  const Image back = read_image(path("r.png"));
  round_to_8bit(img);
  ASSERT_EQ(back.data.size(), img.data.size());
  for (size_t i = 0; i < values.size(); ++i) ASSERT_EQ(back.data[i], img.data[i]) << "value " << values[i];
}

}  // namespace
}  // namespace haha
