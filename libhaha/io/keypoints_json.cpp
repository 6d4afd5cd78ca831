#include "io/keypoints_json.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "io/json_text.h"

namespace haha {

namespace {

using json = nlohmann::json;

std::string num(double v) { return json_num_text(v); }

double number(const json& v, const std::string& where, const std::string& key) { return json_number(v, where, key); }

double unit(const json& v, const std::string& where, const std::string& key) {
  const double d = number(v, where, key);
  if (d < 0 || d > 1) fail(where, key + ": must be in [0, 1] (got " + num(d) + ")");
  return d;
}

int integer(const json& v, const std::string& where, const std::string& key, int lo, int hi) {
  const double d = number(v, where, key);
  if (d != std::floor(d)) fail(where, key + ": must be an integer (got " + num(d) + ")");
  if (d < lo || d > hi) fail(where, key + ": must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (got " + num(d) + ")");
  return int(d);
}

const json& field(const json& root, const char* key, const std::string& where) {
  const auto it = root.find(key);
  if (it == root.end()) fail(where, std::string(key) + ": missing");
  return *it;
}

std::string text(const json& root, const char* key, const std::string& where) {
  const json& v = field(root, key, where);
  if (!v.is_string()) fail(where, std::string(key) + ": expected a string, got " + std::string(v.type_name()));
  return v.get<std::string>();
}

// A list of `count` rows [a, b, c] (null allowed: returns false).
bool rows(const json& v, int count, const std::string& where, const std::string& key) {
  if (v.is_null()) return false;
  if (!v.is_array()) fail(where, key + ": expected an array of " + std::to_string(count) + " points or null");
  if (int(v.size()) != count)
    fail(where, key + ": expected " + std::to_string(count) + " points, got " + std::to_string(v.size()));
  for (size_t i = 0; i < v.size(); ++i)
    if (!v[i].is_array() || v[i].size() != 3)
      fail(where, key + "[" + std::to_string(i) + "]: expected 3 numbers");
  return true;
}

std::vector<Keypoint2> image_points(const json& v, int count, const KeypointsFrame& f, const std::string& where,
                                    const std::string& key) {
  std::vector<Keypoint2> out;
  if (!rows(v, count, where, key)) return out;
  const double mx = kKeypointMargin * f.width, my = kKeypointMargin * f.height;
  for (int i = 0; i < count; ++i) {
    const std::string k = key + "[" + std::to_string(i) + "]";
    Keypoint2 p{number(v[i][0], where, k + "[0]"), number(v[i][1], where, k + "[1]"), unit(v[i][2], where, k + "[2]")};
    if (p.x < -mx || p.x > f.width + mx || p.y < -my || p.y > f.height + my)
      fail(where, k + ": (" + num(p.x) + ", " + num(p.y) + ") is far outside the " + std::to_string(f.width) + "x" +
                      std::to_string(f.height) + " image");
    out.push_back(p);
  }
  return out;
}

}  // namespace

KeypointsFrame parse_keypoints_json(const std::string& txt, const std::string& where) {
  const json root = parse_json_text(txt, where);
  if (!root.is_object()) fail(where, "expected a JSON object at the top level");
  if (text(root, "format", where) != "haha-keypoints") fail(where, "format: expected \"haha-keypoints\"");
  const int version = integer(field(root, "version", where), where, "version", 0, 1 << 30);
  if (version != 1) fail(where, "version: " + std::to_string(version) + " is not supported (this reader knows 1)");
  KeypointsFrame f;
  f.frame = text(root, "frame", where);
  if (f.frame.empty()) fail(where, "frame: empty image name");
  f.width = integer(field(root, "width", where), where, "width", 1, 32768);
  f.height = integer(field(root, "height", where), where, "height", 1, 32768);
  f.people = integer(field(root, "people", where), where, "people", 0, 1 << 20);
  f.score = unit(field(root, "score", where), where, "score");
  f.body = image_points(field(root, "body", where), kBodyKeypoints, f, where, "body");
  if (f.people == 0 && !f.body.empty()) fail(where, "body: must be null when people is 0");
  if (f.people > 0 && f.body.empty()) fail(where, "body: null although people is " + std::to_string(f.people));
  const json& world = field(root, "body_world", where);
  if (rows(world, kBodyKeypoints, where, "body_world")) {
    if (f.body.empty()) fail(where, "body_world: must be null when body is null");
    for (int i = 0; i < kBodyKeypoints; ++i) {
      std::array<double, 3> p{};
      for (int c = 0; c < 3; ++c) {
        const std::string k = "body_world[" + std::to_string(i) + "][" + std::to_string(c) + "]";
        p[c] = number(world[i][c], where, k);
        if (std::fabs(p[c]) > kKeypointWorldMax) fail(where, k + ": " + num(p[c]) + " m is implausibly far from the hips");
      }
      f.body_world.push_back(p);
    }
  }
  f.left_hand = image_points(field(root, "left_hand", where), kHandKeypoints, f, where, "left_hand");
  f.right_hand = image_points(field(root, "right_hand", where), kHandKeypoints, f, where, "right_hand");
  if (f.body.empty() && (!f.left_hand.empty() || !f.right_hand.empty()))
    fail(where, std::string(f.left_hand.empty() ? "right_hand" : "left_hand") + ": must be null when body is null");
  const json& mask = field(root, "mask", where);
  if (!mask.is_null()) {
    if (!mask.is_string()) fail(where, "mask: expected a string or null, got " + std::string(mask.type_name()));
    f.mask = mask.get<std::string>();
    if (f.mask.empty() || f.mask[0] == '/' || f.mask.find('\\') != std::string::npos ||
        ("/" + f.mask + "/").find("/../") != std::string::npos)
      fail(where, "mask: '" + f.mask + "' must be a relative path inside the output folder");
  }
  f.model = text(root, "model", where);
  return f;
}

KeypointsFrame read_keypoints_json(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open keypoint file");
  std::stringstream ss;
  ss << f.rdbuf();
  if (f.bad()) fail(path, "read error");
  return parse_keypoints_json(ss.str(), path);
}

}  // namespace haha
