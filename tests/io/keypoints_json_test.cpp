// tools/keypoints per-frame JSON (io/keypoints_json.h): the documented contract reads back
// field for field, and every kind of malformed file is one error naming the file and field.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "io/keypoints_json.h"
#include "support/expect_error.h"

using namespace haha;

namespace {

// n rows [x0 + i step, y0 + i step / 2, s].
std::string points(int n, double x0, double y0, double s, double step = 1) {
  std::string out = "[";
  for (int i = 0; i < n; ++i)
    out += (i ? ", [" : "[") + std::to_string(x0 + i * step) + ", " + std::to_string(y0 + 0.5 * i * step) + ", " +
           std::to_string(s) + "]";
  return out + "]";
}

// A frame as tools/keypoints writes it (with an extra field a later version might add).
std::string good() {
  return R"({"format": "haha-keypoints", "version": 1, "frame": "000007.png", "width": 640, "height": 480,)"
         R"( "people": 2, "score": 0.93, "body": )" + points(33, 100.25, 50, 0.75) +
         R"(, "body_world": )" + points(33, -0.3, 0.1, 0.02, 0.01) +
         R"(, "left_hand": )" + points(21, 300, 200, 0.9) + R"(, "right_hand": null,)"
         R"( "mask": "masks/000007.png", "model": "BlazePose full", "presence": 0.99})";
}

std::string edit(const std::string& from, const std::string& to) {
  std::string s = good();
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  return p == std::string::npos ? s : s.replace(p, from.size(), to);
}

void expect_bad(const std::string& text, const std::string& field, const std::string& problem = "") {
  haha::test::expect_error_at("kp/000007.json", [&] { parse_keypoints_json(text, "kp/000007.json"); }, {field, problem});
}

}  // namespace

TEST(KeypointsJson, ParsesTheDocumentedFormat) {
  const KeypointsFrame f = parse_keypoints_json(good(), "f.json");
  EXPECT_EQ(f.frame, "000007.png");
  EXPECT_EQ(f.width, 640);
  EXPECT_EQ(f.height, 480);
  EXPECT_EQ(f.people, 2);
  EXPECT_DOUBLE_EQ(f.score, 0.93);
  ASSERT_EQ(f.body.size(), size_t(kBodyKeypoints));
  EXPECT_TRUE(f.has_person());
  EXPECT_DOUBLE_EQ(f.body[blazepose::left_hip].x, 100.25 + 23);
  EXPECT_DOUBLE_EQ(f.body[blazepose::left_hip].y, 50 + 0.5 * 23);
  EXPECT_DOUBLE_EQ(f.body[blazepose::right_foot_index].score, 0.75);
  ASSERT_EQ(f.body_world.size(), size_t(kBodyKeypoints));
  EXPECT_DOUBLE_EQ(f.body_world[2][0], -0.3 + 0.02);
  EXPECT_DOUBLE_EQ(f.body_world[2][2], 0.02);
  ASSERT_EQ(f.left_hand.size(), size_t(kHandKeypoints));
  EXPECT_DOUBLE_EQ(f.left_hand[20].x, 320);
  EXPECT_TRUE(f.right_hand.empty());
  EXPECT_EQ(f.mask, "masks/000007.png");
  EXPECT_EQ(f.model, "BlazePose full");
}

TEST(KeypointsJson, NobodyHasNullBodyAndHands) {
  const std::string text =
      R"({"format": "haha-keypoints", "version": 1, "frame": "a.jpg", "width": 8, "height": 6, "people": 0,)"
      R"( "score": 0, "body": null, "body_world": null, "left_hand": null, "right_hand": null, "mask": null, "model": "m"})";
  const KeypointsFrame f = parse_keypoints_json(text, "f.json");
  EXPECT_FALSE(f.has_person());
  EXPECT_TRUE(f.body_world.empty() && f.left_hand.empty() && f.right_hand.empty() && f.mask.empty());
  // Body present while nobody was detected (and the reverse) is a contradiction.
  std::string with_body = text;
  with_body.replace(with_body.find("\"body\": null"), 12, "\"body\": " + points(33, 1, 1, 0.5, 0));
  expect_bad(with_body, "body", "people is 0");
  std::string without_body = good();
  const auto b = without_body.find("\"body\": [");
  without_body.replace(b, 9, "\"body\": null, \"unused\": [");
  expect_bad(without_body, "body", "null although people is 2");
  std::string hands_only = text;
  hands_only.replace(hands_only.find("\"left_hand\": null"), 17, "\"left_hand\": " + points(21, 1, 1, 0.5, 0));
  expect_bad(hands_only, "left_hand", "null when body is null");
}

