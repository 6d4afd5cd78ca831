#include "data/readers_common.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/text.h"
#include "io/camera_json.h"
#include "io/pickle.h"

namespace haha {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------
// FrameRange

std::vector<int> FrameRange::indices(int available) const {
  std::vector<int> out;
  const int stop = end < 0 ? available : std::min(end, available);
  for (int i = std::max(start, 0); i < stop; i += step) out.push_back(i);
  return out;
}

std::string FrameRange::str() const {
  return std::to_string(start) + ":" + (end < 0 ? std::string() : std::to_string(end)) + ":" + std::to_string(step);
}

FrameRange parse_frame_range(const std::string& s, const std::string& where) {
  FrameRange r;
  std::vector<std::string> parts(1);
  for (char c : s) {
    if (c == ':') parts.emplace_back();
    else parts.back() += c;
  }
  auto num = [&](const std::string& t, int fallback) {
    if (t.empty()) return fallback;
    size_t used = 0;
    int v = 0;
    try {
      v = std::stoi(t, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != t.size() || v < 0) fail(where, "'" + s + "' is not START:END[:STEP] with non-negative integers");
    return v;
  };
  if (parts.size() < 2 || parts.size() > 3) fail(where, "'" + s + "' is not START:END[:STEP]");
  r.start = num(parts[0], 0);
  r.end = num(parts[1], -1);
  r.step = parts.size() == 3 ? num(parts[2], 1) : 1;
  if (r.step < 1) fail(where, "'" + s + "': STEP must be at least 1");
  return r;
}

namespace readers {

std::map<int, std::string> list_numbered(const std::string& dir, const std::string& prefix, int digits,
                                         const std::string& suffix) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail(dir, "missing directory");
  std::map<int, std::string> out;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const std::string mid = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
    if ((digits > 0 && int(mid.size()) != digits) || mid.size() > 9 ||
        !std::all_of(mid.begin(), mid.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    out[std::stoi(mid)] = e.path().string();
  }
  if (ec) fail(dir, "cannot list directory: " + ec.message());
  return out;
}

std::string numbered_name(const std::string& dir, const std::string& prefix, int number, int digits,
                          const std::string& suffix) {
  std::string n = std::to_string(number);
  if (int(n.size()) < digits) n.insert(0, size_t(digits) - n.size(), '0');
  return (fs::path(dir) / (prefix + n + suffix)).string();
}

Camera camera_from_opencv(const double* K, const double* M, int width, int height, const std::string& where) {
  for (int i = 0; i < 9; ++i)
    if (!std::isfinite(K[i])) fail(where, "intrinsic matrix is not finite");
  for (int i = 0; i < 12; ++i)
    if (!std::isfinite(M[i])) fail(where, "extrinsic matrix is not finite");
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = float(K[0]);
  cam.fy = float(K[4]);
  cam.cx = float(K[2] + 0.5);  // OpenCV pixel centres at integers -> at +0.5
  cam.cy = float(K[5] + 0.5);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) cam.R.a[r][c] = float(M[r * 4 + c]);
    cam.t[r] = float(M[r * 4 + 3]);
  }
  if (std::fabs(K[1]) > 1e-6 * std::fabs(K[0])) fail(where, "intrinsic matrix has skew (not supported)");
  // The camera JSON round trip applies the project's camera validation (rotation, focal).
  parse_camera_json(camera_to_json(cam), where);
  return cam;
}

PixelTransform PixelTransform::make(int src_w, int src_h, bool square_crop, int max_side) {
  PixelTransform t;
  t.src_w = src_w;
  t.src_h = src_h;
  t.crop_w = src_w;
  t.crop_h = src_h;
  if (square_crop) {
    const int side = std::min(src_w, src_h);
    t.x0 = (src_w - side) / 2;
    t.y0 = (src_h - side) / 2;
    t.crop_w = t.crop_h = side;
  }
  t.out_w = t.crop_w;
  t.out_h = t.crop_h;
  if (max_side > 0) {
    const double s = double(max_side) / std::max(t.crop_w, t.crop_h);
    t.out_w = std::max(1, int(std::lround(t.crop_w * s)));
    t.out_h = std::max(1, int(std::lround(t.crop_h * s)));
  }
  return t;
}

Camera PixelTransform::apply(Camera cam) const {
  const float sx = float(out_w) / float(crop_w), sy = float(out_h) / float(crop_h);
  cam.cx = (cam.cx - float(x0)) * sx;
  cam.cy = (cam.cy - float(y0)) * sy;
  cam.fx *= sx;
  cam.fy *= sy;
  cam.width = out_w;
  cam.height = out_h;
  return cam;
}

Image PixelTransform::apply(const Image& img) const {
  Image c = (x0 == 0 && y0 == 0 && crop_w == img.width && crop_h == img.height) ? img
                                                                               : crop(img, x0, y0, crop_w, crop_h);
  if (out_w == crop_w && out_h == crop_h) return c;
  return resize_area(c, out_w, out_h);
}

Image read_mask_npy(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open mask");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const NpyArray a = parse_npy(bytes.data(), bytes.size(), path);
  std::vector<int64_t> shape = a.shape;
  if (shape.size() == 3 && shape[2] == 1) shape.pop_back();
  if (shape.size() != 2 || shape[0] < 1 || shape[1] < 1)
    fail(path, "mask has shape " + shape_string(a.shape) + ", expected (H, W) or (H, W, 1)");
  const int h = int(shape[0]), w = int(shape[1]);
  const size_t n = size_t(w) * size_t(h);
  std::vector<double> v;
  bool integer = false;
  if (a.dtype != DType::unsupported) {
    v = a.as_double();
    integer = a.dtype != DType::f32 && a.dtype != DType::f64;
  } else {
    // One-byte types npy.h does not decode (bool, uint8, int8): the data ends the file.
    const std::string d = a.descr;
    if (d != "|b1" && d != "|u1" && d != "|i1" && d != "<u1" && d != "<i1" && d != "<b1")
      fail(path, "mask dtype '" + d + "' is not bool, integer or float");
    if (bytes.size() < n) fail(path, "truncated mask data");
    const uint8_t* p = bytes.data() + bytes.size() - n;
    v.resize(n);
    for (size_t i = 0; i < n; ++i) v[i] = d[1] == 'i' ? double(int8_t(p[i])) : double(p[i]);
    integer = true;
    // Fortran order (rare for masks): transpose.
    const std::string header(reinterpret_cast<const char*>(bytes.data()), std::min<size_t>(bytes.size(), 256));
    if (header.find("'fortran_order': True") != std::string::npos) {
      std::vector<double> t(n);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) t[size_t(y) * w + x] = v[size_t(x) * h + y];
      v.swap(t);
    }
  }
  if (v.size() != n) fail(path, "mask data does not match its shape");
  double mx = 0;
  for (double x : v) {
    if (!std::isfinite(x)) fail(path, "non-finite mask value");
    mx = std::max(mx, x);
  }
  const double scale = integer && mx > 1 ? 1.0 / 255.0 : 1.0;
  Image m(w, h, 1);
  for (size_t i = 0; i < n; ++i) m.data[i] = float(std::clamp(v[i] * scale, 0.0, 1.0));
  return m;
}

