#include "io/camera_json.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/json_text.h"

namespace haha {

namespace {

using json = nlohmann::json;

struct RawCamera {
  double width = 0, height = 0;
  double K[3][3] = {};
  double M[4][4] = {};
  double near_plane = 0.01, far_plane = 100;
};

std::string num(double v) { return json_num_text(v); }

double number(const json& v, const std::string& where, const std::string& key) { return json_number(v, where, key); }

void matrix(const json& v, int rows, int cols, double* out, const std::string& where, const std::string& key) {
  const std::string shape = std::to_string(rows) + "x" + std::to_string(cols);
  if (!v.is_array() || int(v.size()) != rows)
    fail(where, key + ": expected a " + shape + " array of arrays (" + std::to_string(rows) + " rows)");
  for (int r = 0; r < rows; ++r) {
    const json& row = v[r];
    if (!row.is_array() || int(row.size()) != cols)
      fail(where, key + ": row " + std::to_string(r) + " must hold " + std::to_string(cols) + " numbers (" + shape +
                      " expected)");
    for (int c = 0; c < cols; ++c)
      out[r * cols + c] = number(row[c], where, key + "[" + std::to_string(r) + "][" + std::to_string(c) + "]");
  }
}

int size_value(double v, const std::string& where, const std::string& key) {
  if (v != std::floor(v)) fail(where, key + ": must be an integer (got " + num(v) + ")");
  if (v < 1 || v > 32768) fail(where, key + ": must be in [1, 32768] (got " + num(v) + ")");
  return int(v);
}

void validate(const RawCamera& c, const std::string& where) {
  size_value(c.width, where, "width");
  size_value(c.height, where, "height");
  const double fx = c.K[0][0], fy = c.K[1][1];
  if (!(fx > 0)) fail(where, "K: focal length K[0][0] must be > 0 (got " + num(fx) + ")");
  if (!(fy > 0)) fail(where, "K: focal length K[1][1] must be > 0 (got " + num(fy) + ")");
  if (std::fabs(c.K[0][1]) > 1e-6 * fx) fail(where, "K: skew K[0][1] = " + num(c.K[0][1]) + " is not supported (must be 0)");
  if (std::fabs(c.K[1][0]) > 1e-6 * fy) fail(where, "K: K[1][0] must be 0 (got " + num(c.K[1][0]) + ")");
  if (std::fabs(c.K[2][0]) > 1e-6 || std::fabs(c.K[2][1]) > 1e-6 || std::fabs(c.K[2][2] - 1) > 1e-6)
    fail(where, "K: third row must be [0, 0, 1]");
  if (std::fabs(c.M[3][0]) > 1e-6 || std::fabs(c.M[3][1]) > 1e-6 || std::fabs(c.M[3][2]) > 1e-6 ||
      std::fabs(c.M[3][3] - 1) > 1e-6)
    fail(where, "world_to_camera: last row must be [0, 0, 0, 1]");
  double err = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += c.M[i][k] * c.M[j][k];
      err = std::max(err, std::fabs(s - (i == j ? 1.0 : 0.0)));
    }
  if (err > kCameraRotationTol)
    fail(where, "world_to_camera: rotation block is not orthonormal (max |R R^T - I| = " + num(err) + " > " +
                    num(kCameraRotationTol) + ")");
  const double det = c.M[0][0] * (c.M[1][1] * c.M[2][2] - c.M[1][2] * c.M[2][1]) -
                     c.M[0][1] * (c.M[1][0] * c.M[2][2] - c.M[1][2] * c.M[2][0]) +
                     c.M[0][2] * (c.M[1][0] * c.M[2][1] - c.M[1][1] * c.M[2][0]);
  if (!(det > 0)) fail(where, "world_to_camera: rotation block is a reflection (det < 0)");
  if (!(c.near_plane > 0) || !std::isfinite(c.near_plane)) fail(where, "near: must be > 0 (got " + num(c.near_plane) + ")");
  if (!(c.far_plane > c.near_plane) || !std::isfinite(c.far_plane))
    fail(where, "far: must be finite and > near (got " + num(c.far_plane) + ")");
}

Camera to_camera(const RawCamera& c) {
  Camera cam;
  cam.width = int(c.width);
  cam.height = int(c.height);
  cam.fx = float(c.K[0][0]);
  cam.fy = float(c.K[1][1]);
  cam.cx = float(c.K[0][2]);
  cam.cy = float(c.K[1][2]);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) cam.R.a[i][j] = float(c.M[i][j]);
    cam.t[i] = float(c.M[i][3]);
  }
  cam.near_plane = float(c.near_plane);
  cam.far_plane = float(c.far_plane);
  return cam;
}