TEST(KeypointsJson, ReadsFromAFile) {
  const auto path = std::filesystem::temp_directory_path() / ("haha_kpjson_" + std::to_string(::getpid()) + ".json");
  std::ofstream(path) << good();
  EXPECT_EQ(read_keypoints_json(path.string()).body.size(), size_t(kBodyKeypoints));
  std::filesystem::remove(path);
  haha::test::expect_error_at(path.string(), [&] { read_keypoints_json(path.string()); }, {"cannot open"});
}

TEST(KeypointsJson, RejectsMalformedFiles) {
  expect_bad("{\"format\": ", "invalid JSON");
  expect_bad("[1, 2]", "top level");
  expect_bad(edit("\"haha-keypoints\"", "\"haha-dataset\""), "format");
  expect_bad(edit("\"version\": 1", "\"version\": 2"), "version", "not supported");
  expect_bad(edit("\"version\": 1, ", ""), "version", "missing");
  expect_bad(edit("\"frame\": \"000007.png\", ", "\"frame\": \"000007.png\", \"frame\": \"x.png\", "), "frame", "duplicate");
  expect_bad(edit("\"frame\": \"000007.png\"", "\"frame\": 7"), "frame", "string");
  expect_bad(edit("\"width\": 640", "\"width\": 0"), "width", "[1, 32768]");
  expect_bad(edit("\"height\": 480", "\"height\": 480.5"), "height", "integer");
  expect_bad(edit("\"people\": 2", "\"people\": -1"), "people");
  expect_bad(edit("\"score\": 0.93", "\"score\": 1.5"), "score", "[0, 1]");
  expect_bad(edit("\"score\": 0.93", "\"score\": \"high\""), "score", "number");
  // Wrong counts, short rows, non-numbers.
  expect_bad(edit("\"body\": " + points(33, 100.25, 50, 0.75), "\"body\": " + points(32, 100.25, 50, 0.75)), "body",
             "expected 33 points, got 32");
  expect_bad(edit("\"left_hand\": " + points(21, 300, 200, 0.9), "\"left_hand\": " + points(22, 300, 200, 0.9)),
             "left_hand", "expected 21 points");
  expect_bad(edit("[100.250000, 50.000000, 0.750000]", "[100.25, 50]"), "body[0]", "3 numbers");
  expect_bad(edit("[100.250000, 50.000000, 0.750000]", "[100.25, null, 0.75]"), "body[0][1]", "number");
  expect_bad(edit("\"right_hand\": null", "\"right_hand\": {}"), "right_hand", "array");
  // Values: scores outside [0, 1], points far outside the image, world points far away.
  expect_bad(edit("[100.250000, 50.000000, 0.750000]", "[100.25, 50, 1.01]"), "body[0][2]", "[0, 1]");
  expect_bad(edit("[300.000000, 200.000000, 0.900000]", "[300, 200, -0.1]"), "left_hand[0][2]", "[0, 1]");
  expect_bad(edit("[100.250000, 50.000000, 0.750000]", "[1290, 50, 0.75]"), "body[0]", "far outside");
  expect_bad(edit("[100.250000, 50.000000, 0.750000]", "[100, -481, 0.75]"), "body[0]", "far outside");
  expect_bad(edit("[-0.300000, 0.100000, 0.020000]", "[-0.3, 0.1, 42]"), "body_world[0][2]", "far from the hips");
  // Just inside the margin is fine: BlazePose extrapolates points past the border.
  EXPECT_NO_THROW(parse_keypoints_json(edit("[100.250000, 50.000000, 0.750000]", "[-640, 960, 0.75]"), "f.json"));
  // The mask is a relative path inside the output folder.
  expect_bad(edit("\"masks/000007.png\"", "\"/etc/passwd\""), "mask", "relative");
  expect_bad(edit("\"masks/000007.png\"", "\"../masks/000007.png\""), "mask", "relative");
  expect_bad(edit("\"masks/000007.png\"", "3"), "mask", "string or null");
  expect_bad(edit("\"model\": \"BlazePose full\"", "\"model\": null"), "model", "string");
}

TEST(KeypointsJson, RejectsNonFiniteNumbers) {
  // JSON has no NaN or infinity literals, and a number too large for a double is refused
  // by the parser: no non-finite value reaches the checks.
  expect_bad(edit("[100.250000, 50.000000, 0.750000]", "[1e999, 50, 0.75]"), "invalid JSON", "overflow");
  expect_bad(edit("[100.250000, 50.000000, 0.750000]", "[NaN, 50, 0.75]"), "invalid JSON");
  expect_bad(edit("\"score\": 0.93", "\"score\": -1e999"), "invalid JSON", "overflow");
}
