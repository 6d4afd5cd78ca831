// cam.json reading/writing: exact round trip, defaults, and one clear error per kind of
// malformed file (naming the file and the key).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "io/camera_json.h"
#include "support/data_test_util.h"
#include "support/expect_error.h"

using namespace haha;

namespace {

const char* kGood = R"({"width": 640, "height": 480,
  "K": [[500, 0, 320.5], [0, 505, 240.25], [0, 0, 1]],
  "world_to_camera": [[1, 0, 0, 0.1], [0, 0.8, -0.6, 0.2], [0, 0.6, 0.8, 3], [0, 0, 0, 1]]})";

// Replaces the first occurrence of `from` in the good file.
std::string edit(const std::string& from, const std::string& to) {
  std::string s = kGood;
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  return s.replace(p, from.size(), to);
}

// Parsing `text` fails with a message that starts with the file name and contains `what`.
void expect_error(const std::string& text, const std::string& what) {
  haha::test::expect_error_at("cams/cam.json", [&] { parse_camera_json(text, "cams/cam.json"); }, {what});
}

}  // namespace

TEST(CameraJson, ParsesTheDocumentedFormat) {
  const Camera c = parse_camera_json(kGood, "cam.json");
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_EQ(c.fx, 500.0f);
  EXPECT_EQ(c.fy, 505.0f);
  EXPECT_EQ(c.cx, 320.5f);
  EXPECT_EQ(c.cy, 240.25f);
  EXPECT_EQ(c.R.a[1][2], -0.6f);
  EXPECT_EQ(c.R.a[2][1], 0.6f);
  EXPECT_EQ(c.t.z, 3.0f);
  EXPECT_EQ(c.near_plane, 0.01f);  // defaults
  EXPECT_EQ(c.far_plane, 100.0f);
  const Camera d = parse_camera_json(edit("\"width\"", "\"near\": 0.5, \"far\": 20, \"width\""), "cam.json");
  EXPECT_EQ(d.near_plane, 0.5f);
  EXPECT_EQ(d.far_plane, 20.0f);
  EXPECT_EQ(parse_camera_json(edit("640", "640.0"), "cam.json").width, 640);  // integral float
}

using CameraJsonFiles = haha::testutil::TempDirTest;  // removes its folder afterwards

TEST_F(CameraJsonFiles, WriteReadRoundTripIsExact) {
  Camera c;
  c.width = 543;
  c.height = 321;
  c.fx = 612.345678f;
  c.fy = 611.1f;
  c.cx = 271.3f;
  c.cy = 160.7f;
  // A rotation about an oblique axis (float-rounded, well within the tolerance).
  const double ang = 0.7, ax[3] = {0.48, 0.6, 0.64};
  const double s = std::sin(ang), co = std::cos(ang);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double v = (1 - co) * ax[i] * ax[j] + (i == j ? co : 0);
      if (i != j) {
        const int k = 3 - i - j;
        const double sign = ((i + 1) % 3 == j) ? -1 : 1;
        v += sign * s * ax[k];
      }
      c.R.a[i][j] = float(v);
    }
  c.t = Vec3f(0.123456789f, -1e-5f, 2.5f);
  c.near_plane = 0.05f;
  c.far_plane = 12.5f;
  const std::string file = path("cam.json");
  write_camera_json(file, c);
  const Camera d = read_camera_json(file);
  EXPECT_EQ(d.width, c.width);
  EXPECT_EQ(d.height, c.height);
  EXPECT_EQ(d.fx, c.fx);
  EXPECT_EQ(d.fy, c.fy);
  EXPECT_EQ(d.cx, c.cx);
  EXPECT_EQ(d.cy, c.cy);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) EXPECT_EQ(d.R.a[i][j], c.R.a[i][j]);
    EXPECT_EQ(d.t[i], c.t[i]);
  }
  EXPECT_EQ(d.near_plane, c.near_plane);
  EXPECT_EQ(d.far_plane, c.far_plane);
}

