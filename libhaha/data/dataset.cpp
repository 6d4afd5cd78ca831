#include "data/dataset.h"

#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/parallel.h"
#include "data/stage_dir.h"
#include "io/camera_json.h"
#include "io/json_text.h"
#include "io/smplx_params_io.h"

namespace haha {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

constexpr int kDatasetVersion = 1;
constexpr const char* kDatasetFormat = "haha-dataset";

const char* split_name(Split s) {
  switch (s) {
    case Split::train: return "train";
    case Split::test: return "test";
    case Split::unseen: return "unseen";
  }
  return "?";
}

Split parse_split(const std::string& s, const std::string& where) {
  if (s == "train") return Split::train;
  if (s == "test") return Split::test;
  if (s == "unseen") return Split::unseen;
  fail(where, "split '" + s + "' is not \"train\", \"test\" or \"unseen\"");
}

const char* fits_name(Fits f) {
  return f == Fits::exact ? "exact" : f == Fits::estimated ? "estimated" : "";
}

Fits parse_fits(const std::string& s, const std::string& where) {
  if (s == "exact") return Fits::exact;
  if (s == "estimated") return Fits::estimated;
  fail(where, "'" + s + "' is neither \"exact\" nor \"estimated\"");
}

namespace {

// Camera <-> the dataset.json camera object (io/camera_json.h's keys minus the size,
// which is the dataset's).
ojson camera_object(const Camera& cam) {
  ojson j = ojson::parse(camera_to_json(cam));
  j.erase("width");
  j.erase("height");
  return j;
}

Camera parse_camera_object(const ojson& j, int width, int height, const std::string& where) {
  if (!j.is_object()) fail(where, "expected a camera object");
  ojson full = {{"width", width}, {"height", height}};
  for (const auto& [k, v] : j.items()) {
    if (k == "width" || k == "height") fail(where, k + ": the camera size is the dataset's; remove it");
    full[k] = v;
  }
  return parse_camera_json(full.dump(), where);
}

// Relative path inside the dataset directory: no absolute paths, no "..".
std::string dataset_file(const std::string& dir, const ojson& v, const std::string& where) {
  if (!v.is_string()) fail(where, "expected a relative file name");
  const std::string s = v.get<std::string>();
  const fs::path p(s);
  if (s.empty() || p.is_absolute()) fail(where, "'" + s + "' must be a path relative to the dataset directory");
  for (const auto& part : p)
    if (part == "..") fail(where, "'" + s + "' must stay inside the dataset directory (no '..')");
  return (fs::path(dir) / p).string();
}

void check_finite(const SmplxParams& p, const std::string& where) {
  auto ok = [](const float* v, size_t n) {
    for (size_t i = 0; i < n; ++i)
      if (!std::isfinite(v[i])) return false;
    return true;
  };
  if (!ok(p.pose.data(), p.pose.size()) || !ok(p.betas.data(), p.betas.size()) ||
      !ok(p.expression.data(), p.expression.size()) || !ok(p.transl.data(), 3))
    fail(where, "non-finite SMPL-X parameter");
}

// Pixels must be finite and, where the dataset's contract says so (frames and masks read
// from a dataset: RGB and coverage in [0, 1]), within [0, 1]; a float image (EXR, TIFF)
// can hold anything. The first offending pixel is named.
void check_pixels(const Image& img, const std::string& where, bool unit_range) {
  for (size_t k = 0; k < img.data.size(); ++k) {
    const float v = img.data[k];
    if (std::isfinite(v) && (!unit_range || (v >= 0.0f && v <= 1.0f))) continue;
    const size_t px = k / size_t(img.channels);
    const std::string at = "pixel (" + std::to_string(px % size_t(img.width)) + ", " +
                           std::to_string(px / size_t(img.width)) + ")";
    if (!std::isfinite(v)) fail(where, "non-finite value at " + at);
    fail(where, "value " + std::to_string(v) + " at " + at + " is outside [0, 1]");
  }
}

// First channel (grey masks; an RGB(A) mask uses its red channel).
Image first_channel(const Image& img) {
  if (img.channels == 1) return img;
  Image out(img.width, img.height, 1);
  for (size_t i = 0; i < size_t(img.width) * img.height; ++i) out.data[i] = img.data[i * size_t(img.channels)];
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Dataset

void Dataset::load_frame(int i) {
  if (i < 0 || i >= int(frames.size())) throw Error(path + ": frame " + std::to_string(i) + " out of range");
  DatasetFrame& f = frames[size_t(i)];
  if (!f.image.empty() && !f.mask.empty()) return;
  if (!loader) fail(path, "frame " + std::to_string(i) + " has no pixels and the dataset no loader");
  Image rgb, mask;
  loader(i, rgb, mask);
  const std::string& img_where = f.image_path.empty() ? path : f.image_path;
  const std::string& mask_where = f.mask_path.empty() ? path : f.mask_path;
  if (rgb.width != width || rgb.height != height || rgb.channels != 3)
    fail(img_where, "image is " + std::to_string(rgb.width) + "x" + std::to_string(rgb.height) + "x" +
                        std::to_string(rgb.channels) + ", the dataset is " + std::to_string(width) + "x" +
                        std::to_string(height) + " RGB");
  if (mask.width != width || mask.height != height || mask.channels != 1)
    fail(mask_where, "mask is " + std::to_string(mask.width) + "x" + std::to_string(mask.height) + "x" +
                         std::to_string(mask.channels) + ", the dataset is " + std::to_string(width) + "x" +
                         std::to_string(height) + " with one mask channel");
  f.image = std::move(rgb);
  f.mask = std::move(mask);
}

void Dataset::load_all() {
  const int n = int(frames.size());
  std::vector<std::string> errors(static_cast<size_t>(n));
  parallel_for_dynamic(n, [&](int64_t i) {
    try {
      load_frame(int(i));
    } catch (const std::exception& e) {
      errors[size_t(i)] = e.what();
    }
  });
  for (const std::string& e : errors)
    if (!e.empty()) throw Error(e);
}

void Dataset::unload_frame(int i) {
  frames.at(size_t(i)).image = Image();
  frames.at(size_t(i)).mask = Image();
}

std::vector<int> Dataset::indices(Split s) const {
  std::vector<int> out;
  for (int i = 0; i < int(frames.size()); ++i)
    if (frames[size_t(i)].split == s) out.push_back(i);
  return out;
}

bool Dataset::is_static_camera() const {
  for (const DatasetFrame& f : frames)
    if (camera_to_json(f.camera) != camera_to_json(frames.front().camera)) return false;
  return true;
}

// ---------------------------------------------------------------------------------------
// Reading

namespace {

// dataset.json, parsed; `where` names one of its keys in messages.
struct DatasetJson {
  std::string dir, path;
  ojson root;
  std::string where(const std::string& key) const { return path + ": " + key; }
  const ojson& require(const char* key) const {
    if (!root.contains(key)) fail(where(key), "missing");
    return root[key];
  }
};

DatasetJson read_dataset_json(const std::string& dir) {
  DatasetJson j;
  j.dir = dir;
  j.path = (fs::path(dir) / "dataset.json").string();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail(dir, "no such dataset directory");
  if (!fs::is_regular_file(j.path, ec)) fail(j.path, "missing (not a haha dataset directory)");
  std::ifstream f(j.path, std::ios::binary);
  if (!f) fail(j.path, "cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  try {
    j.root = ojson::parse(ss.str());
  } catch (const std::exception& e) {
    fail(j.path, "invalid JSON: " + json_error_message(e));
  }
  return j;
}

// Known keys only, and this format and version.
void check_header(const DatasetJson& j) {
  const ojson& root = j.root;
  if (!root.is_object()) fail(j.path, "expected a JSON object at the top level");
  for (const auto& [k, v] : root.items()) {
    (void)v;
    static const char* known[] = {"format", "version", "width", "height", "fps",        "gender",
                                  "source", "source_crop", "premultiplied", "fits", "camera", "smplx", "smplx_true", "frames"};
    bool ok = false;
    for (const char* kk : known) ok = ok || k == kk;
    if (!ok) fail(j.where(k), "unknown key");
  }
  if (!j.require("format").is_string() || root["format"].get<std::string>() != kDatasetFormat)
    fail(j.where("format"), std::string("expected \"") + kDatasetFormat + "\"");
  if (!j.require("version").is_number_integer() || root["version"].get<int64_t>() != kDatasetVersion)
    fail(j.where("version"), "unsupported version (this build reads version " + std::to_string(kDatasetVersion) + ")");
}

// The dataset-wide values: size, fps, gender, source, premultiplied, source_crop, fits.
void read_properties(const DatasetJson& j, Dataset& ds) {
  const ojson& root = j.root;
  auto size_value = [&](const char* key) {
    const ojson& v = j.require(key);
    if (!v.is_number_integer() || v.get<int64_t>() < 1 || v.get<int64_t>() > 32768)
      fail(j.where(key), "expected an integer in [1, 32768]");
    return int(v.get<int64_t>());
  };
  ds.width = size_value("width");
  ds.height = size_value("height");
  if (root.contains("fps")) {
    if (!root["fps"].is_number() || !(root["fps"].get<double>() > 0) || !std::isfinite(root["fps"].get<double>()))
      fail(j.where("fps"), "expected a positive number");
    ds.fps = root["fps"].get<double>();
  }
  if (root.contains("gender")) {
    if (!root["gender"].is_string()) fail(j.where("gender"), "expected a string");
    ds.gender = root["gender"].get<std::string>();
    if (ds.gender != "neutral" && ds.gender != "male" && ds.gender != "female")
      fail(j.where("gender"), "'" + ds.gender + "' is not neutral, male or female");
  }
  if (root.contains("source")) {
    if (!root["source"].is_string()) fail(j.where("source"), "expected a string");
    ds.source = root["source"].get<std::string>();
  }
  if (root.contains("premultiplied")) {
    if (!root["premultiplied"].is_boolean()) fail(j.where("premultiplied"), "expected true or false");
    ds.premultiplied = root["premultiplied"].get<bool>() ? 1 : 0;
  }
  if (root.contains("source_crop")) {
    const ojson& v = root["source_crop"];
    bool ok = v.is_array() && v.size() == 4;
    for (size_t k = 0; ok && k < 4; ++k)
      ok = v[k].is_number_integer() && v[k].get<int64_t>() >= 0 && v[k].get<int64_t>() <= 32768 * 4;
    if (!ok) fail(j.where("source_crop"), "expected [x0, y0, w, h]: four non-negative integers");
    for (size_t k = 0; k < 4; ++k) ds.source_crop[k] = int(v[k].get<int64_t>());
    if (ds.source_crop[2] != ds.width || ds.source_crop[3] != ds.height)
      fail(j.where("source_crop"), "box is " + std::to_string(ds.source_crop[2]) + "x" +
                                       std::to_string(ds.source_crop[3]) + ", the dataset " + std::to_string(ds.width) +
                                       "x" + std::to_string(ds.height));
  }
  if (root.contains("fits")) {
    if (!root["fits"].is_string()) fail(j.where("fits"), "expected \"exact\" or \"estimated\"");
    ds.fits = parse_fits(root["fits"].get<std::string>(), j.where("fits"));
  }
}

// One entry of "frames" (fw names it); static_cam: the top-level camera, if any.
void read_frame(const ojson& fj, const std::string& fw, const std::string& dir, const Dataset& ds,
                const Camera* static_cam, DatasetFrame& f) {
  if (!fj.is_object()) fail(fw, "expected an object");
  for (const auto& [k, v] : fj.items()) {
    (void)v;
    if (k != "image" && k != "mask" && k != "split" && k != "source_index" && k != "camera")
      fail(fw + "." + k, "unknown key");
  }
  if (!fj.contains("image")) fail(fw + ".image", "missing");
  if (!fj.contains("mask")) fail(fw + ".mask", "missing");
  f.image_path = dataset_file(dir, fj["image"], fw + ".image");
  f.mask_path = dataset_file(dir, fj["mask"], fw + ".mask");
  if (!fj.contains("split") || !fj["split"].is_string()) fail(fw + ".split", "missing (\"train\" or \"test\")");
  f.split = parse_split(fj["split"].get<std::string>(), fw + ".split");
  if (fj.contains("source_index")) {
    if (!fj["source_index"].is_number_integer()) fail(fw + ".source_index", "expected an integer");
    f.source_index = int(fj["source_index"].get<int64_t>());
  }
  if (fj.contains("camera")) f.camera = parse_camera_object(fj["camera"], ds.width, ds.height, fw + ".camera");
  else if (static_cam) f.camera = *static_cam;
  else fail(fw + ".camera", "missing (and no top-level \"camera\")");
}

// The top-level camera (if any), then the frame list.
void read_frames(const DatasetJson& j, Dataset& ds) {
  bool have_static = false;
  Camera static_cam;
  if (j.root.contains("camera")) {
    static_cam = parse_camera_object(j.root["camera"], ds.width, ds.height, j.where("camera"));
    have_static = true;
  }
  const ojson& frames = j.require("frames");
  if (!frames.is_array() || frames.empty()) fail(j.where("frames"), "expected a non-empty list of frames");
  ds.frames.resize(frames.size());
  for (size_t i = 0; i < frames.size(); ++i)
    read_frame(frames[i], j.where("frames[" + std::to_string(i) + "]"), j.dir, ds, have_static ? &static_cam : nullptr,
               ds.frames[i]);
}

// Files referenced by the frame list exist and are images of the dataset's size.
// Checked here, in order, so the first missing frame is the one reported.
void check_frame_files(const Dataset& ds, const std::string& json_path) {
  std::error_code ec;
  for (const DatasetFrame& f : ds.frames) {
    for (const std::string* p : {&f.image_path, &f.mask_path}) {
      if (!fs::is_regular_file(*p, ec))
        fail(*p, std::string("missing ") + (p == &f.image_path ? "frame image" : "mask") + " listed in " + json_path);
      const ImageInfo info = read_image_info(*p);
      if (info.width != ds.width || info.height != ds.height)
        fail(*p, "image is " + std::to_string(info.width) + "x" + std::to_string(info.height) + ", dataset.json says " +
                     std::to_string(ds.width) + "x" + std::to_string(ds.height));
    }
  }
}

// Parameters: one row per frame.
std::vector<SmplxParams> read_params(const DatasetJson& j, const char* key, size_t num_frames) {
  std::error_code ec;
  const std::string p = dataset_file(j.dir, j.root[key], j.where(key));
  if (!fs::is_regular_file(p, ec)) fail(p, std::string("missing (named by ") + j.path + " " + key + ")");
  std::vector<SmplxParams> v = read_smplx_params(p);
  if (v.size() != num_frames)
    fail(p, std::to_string(v.size()) + " frames of SMPL-X parameters, but " + j.path + " lists " +
                std::to_string(num_frames) + " frames");
  for (size_t i = 0; i < v.size(); ++i) check_finite(v[i], p + ": frame " + std::to_string(i));
  return v;
}

// The loader must not capture `ds` (it moves on return): it captures the paths.
void install_loader(Dataset& ds) {
  std::vector<std::pair<std::string, std::string>> files;
  for (const DatasetFrame& f : ds.frames) files.emplace_back(f.image_path, f.mask_path);
  ds.loader = [files = std::move(files)](int i, Image& rgb, Image& mask) {
    const auto& [img_path, mask_path] = files.at(size_t(i));
    rgb = to_rgb(read_image(img_path), img_path);
    mask = first_channel(read_image(mask_path));
    check_pixels(rgb, img_path, true);
    check_pixels(mask, mask_path, true);
  };
}

}  // namespace

Dataset read_dataset(const std::string& dir, LoadPixels load) {
  const DatasetJson j = read_dataset_json(dir);
  check_header(j);
  Dataset ds;
  ds.path = dir;
  read_properties(j, ds);
  read_frames(j, ds);
  check_frame_files(ds, j.path);
  j.require("smplx");
  const std::vector<SmplxParams> params = read_params(j, "smplx", ds.frames.size());
  for (size_t i = 0; i < params.size(); ++i) ds.frames[i].params = params[i];
  if (j.root.contains("smplx_true")) ds.params_true = read_params(j, "smplx_true", ds.frames.size());
  install_loader(ds);
  if (load == LoadPixels::all) ds.load_all();
  return ds;
}

// ---------------------------------------------------------------------------------------
// Writing

struct DatasetWriter::State {
  fs::path dir, tmp;
  int width = 0, height = 0;
  double fps = 30;
  std::string gender, source;
  ojson frames = ojson::array();
  std::vector<Camera> cameras;
  std::vector<SmplxParams> params, truth;
  int with_truth = 0;
  int premultiplied = -1;
  std::array<int, 4> source_crop{};  // w = 0: none
  Fits fits = Fits::unknown;
  bool finished = false;
};

DatasetWriter::DatasetWriter(std::string dir, int width, int height, double fps, std::string gender,
                             std::string source)
    : s_(std::make_unique<State>()) {
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  s_->dir = dir;
  s_->tmp = dir + ".tmp-" + std::to_string(::getpid());
  s_->width = width;
  s_->height = height;
  s_->fps = fps;
  s_->gender = std::move(gender);
  s_->source = std::move(source);
  if (width < 1 || height < 1 || width > 32768 || height > 32768)
    fail(dir, "dataset size " + std::to_string(width) + "x" + std::to_string(height) + " out of range");
  if (!(fps > 0) || !std::isfinite(fps)) fail(dir, "fps must be positive");
  if (s_->gender != "neutral" && s_->gender != "male" && s_->gender != "female")
    fail(dir, "gender '" + s_->gender + "' is not neutral, male or female");
  std::error_code ec;
  if (fs::exists(s_->dir, ec) && !fs::is_directory(s_->dir, ec)) fail(dir, "exists and is not a directory");
  if (!dataset_dir_replaceable(s_->dir.string()))
    fail(dir, "exists, is not empty and holds no dataset.json: refusing to replace it");
  fs::remove_all(s_->tmp, ec);
  ensure_directory((s_->tmp / "images").string());
  ensure_directory((s_->tmp / "masks").string());
  ensure_directory((s_->tmp / "smplx").string());
}

void DatasetWriter::set_premultiplied(int flag) {
  if (flag < -1 || flag > 1) fail(s_->dir.string(), "premultiplied flag must be -1, 0 or 1");
  s_->premultiplied = flag;
}

void DatasetWriter::set_fits(Fits fits) { s_->fits = fits; }

void DatasetWriter::set_source_crop(int x0, int y0, int w, int h) {
  if (x0 < 0 || y0 < 0 || w != s_->width || h != s_->height)
    fail(s_->dir.string(), "source crop [" + std::to_string(x0) + ", " + std::to_string(y0) + ", " + std::to_string(w) +
                               ", " + std::to_string(h) + "] must start at x0, y0 >= 0 and be the dataset's " +
                               std::to_string(s_->width) + "x" + std::to_string(s_->height));
  s_->source_crop = {x0, y0, w, h};
}

DatasetWriter::~DatasetWriter() {
  if (s_ && !s_->finished) {
    std::error_code ec;
    fs::remove_all(s_->tmp, ec);  // nothing half-written stays behind
  }
}

int DatasetWriter::num_frames() const { return int(s_->params.size()); }

void DatasetWriter::add(const DatasetFrame& frame, const Image& rgb_in, const Image& mask, const SmplxParams* truth) {
  const int i = num_frames();
  char name[32];
  std::snprintf(name, sizeof name, "%06d.png", i);
  const std::string img_rel = std::string("images/") + name, mask_rel = std::string("masks/") + name;
  const std::string img_final = (s_->dir / img_rel).string(), mask_final = (s_->dir / mask_rel).string();
  const std::string src = frame.image_path.empty() ? img_final : frame.image_path;
  const std::string mask_src = frame.mask_path.empty() ? mask_final : frame.mask_path;

  if (rgb_in.width != s_->width || rgb_in.height != s_->height || (rgb_in.channels != 3 && rgb_in.channels != 4))
    fail(src, "frame " + std::to_string(i) + " image is " + std::to_string(rgb_in.width) + "x" +
                  std::to_string(rgb_in.height) + "x" + std::to_string(rgb_in.channels) + ", the dataset is " +
                  std::to_string(s_->width) + "x" + std::to_string(s_->height) + " RGB");
  if (mask.width != s_->width || mask.height != s_->height || mask.channels != 1)
    fail(mask_src, "frame " + std::to_string(i) + " mask is " + std::to_string(mask.width) + "x" +
                       std::to_string(mask.height) + "x" + std::to_string(mask.channels) + ", the dataset is " +
                       std::to_string(s_->width) + "x" + std::to_string(s_->height) + " with one channel");
  const std::string frame_where =
      (s_->dir / "dataset.json").string() + ": frames[" + std::to_string(i) + "]";
  if (frame.camera.width != s_->width || frame.camera.height != s_->height)
    fail(frame_where + ".camera", "camera is " + std::to_string(frame.camera.width) + "x" +
                                      std::to_string(frame.camera.height) + ", the dataset is " +
                                      std::to_string(s_->width) + "x" + std::to_string(s_->height));
  // Round trip through the JSON form validates the camera (finite, rotation, K).
  parse_camera_object(camera_object(frame.camera), s_->width, s_->height, frame_where + ".camera");
  const std::string params_where = (s_->dir / "smplx" / "params.npz").string() + ": frame " + std::to_string(i);
  check_finite(frame.params, params_where);
  if (truth) check_finite(*truth, (s_->dir / "smplx" / "params_true.npz").string() + ": frame " + std::to_string(i));
  if (i > 0 && (truth != nullptr) != (s_->with_truth > 0))
    fail(src, "true SMPL-X parameters must be given for every frame or for none");
  check_pixels(rgb_in, src, false);  // written as PNG: the range is clamped there
  check_pixels(mask, mask_src, false);

  const Image rgb = to_rgb(rgb_in, src);
  write_image((s_->tmp / img_rel).string(), rgb);
  write_image((s_->tmp / mask_rel).string(), mask);

  ojson fj;
  fj["image"] = img_rel;
  fj["mask"] = mask_rel;
  fj["split"] = split_name(frame.split);
  if (frame.source_index >= 0) fj["source_index"] = frame.source_index;
  s_->frames.push_back(std::move(fj));
  s_->cameras.push_back(frame.camera);
  s_->params.push_back(frame.params);
  if (truth) {
    s_->truth.push_back(*truth);
    ++s_->with_truth;
  }
}

void DatasetWriter::finish() {
  State& s = *s_;
  if (s.finished) return;
  if (s.params.empty()) fail(s.dir.string(), "no frames to write");
  const fs::path json_final = s.dir / "dataset.json";
  write_smplx_params((s.tmp / "smplx" / "params.npz").string(), s.params);
  if (s.with_truth) write_smplx_params((s.tmp / "smplx" / "params_true.npz").string(), s.truth);

  bool is_static = true;
  const std::string first = camera_to_json(s.cameras.front());
  for (const Camera& c : s.cameras) is_static = is_static && camera_to_json(c) == first;
  ojson root;
  root["format"] = kDatasetFormat;
  root["version"] = kDatasetVersion;
  root["width"] = s.width;
  root["height"] = s.height;
  root["fps"] = s.fps;
  root["gender"] = s.gender;
  root["source"] = s.source;
  if (s.source_crop[2] > 0) root["source_crop"] = s.source_crop;
  if (s.premultiplied >= 0) root["premultiplied"] = s.premultiplied == 1;
  if (s.fits != Fits::unknown) root["fits"] = fits_name(s.fits);
  if (is_static) root["camera"] = camera_object(s.cameras.front());
  root["smplx"] = "smplx/params.npz";
  if (s.with_truth) root["smplx_true"] = "smplx/params_true.npz";
  if (!is_static)
    for (size_t i = 0; i < s.frames.size(); ++i) s.frames[i]["camera"] = camera_object(s.cameras[i]);
  root["frames"] = s.frames;
  // One line per top-level key and per frame: readable, and diffs stay small.
  std::string text = "{\n";
  for (auto it = root.begin(); it != root.end(); ++it) {
    text += " " + ojson(it.key()).dump() + ": ";
    if (it.key() == "frames") {
      text += "[\n";
      for (size_t i = 0; i < it->size(); ++i) text += "  " + (*it)[i].dump() + (i + 1 < it->size() ? ",\n" : "\n");
      text += " ]";
    } else {
      text += it->dump();
    }
    text += std::next(it) != root.end() ? ",\n" : "\n";
  }
  text += "}\n";
  const std::string json_tmp = (s.tmp / "dataset.json").string();
  write_atomically(json_tmp, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) fail(json_final.string(), "cannot open for writing");
    f << text;
    f.close();
    if (!f) fail(json_final.string(), "write error");
  });