Image read_mask_file(const std::string& path) {
  if (fs::path(path).extension() == ".npy") return read_mask_npy(path);
  Image img = read_image(path);
  if (img.channels == 1) return img;
  Image m(img.width, img.height, 1);
  for (size_t i = 0; i < size_t(img.width) * img.height; ++i) m.data[i] = img.data[i * size_t(img.channels)];
  return m;
}

Image read_rgb(const std::string& path) { return to_rgb(read_image(path), path); }

std::vector<int> subsample(const std::vector<int>& frames, int every, int max_frames) {
  std::vector<int> out;
  for (size_t i = 0; i < frames.size(); i += size_t(std::max(every, 1))) {
    if (max_frames > 0 && int(out.size()) >= max_frames) break;
    out.push_back(frames[i]);
  }
  return out;
}

std::string read_first_word(const std::string& path) {
  std::ifstream f(path);
  std::string w;
  if (f) f >> w;
  return ascii_lower(w);
}

}  // namespace readers

// ---------------------------------------------------------------------------------------
// SMPL-X parameters of one fit dict.

SmplxParams smplx_params_from_pickle(const Pickle& p, const ConvertOptions& opt) {
  const std::string& file = p.where();
  if (p.root().kind != PyKind::dict)
    fail(file, std::string("expected a dict of SMPL-X parameters, found a ") + py_kind_name(p.root().kind));
  // (D,) or (1, D) -> D values.
  auto row = [&](const char* key, bool required) -> std::vector<double> {
    const PyObj* v = p.find(key);
    if (!v || v->kind == PyKind::none) {
      if (required) fail(file + ": " + key, "missing");
      return {};
    }
    PyNumbers n = py_numbers(*v, file + ": " + key);
    if (!(n.shape.size() == 1 || (n.shape.size() == 2 && n.shape[0] == 1)))
      fail(file + ": " + key, "shape " + shape_string(n.shape) + ", expected (D,) or (1, D)");
    for (double d : n.values)
      if (!std::isfinite(d)) fail(file + ": " + key, "non-finite value");
    return n.values;
  };
  struct Group { const char* key; int first; int joints; bool required; };
  static const Group groups[] = {
      {"global_orient", kGlobalOrient, 1, true},    {"body_pose", kBodyFirst, 21, true},
      {"jaw_pose", kJaw, 1, false},                 {"leye_pose", kLeftEye, 1, false},
      {"reye_pose", kRightEye, 1, false},           {"left_hand_pose", kLeftHandFirst, 15, false},
      {"right_hand_pose", kRightHandFirst, 15, false},
  };
  SmplxParams out;
  for (const Group& g : groups) {
    const std::vector<double> v = row(g.key, g.required);
    const std::string where = file + ": " + g.key;
    float* dst = out.pose.data() + 3 * g.first;
    const bool hand = g.joints == 15;
    const int full = 3 * g.joints;
    if (v.empty()) {
      // absent: rest pose
    } else if (int(v.size()) == full) {
      for (int c = 0; c < full; ++c) dst[c] = float(v[size_t(c)]);
    } else if (hand && v.size() < 45) {
      const std::vector<float>* comp =
          opt.model ? (g.first == kLeftHandFirst ? &opt.model->hands_components_l : &opt.model->hands_components_r)
                    : nullptr;
      if (!comp || comp->size() != 45 * 45)
        fail(where, std::to_string(v.size()) + " PCA coefficients need a body model with hand components (--body)");
      for (int c = 0; c < 45; ++c) {
        double acc = 0;
        for (size_t q = 0; q < v.size(); ++q) acc += v[q] * (*comp)[q * 45 + size_t(c)];
        dst[c] = float(acc);
      }
    } else if (g.first == kBodyFirst && v.size() == 32) {
      fail(where, "32 values: a VPoser latent code, not axis-angle (decode it with VPoser first)");
    } else {
      fail(where, std::to_string(v.size()) + " values, expected " + std::to_string(full) +
                      (hand ? " (axis-angle) or fewer (PCA)" : ""));
    }
    if (hand && !opt.flat_hand_mean) {
      const std::vector<float>* mean =
          opt.model ? (g.first == kLeftHandFirst ? &opt.model->hands_mean_l : &opt.model->hands_mean_r) : nullptr;
      if (!mean || mean->size() != 45) fail(where, "a non-flat hand mean needs a body model with hands_mean (--body)");
      for (int c = 0; c < 45; ++c) dst[c] += (*mean)[size_t(c)];
    }
  }
  for (double b : row("betas", false)) out.betas.push_back(float(b));
  for (double e : row("expression", false)) out.expression.push_back(float(e));
  const std::vector<double> t = row("transl", false);
  if (!t.empty()) {
    if (t.size() != 3) fail(file + ": transl", std::to_string(t.size()) + " values, expected 3");
    for (int c = 0; c < 3; ++c) out.transl[size_t(c)] = float(t[size_t(c)]);
  }
  if (opt.model && int(out.betas.size()) > opt.model->num_shape)
    fail(file + ": betas", std::to_string(out.betas.size()) + " values, the body model has " +
                               std::to_string(opt.model->num_shape));
  if (opt.model && int(out.expression.size()) > opt.model->num_expr)
    fail(file + ": expression", std::to_string(out.expression.size()) + " values, the body model has " +
                                    std::to_string(opt.model->num_expr));
  return out;
}

}  // namespace haha