TEST(CameraJson, MalformedFilesGiveClearErrors) {
  expect_error("{\"width\": 640,", "invalid JSON");
  expect_error(edit("500", "NaN"), "invalid JSON");
  expect_error("[1, 2]", "expected a JSON object");
  expect_error(edit("\"width\": 640, ", ""), "width: missing");
  expect_error(edit("\"width\"", "\"widht\": 3, \"width\""), "widht: unknown key");
  expect_error(edit("\"height\": 480", "\"height\": 480, \"height\": 481"), "height: duplicate key");
  expect_error(edit("640", "\"640\""), "width: expected a number");
  expect_error(edit("640", "640.5"), "width: must be an integer");
  expect_error(edit("640", "0"), "width: must be in [1, 32768]");
  expect_error(edit("480", "-3"), "height: must be in [1, 32768]");
  expect_error(edit("480", "true"), "height: expected a number");
  expect_error(edit("[[500, 0, 320.5], [0, 505, 240.25], [0, 0, 1]]", "[[500, 0, 320.5], [0, 505, 240.25]]"),
               "K: expected a 3x3 array");
  expect_error(edit("[0, 505, 240.25]", "[0, 505]"), "K: row 1 must hold 3 numbers");
  expect_error(edit("500", "0"), "K: focal length K[0][0] must be > 0");
  expect_error(edit("505", "-505"), "K: focal length K[1][1] must be > 0");
  expect_error(edit("[[500, 0,", "[[500, 2,"), "K: skew K[0][1]");
  expect_error(edit("[0, 0, 1]]", "[0, 0, 2]]"), "K: third row");
  expect_error(edit("[0, 0, 0, 1]]", "[0, 0, 0, 1], [0, 0, 0, 1]]"), "world_to_camera: expected a 4x4");
  expect_error(edit("[0, 0, 0, 1]]", "[0, 0.1, 0, 1]]"), "world_to_camera: last row");
  expect_error(edit("[1, 0, 0, 0.1]", "[1.01, 0, 0, 0.1]"), "world_to_camera: rotation block is not orthonormal");
  expect_error(edit("[1, 0, 0, 0.1]", "[-1, 0, 0, 0.1]"), "world_to_camera: rotation block is a reflection");
  expect_error(edit("[0, 0.6, 0.8, 3]", "[0, 0.6, 0.8, \"x\"]"), "world_to_camera[2][3]: expected a number");
  expect_error(edit("\"width\"", "\"near\": 0, \"width\""), "near: must be > 0");
  expect_error(edit("\"width\"", "\"near\": 2, \"far\": 1, \"width\""), "far: must be finite and > near");
  expect_error(edit("3]", "1e999]"), "invalid JSON");  // overflows a double
}

TEST(CameraJson, RotationToleranceIsAsDocumented) {
  // A perturbation of 2e-5 in one entry passes (max |R R^T - I| ~ 4e-5 < 1e-4); 1e-4 fails.
  EXPECT_NO_THROW(parse_camera_json(edit("[1, 0, 0, 0.1]", "[1.00002, 0, 0, 0.1]"), "cam.json"));
  EXPECT_THROW(parse_camera_json(edit("[1, 0, 0, 0.1]", "[1.0001, 0, 0, 0.1]"), "cam.json"), Error);
}

TEST_F(CameraJsonFiles, FileErrorsAndAtomicWrite) {
  try {
    read_camera_json("/nonexistent/dir/cam.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/cam.json: cannot open"), std::string::npos);
  }
  // Writing an invalid camera fails, names the file and leaves the existing file untouched.
  const std::string file = path("keep.json");
  Camera good = parse_camera_json(kGood, "x");
  write_camera_json(file, good);
  Camera bad = good;
  bad.fx = 0;
  try {
    write_camera_json(file, bad);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(file + ": K:", 0), 0u) << e.what();
  }
  bad = good;
  bad.t.x = NAN;
  EXPECT_THROW(write_camera_json(file, bad), Error);
  EXPECT_EQ(read_camera_json(file).fx, 500.0f);
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(file).parent_path()))
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos) << "leftover " << entry.path();
}
