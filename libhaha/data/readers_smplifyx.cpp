// SMPLify-X style per-frame pickles (docs/method.md section 6).
#include <algorithm>
#include <filesystem>
#include <map>
#include <set>

#include "core/error.h"
#include "core/text.h"
#include "data/readers.h"
#include "data/readers_common.h"
#include "io/pickle.h"

namespace haha {

namespace fs = std::filesystem;
using namespace readers;

namespace {

// All numbers of an optional key with one of the accepted sizes; empty when absent.
std::vector<double> optional_numbers(const Pickle& p, const char* key, std::initializer_list<size_t> sizes) {
  const PyObj* v = p.find(key);
  if (!v || v->kind == PyKind::none) return {};
  const std::string where = p.where() + ": " + key;
  PyNumbers n = py_numbers(*v, where);
  if (std::find(sizes.begin(), sizes.end(), n.values.size()) == sizes.end())
    fail(where, "shape " + shape_string(n.shape) + " has an unexpected number of values");
  for (double d : n.values)
    if (!std::isfinite(d)) fail(where, "non-finite value");
  return n.values;
}

Camera pickle_camera(const Pickle& p, int width, int height, double default_focal) {
  const std::vector<double> R = optional_numbers(p, "camera_rotation", {9});
  const std::vector<double> t = optional_numbers(p, "camera_translation", {3});
  std::vector<double> fx = optional_numbers(p, "camera_focal_length_x", {1});
  std::vector<double> fy = optional_numbers(p, "camera_focal_length_y", {1});
  const std::vector<double> f = optional_numbers(p, "focal_length", {1, 2});
  const std::vector<double> c = optional_numbers(p, "camera_center", {2});
  double K[9] = {default_focal, 0, width * 0.5, 0, default_focal, height * 0.5, 0, 0, 1};
  if (!f.empty()) {
    K[0] = f[0];
    K[4] = f.size() == 2 ? f[1] : f[0];
  }
  if (!fx.empty()) K[0] = fx[0];
  if (!fy.empty()) K[4] = fy[0];
  if (!c.empty()) {
    K[2] = c[0];
    K[5] = c[1];
  }
  double M[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (int r = 0; r < 3; ++r) {
    if (!R.empty())
      for (int k = 0; k < 3; ++k) M[r * 4 + k] = R[size_t(r * 3 + k)];
    if (!t.empty()) M[r * 4 + 3] = t[size_t(r)];
  }
  return camera_from_opencv(K, M, width, height, p.where() + ": camera");
}

}  // namespace

Dataset read_smplifyx(const SmplifyxOptions& opt) {
  const fs::path dir(opt.dir);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail(opt.dir, "no such directory");
  const fs::path image_dir = dir / "images", mask_dir = dir / "masks";
  if (!fs::is_directory(image_dir, ec)) fail(image_dir.string(), "missing directory");
  if (!fs::is_directory(mask_dir, ec)) fail(mask_dir.string(), "missing directory");
  const bool results_tree = fs::is_directory(dir / "results", ec);
  const fs::path fit_dir = results_tree ? dir / "results" : dir / "smplx";
  if (!fs::is_directory(fit_dir, ec))
    fail(opt.dir, "no fits: expected results/<name>/000.pkl (SMPLify-X output) or smplx/<name>.pkl");

  // Images by stem, sorted by name.
  std::map<std::string, std::string> images;
  for (const auto& e : fs::directory_iterator(image_dir, ec)) {
    const std::string ext = ascii_lower(e.path().extension().string());
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") continue;
    const std::string stem = e.path().stem().string();
    if (images.count(stem)) fail(e.path().string(), "two images named '" + stem + "' (different extensions)");
    images[stem] = e.path().string();
  }
  if (images.empty()) fail(image_dir.string(), "no .png / .jpg images");
  auto fit_path = [&](const std::string& stem) {
    return results_tree ? (fit_dir / stem / "000.pkl").string() : (fit_dir / (stem + ".pkl")).string();
  };
  auto mask_path = [&](const std::string& stem) {
    for (const char* ext : {".png", ".npy", ".jpg"}) {
      const fs::path p = mask_dir / (stem + ext);
      if (fs::is_regular_file(p, ec)) return p.string();
    }
    return std::string();
  };
  std::vector<std::string> stems;
  for (const auto& [stem, path] : images) {
    if (!fs::is_regular_file(fit_path(stem), ec)) fail(fit_path(stem), "missing (image " + path + " has no fit)");
    if (mask_path(stem).empty()) fail((mask_dir / (stem + ".png")).string(), "missing (image " + path + " has no mask)");
    stems.push_back(stem);
  }
  // Fits and masks without an image.
  for (const auto& e : fs::directory_iterator(fit_dir, ec)) {
    const std::string stem = results_tree ? e.path().filename().string() : e.path().stem().string();
    if (results_tree ? !e.is_directory() : e.path().extension() != ".pkl") continue;
    if (!images.count(stem)) fail(results_tree ? fit_path(stem) : e.path().string(), "no matching image in " + image_dir.string());
  }
  for (const auto& e : fs::directory_iterator(mask_dir, ec))
    if (!images.count(e.path().stem().string()))
      fail(e.path().string(), "no matching image in " + image_dir.string());

  Dataset ds;
  ds.path = opt.dir;
  ds.fps = opt.fps;
  ds.gender = opt.gender.empty() ? "neutral" : opt.gender;
  ds.premultiplied = 0;  // camera frames with their own background
  ds.fits = Fits::estimated;  // SMPLify-X optimises against 2D keypoints of each image
  ds.source = "SMPLify-X fits: " + opt.dir + " train " + opt.train.str() + " test " + opt.test.str();
  std::vector<std::pair<std::string, std::string>> files;
  PixelTransform tr;
  int src_w = 0, src_h = 0;
  std::set<int> used;
  for (Split split : {Split::train, Split::test}) {
    const FrameRange& range = split == Split::train ? opt.train : opt.test;
    for (int k : subsample(range.indices(int(stems.size())), opt.every, opt.max_frames)) {
      const std::string& stem = stems[size_t(k)];
      if (!used.insert(k).second) fail(images.at(stem), "selected by both the train and the test frame range");
      const std::string& img = images.at(stem);
      const ImageInfo info = read_image_info(img);
      if (src_w == 0) {
        src_w = info.width;
        src_h = info.height;
        tr = PixelTransform::make(src_w, src_h, false, opt.max_side);
        ds.width = tr.out_w;
        ds.height = tr.out_h;
      }
      if (info.width != src_w || info.height != src_h)
        fail(img, "image is " + std::to_string(info.width) + "x" + std::to_string(info.height) + ", earlier frames are " +
                      std::to_string(src_w) + "x" + std::to_string(src_h));
      const Pickle fit = Pickle::read(fit_path(stem));
      DatasetFrame f;
      f.split = split;
      f.params = smplx_params_from_pickle(fit, opt);
      f.camera = tr.apply(pickle_camera(fit, src_w, src_h, opt.focal));
      f.source_index = k;
      f.image_path = img;
      f.mask_path = mask_path(stem);
      files.emplace_back(f.image_path, f.mask_path);
      ds.frames.push_back(std::move(f));
    }
  }
  if (ds.frames.empty()) fail(opt.dir, "the frame ranges select no frames");
  ds.loader = [files = std::move(files), tr](int i, Image& rgb, Image& mask) {
    const auto& [img_path, m_path] = files.at(size_t(i));
    const Image color = read_rgb(img_path);
    const Image m = read_mask_file(m_path);
    if (m.width != color.width || m.height != color.height)
      fail(m_path, "mask is " + std::to_string(m.width) + "x" + std::to_string(m.height) + ", its image " +
                       std::to_string(color.width) + "x" + std::to_string(color.height));
    rgb = tr.apply(color);
    mask = tr.apply(m);
  };
  return ds;
}

}  // namespace haha