  move_dir_into_place(s.tmp.string(), s.dir.string());
  s.finished = true;
}

void write_dataset(const Dataset& ds, const std::string& dir) {
  DatasetWriter w(dir, ds.width, ds.height, ds.fps, ds.gender, ds.source);
  w.set_premultiplied(ds.premultiplied);
  if (ds.source_crop[2] > 0)
    w.set_source_crop(ds.source_crop[0], ds.source_crop[1], ds.source_crop[2], ds.source_crop[3]);
  w.set_fits(ds.fits);
  if (!ds.params_true.empty() && ds.params_true.size() != ds.frames.size())
    fail(dir, std::to_string(ds.params_true.size()) + " true parameter sets for " + std::to_string(ds.frames.size()) +
                  " frames");
  for (size_t i = 0; i < ds.frames.size(); ++i) {
    const DatasetFrame& f = ds.frames[i];
    const SmplxParams* truth = ds.params_true.empty() ? nullptr : &ds.params_true[i];
    if (!f.image.empty() && !f.mask.empty()) {
      w.add(f, f.image, f.mask, truth);
    } else {
      if (!ds.loader) fail(dir, "frame " + std::to_string(i) + " has no pixels and the dataset no loader");
      Image rgb, mask;
      ds.loader(int(i), rgb, mask);
      w.add(f, rgb, mask, truth);
    }
  }
  w.finish();
}

}  // namespace haha
