// X-Humans takes (docs/method.md section 6).
#include <algorithm>
#include <filesystem>

#include "core/error.h"
#include "data/readers.h"
#include "data/readers_common.h"
#include "io/pickle.h"

namespace haha {

namespace fs = std::filesystem;
using namespace readers;

namespace {

struct TakeFrame {
  int number = 0;
  std::string color, depth, pkl;
  Camera camera;  // source size
  SmplxParams params;
};

struct Take {
  std::string dir;
  int width = 0, height = 0;
  std::vector<TakeFrame> frames;
  std::string gender;
};

Take read_take(const std::string& take_dir, const XHumansOptions& opt) {
  Take take;
  take.dir = take_dir;
  std::error_code ec;
  if (!fs::is_directory(take_dir, ec)) fail(take_dir, "no such X-Humans take directory");
  const std::string image_dir = (fs::path(take_dir) / "render" / "image").string();
  const std::string depth_dir = (fs::path(take_dir) / "render" / "depth").string();
  const std::string smplx_dir = (fs::path(take_dir) / "SMPLX").string();
  const std::string cam_path = (fs::path(take_dir) / "render" / "cameras.npz").string();

  const auto colors = list_numbered(image_dir, "color_", 6, ".png");
  const auto depths = list_numbered(depth_dir, "depth_", 6, ".tiff");
  const auto pkls = list_numbered(smplx_dir, "mesh-f", 5, "_smplx.pkl");
  if (colors.empty()) fail(image_dir, "no color_%06d.png frames");
  // Every frame has its color image, depth and fit; a file without partners is reported.
  for (const auto& [n, path] : colors) {
    if (!depths.count(n)) fail(numbered_name(depth_dir, "depth_", n, 6, ".tiff"), "missing (frame " + std::to_string(n) + " has a color image)");
    if (!pkls.count(n)) fail(numbered_name(smplx_dir, "mesh-f", n, 5, "_smplx.pkl"), "missing (frame " + std::to_string(n) + " has a color image)");
  }
  for (const auto& [n, path] : depths)
    if (!colors.count(n)) fail(path, "no matching color image " + numbered_name(image_dir, "color_", n, 6, ".png"));
  for (const auto& [n, path] : pkls)
    if (!colors.count(n)) fail(path, "no matching color image " + numbered_name(image_dir, "color_", n, 6, ".png"));

  if (!fs::is_regular_file(cam_path, ec)) fail(cam_path, "missing");
  const Npz cams = Npz::read(cam_path);
  const std::vector<double> K = npz_numbers(cams, "intrinsic", {3, 3});
  const int64_t n_frames = int64_t(colors.size());
  const NpyArray& ext = cams.get("extrinsic");
  if (ext.ndim() != 3 || ext.shape[1] != 4 || ext.shape[2] != 4)
    fail(cam_path + ": extrinsic", "shape " + shape_string(ext.shape) + ", expected (N, 4, 4)");
  if (ext.shape[0] != n_frames)
    fail(cam_path + ": extrinsic", std::to_string(ext.shape[0]) + " cameras for " + std::to_string(n_frames) +
                                       " frames in " + image_dir);
  const std::vector<double> E = npz_numbers(cams, "extrinsic", {n_frames, 4, 4});

  std::vector<int> numbers;
  for (const auto& [n, p] : colors) numbers.push_back(n);
  const std::vector<int> keep = subsample(numbers, opt.every, opt.max_frames);
  for (int n : keep) {
    const size_t row = size_t(std::distance(colors.begin(), colors.find(n)));
    TakeFrame f;
    f.number = n;
    f.color = colors.at(n);
    f.depth = depths.at(n);
    f.pkl = pkls.at(n);
    const ImageInfo ci = read_image_info(f.color);
    const ImageInfo di = read_image_info(f.depth);
    if (take.width == 0) {
      take.width = ci.width;
      take.height = ci.height;
    }
    if (ci.width != take.width || ci.height != take.height)
      fail(f.color, "image is " + std::to_string(ci.width) + "x" + std::to_string(ci.height) + ", earlier frames are " +
                        std::to_string(take.width) + "x" + std::to_string(take.height));
    if (di.width != ci.width || di.height != ci.height)
      fail(f.depth, "depth is " + std::to_string(di.width) + "x" + std::to_string(di.height) + ", its color image " +
                        std::to_string(ci.width) + "x" + std::to_string(ci.height));
    f.camera = camera_from_opencv(K.data(), E.data() + row * 16, ci.width, ci.height,
                                  cam_path + ": extrinsic[" + std::to_string(row) + "]");
    f.params = smplx_params_from_pickle(Pickle::read(f.pkl), opt);
    take.frames.push_back(std::move(f));
  }
  const std::string g = read_first_word((fs::path(take_dir).parent_path() / "gender.txt").string());
  if (g == "male" || g == "female" || g == "neutral") take.gender = g;
  return take;
}

}  // namespace

Dataset read_xhumans(const XHumansOptions& opt) {
  if (opt.train_takes.empty()) throw Error("X-Humans: no training take given");
  std::vector<std::pair<Take, Split>> takes;
  for (const auto& t : opt.train_takes) takes.emplace_back(read_take(t, opt), Split::train);
  for (const auto& t : opt.test_takes) takes.emplace_back(read_take(t, opt), Split::test);

  Dataset ds;
  ds.path = opt.train_takes.front();
  ds.fps = opt.fps;
  ds.gender = !opt.gender.empty() ? opt.gender : (!takes.front().first.gender.empty() ? takes.front().first.gender : "neutral");
  ds.source = "X-Humans:";
  // Exact: X-Humans' SMPL-X fits are registered to each frame's 3D scan, and the frames
  // (render/image) are renders of those textured scans, so the fits sit millimetres from
  // the surface in the images; nothing is estimated from one view. (The paper trains on
  // them as given, with the default settings.)
  ds.fits = Fits::exact;
  struct Src { std::string color, depth; PixelTransform tr; };
  std::vector<Src> srcs;
  for (const auto& [take, split] : takes) {
    ds.source += std::string(" ") + split_name(split) + "=" + take.dir;
    const PixelTransform tr = PixelTransform::make(take.width, take.height, opt.square_crop, opt.max_side);
    if (ds.width == 0) {
      ds.width = tr.out_w;
      ds.height = tr.out_h;
    }
    if (tr.out_w != ds.width || tr.out_h != ds.height)
      fail(take.dir, "frames become " + std::to_string(tr.out_w) + "x" + std::to_string(tr.out_h) +
                         " after crop/resize, the first take's " + std::to_string(ds.width) + "x" +
                         std::to_string(ds.height));
    for (const TakeFrame& tf : take.frames) {
      DatasetFrame f;
      f.split = split;
      f.camera = tr.apply(tf.camera);
      f.params = tf.params;
      f.source_index = tf.number;
      f.image_path = tf.color;
      f.mask_path = tf.depth;
      ds.frames.push_back(std::move(f));
      srcs.push_back({tf.color, tf.depth, tr});
    }
  }
  const float threshold = opt.depth_threshold;
  ds.loader = [srcs = std::move(srcs), threshold](int i, Image& rgb, Image& mask) {
    const Src& s = srcs.at(size_t(i));
    const Image color = read_rgb(s.color);
    const Image depth = read_depth(s.depth);
    if (color.width != depth.width || color.height != depth.height)
      fail(s.depth, "depth size differs from its color image");
    // The release's mask rule: far background has the largest depth value.
    float dmax = -std::numeric_limits<float>::infinity();
    for (float d : depth.data)
      if (std::isfinite(d)) dmax = std::max(dmax, d);
    Image m(depth.width, depth.height, 1);
    for (size_t k = 0; k < depth.data.size(); ++k)
      m.data[k] = std::isfinite(depth.data[k]) && dmax - depth.data[k] > threshold ? 1.0f : 0.0f;
    rgb = s.tr.apply(color);
    mask = s.tr.apply(m);
  };
  return ds;
}

}  // namespace haha
