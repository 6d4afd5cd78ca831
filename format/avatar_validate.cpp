#include "format/avatar_validate.h"

#include <cmath>

#include "core/error.h"

namespace haha {

namespace {

void check_size(size_t actual, size_t expected, const std::string& where, const char* name, const std::string& shape) {
  if (actual != expected) {
    fail(where, std::string(name) + ": " + std::to_string(actual) + " values, expected " + std::to_string(expected) +
                    " (" + shape + ")");
  }
}

void check_finite(const std::vector<float>& v, const std::string& where, const char* name) {
  for (size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) fail(where, std::string(name) + ": non-finite value at index " + std::to_string(i));
  }
}

void check_index(const std::vector<int32_t>& v, int64_t n, const std::string& where, const char* name, const char* of) {
  for (size_t i = 0; i < v.size(); ++i) {
    if (v[i] < 0 || v[i] >= n) {
      fail(where, std::string(name) + ": index " + std::to_string(v[i]) + " at position " + std::to_string(i) +
                      " out of range [0, " + std::to_string(n) + ") " + of);
    }
  }
}

}  // namespace

void validate_body(const BodyModel& b, const std::string& where) {
  if (b.num_verts <= 0 || b.num_faces <= 0) fail(where, "body: empty mesh");
  const size_t V = size_t(b.num_verts), F = size_t(b.num_faces);
  const std::string v3 = std::to_string(V) + " x 3";
  check_size(b.v_template.size(), V * 3, where, "body v_template", v3);
  check_size(b.faces.size(), F * 3, where, "body faces", std::to_string(F) + " x 3");
  check_size(b.parents.size(), kNumJoints, where, "body parents", "55");
  check_size(b.weights.size(), V * kNumJoints, where, "body weights", std::to_string(V) + " x 55");
  if (b.j_regressor.empty() && !b.joints_rest.empty()) {  // an unpacked avatar: joints stored, shape baked
    check_size(b.joints_rest.size(), size_t(kNumJoints) * 3, where, "body rest joints", "55 x 3");
    if (has_shape_blend(b)) fail(where, "body: fixed rest joints but shape directions (the joints would not follow the shape)");
  } else {
    check_size(b.j_regressor.size(), V * kNumJoints, where, "body J_regressor", "55 x " + std::to_string(V));
  }
  if (b.num_shape < 0 || b.num_expr < 0) fail(where, "body: negative shape/expression column count");
  if (!b.shapedirs.empty()) {
    check_size(b.shapedirs.size(), V * 3 * size_t(b.num_shape + b.num_expr), where, "body shapedirs",
               v3 + " x " + std::to_string(b.num_shape + b.num_expr));
  }
  if (!b.posedirs.empty()) check_size(b.posedirs.size(), V * 3 * kNumPoseFeatures, where, "body posedirs", v3 + " x 486");
  check_index(b.faces, b.num_verts, where, "body faces", "(vertex count)");
  if (!b.vt.empty() || !b.ft.empty()) {
    if (b.vt.size() % 2) fail(where, "body vt: odd number of values");
    check_size(b.ft.size(), F * 3, where, "body ft", std::to_string(F) + " x 3");
    check_index(b.ft, int64_t(b.vt.size() / 2), where, "body ft", "(UV count)");
  }
  if (b.parents[0] != -1) fail(where, "body parents: parents[0] must be -1");
  for (int j = 1; j < kNumJoints; ++j) {
    if (b.parents[size_t(j)] < 0 || b.parents[size_t(j)] >= j) {
      fail(where, "body parents: joint " + std::to_string(j) + " has parent " + std::to_string(b.parents[size_t(j)]) +
                      " (must be an earlier joint)");
    }
  }
  if (!b.rest_offsets.empty()) check_size(b.rest_offsets.size(), V * 3, where, "body rest_offsets", v3);
  check_finite(b.v_template, where, "body v_template");
  check_finite(b.rest_offsets, where, "body rest_offsets");
  check_finite(b.weights, where, "body weights");
  check_finite(b.j_regressor, where, "body J_regressor");
  check_finite(b.joints_rest, where, "body rest joints");
  check_finite(b.shapedirs, where, "body shapedirs");
  check_finite(b.posedirs, where, "body posedirs");
  check_finite(b.vt, where, "body vt");
  for (size_t i = 0; i < b.weights.size(); ++i) {
    if (b.weights[i] < 0) fail(where, "body weights: negative weight at vertex " + std::to_string(i / kNumJoints));
  }
}