RawCamera from_camera(const Camera& cam) {
  RawCamera c;
  c.width = cam.width;
  c.height = cam.height;
  c.K[0][0] = cam.fx;
  c.K[0][2] = cam.cx;
  c.K[1][1] = cam.fy;
  c.K[1][2] = cam.cy;
  c.K[2][2] = 1;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) c.M[i][j] = cam.R.a[i][j];
    c.M[i][3] = cam.t[i];
  }
  c.M[3][3] = 1;
  c.near_plane = cam.near_plane;
  c.far_plane = cam.far_plane;
  return c;
}

std::string fnum(float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace

Camera parse_camera_json(const std::string& text, const std::string& where) {
  const json root = parse_json_text(text, where);
  if (!root.is_object()) fail(where, "expected a JSON object at the top level");
  for (const auto& [k, v] : root.items()) {
    (void)v;
    if (k != "width" && k != "height" && k != "K" && k != "world_to_camera" && k != "near" && k != "far")
      fail(where, k + ": unknown key (expected width, height, K, world_to_camera, near, far)");
  }
  for (const char* k : {"width", "height", "K", "world_to_camera"})
    if (!root.contains(k)) fail(where, std::string(k) + ": missing");
  RawCamera c;
  c.width = number(root["width"], where, "width");
  c.height = number(root["height"], where, "height");
  matrix(root["K"], 3, 3, &c.K[0][0], where, "K");
  matrix(root["world_to_camera"], 4, 4, &c.M[0][0], where, "world_to_camera");
  if (root.contains("near")) c.near_plane = number(root["near"], where, "near");
  if (root.contains("far")) c.far_plane = number(root["far"], where, "far");
  validate(c, where);
  return to_camera(c);
}

Camera read_camera_json(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open camera file");
  std::stringstream ss;
  ss << f.rdbuf();
  if (f.bad()) fail(path, "read error");
  return parse_camera_json(ss.str(), path);
}

std::string camera_to_json(const Camera& cam) {
  std::string s = "{\n  \"width\": " + std::to_string(cam.width) + ",\n  \"height\": " + std::to_string(cam.height);
  s += ",\n  \"K\": [[" + fnum(cam.fx) + ", 0, " + fnum(cam.cx) + "], [0, " + fnum(cam.fy) + ", " + fnum(cam.cy) +
       "], [0, 0, 1]],\n  \"world_to_camera\": [";
  for (int i = 0; i < 3; ++i)
    s += "[" + fnum(cam.R.a[i][0]) + ", " + fnum(cam.R.a[i][1]) + ", " + fnum(cam.R.a[i][2]) + ", " + fnum(cam.t[i]) +
         "], ";
  s += "[0, 0, 0, 1]],\n  \"near\": " + fnum(cam.near_plane) + ",\n  \"far\": " + fnum(cam.far_plane) + "\n}\n";
  return s;
}

void write_camera_json(const std::string& path, const Camera& cam) {
  const RawCamera raw = from_camera(cam);
  for (const double* v = &raw.K[0][0]; v != &raw.K[0][0] + 9; ++v)
    if (!std::isfinite(*v)) fail(path, "K: camera intrinsics are not finite");
  for (const double* v = &raw.M[0][0]; v != &raw.M[0][0] + 16; ++v)
    if (!std::isfinite(*v)) fail(path, "world_to_camera: camera pose is not finite");
  validate(raw, path);
  const std::string text = camera_to_json(cam);
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) fail(path, "cannot open for writing");
    f << text;
    f.close();
    if (!f) fail(path, "write error");
  });
}

}  // namespace haha