void validate_gaussians(const BoundGaussians& g, int num_faces, const std::string& where) {
  const size_t n = g.face.size();
  check_size(g.offset.size(), n * 3, where, "gaussian offset", "N x 3");
  check_size(g.rotation.size(), n * 4, where, "gaussian rotation", "N x 4");
  check_size(g.scale.size(), n * 3, where, "gaussian scale", "N x 3");
  check_size(g.color.size(), n * 3, where, "gaussian color", "N x 3");
  check_size(g.opacity.size(), n, where, "gaussian opacity", "N");
  if (num_faces >= 0) check_index(g.face, num_faces, where, "gaussian face", "(face count)");
  check_finite(g.offset, where, "gaussian offset");
  check_finite(g.rotation, where, "gaussian rotation");
  check_finite(g.scale, where, "gaussian scale");
  check_finite(g.color, where, "gaussian color");
  check_finite(g.opacity, where, "gaussian opacity");
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      if (!(g.scale[i * 3 + k] > 0)) fail(where, "gaussian scale: non-positive value at Gaussian " + std::to_string(i));
    }
    if (!(g.opacity[i] >= 0 && g.opacity[i] <= 1)) fail(where, "gaussian opacity: outside [0, 1] at Gaussian " + std::to_string(i));
    const float* q = &g.rotation[i * 4];
    const double n2 = double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3];
    if (!(n2 > 1e-12)) fail(where, "gaussian rotation: zero quaternion at Gaussian " + std::to_string(i));
  }
}

void validate_subject(const Avatar& a, const std::string& where) {
  const Texture& t = a.texture;
  if (t.width <= 0 || t.height <= 0) fail(where, "texture: empty");
  check_size(t.rgb.size(), size_t(t.width) * t.height * 3, where, "texture",
             std::to_string(t.height) + " x " + std::to_string(t.width) + " x 3");
  check_finite(t.rgb, where, "texture");
  check_finite(a.betas, where, "betas");
  check_finite(a.expression, where, "expression");
  if (!(std::isfinite(a.face_scale_divisor) && a.face_scale_divisor > 0)) {
    fail(where, "face_scale_divisor: must be a positive finite number");
  }
  if (!(std::isfinite(a.depth_margin) && std::abs(a.depth_margin) <= kMaxDepthMargin)) {
    fail(where, "depth_margin: must be a finite number of metres in [-1, 1]");
  }
  for (float c : a.mesh_coverage)
    if (!(c >= 0.0f && c <= 1.0f)) fail(where, "mesh_coverage: values must be in [0, 1]");
}

bool has_shape_blend(const BodyModel& b) {
  if (b.num_shape + b.num_expr <= 0) return false;
  for (float x : b.shapedirs)
    if (x != 0.0f) return true;
  return false;
}

void validate_avatar(const Avatar& a, const std::string& where) {
  validate_body(a.body, where);
  validate_subject(a, where);
  if (!a.mesh_coverage.empty() && a.mesh_coverage.size() != size_t(a.body.num_verts))
    fail(where, "mesh_coverage: " + std::to_string(a.mesh_coverage.size()) + " values for " +
                    std::to_string(a.body.num_verts) + " body vertices");
  validate_gaussians(a.gaussians, a.body.num_faces, where);
}

}  // namespace haha
