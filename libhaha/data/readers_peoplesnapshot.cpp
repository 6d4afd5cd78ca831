// PeopleSnapshot as preprocessed by InstantAvatar (docs/method.md section 6).
#include <cmath>
#include <filesystem>
#include <set>

#include "core/error.h"
#include "data/readers.h"
#include "data/readers_common.h"
#include "io/smpl_model_io.h"

namespace haha {

namespace fs = std::filesystem;
using namespace readers;

Dataset read_peoplesnapshot(const PeopleSnapshotOptions& opt) {
  const fs::path dir(opt.dir);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail(opt.dir, "no such PeopleSnapshot directory");
  if (!opt.fit_smpl)
    fail(opt.dir, "its poses are SMPL fits: converting them needs the SMPL body model (--smpl-model SMPL_NEUTRAL.npz) "
                  "and the SMPL-X model (--model) to fit SMPL-X to them");
  const std::string image_dir = (dir / "images").string(), mask_dir = (dir / "masks").string();
  const std::string cam_path = (dir / "cameras.npz").string();

  const auto images = list_numbered(image_dir, "image_", 4, ".png");
  const auto masks = list_numbered(mask_dir, "mask_", 4, ".npy");
  if (images.empty()) fail(image_dir, "no image_%04d.png frames");
  for (const auto& [n, p] : images)
    if (!masks.count(n)) fail(numbered_name(mask_dir, "mask_", n, 4, ".npy"), "missing (frame " + std::to_string(n) + " has an image)");
  for (const auto& [n, p] : masks)
    if (!images.count(n)) fail(p, "no matching image " + numbered_name(image_dir, "image_", n, 4, ".png"));
  // Row i of a split belongs to the i-th sorted image of its range: gaps in the
  // numbering would silently shift every later frame.
  {
    int expect = images.begin()->first;
    for (const auto& [n, p] : images) {
      if (n != expect) fail(numbered_name(image_dir, "image_", expect, 4, ".png"), "missing (frames are numbered consecutively)");
      ++expect;
    }
  }
  std::vector<std::string> image_list, mask_list;
  for (const auto& [n, p] : images) {
    image_list.push_back(p);
    mask_list.push_back(masks.at(n));
  }

  if (!fs::is_regular_file(cam_path, ec)) fail(cam_path, "missing");
  const Npz cams = Npz::read(cam_path);
  const std::vector<double> K = npz_numbers(cams, "intrinsic", {3, 3});
  const std::vector<double> E = npz_numbers(cams, "extrinsic", {4, 4});
  const double w = npz_scalar(cams, "width"), h = npz_scalar(cams, "height");
  if (w < 1 || h < 1 || w != std::floor(w) || h != std::floor(h) || w > 32768 || h > 32768)
    fail(cam_path, "width/height " + std::to_string(w) + "x" + std::to_string(h) + " are not image sizes");
  const Camera src_cam = camera_from_opencv(K.data(), E.data(), int(w), int(h), cam_path);
  const PixelTransform tr = PixelTransform::make(int(w), int(h), false, opt.max_side);

  Dataset ds;
  ds.path = opt.dir;
  ds.width = tr.out_w;
  ds.height = tr.out_h;
  ds.fps = opt.fps;
  ds.gender = opt.gender.empty() ? "neutral" : opt.gender;
  ds.premultiplied = 0;  // camera frames with their own background
  ds.fits = Fits::estimated;  // SMPL fits to the monocular video, then fitted again to SMPL-X here
  ds.source = "PeopleSnapshot (InstantAvatar preprocessing): " + opt.dir + " train " + opt.train.str() + " test " +
              opt.test.str();
  const Camera cam = tr.apply(src_cam);
  std::vector<std::pair<std::string, std::string>> files;
  std::set<int> used;
  std::vector<SmplxParams> smpl;
  std::vector<int> source_frames;

  for (Split split : {Split::train, Split::test}) {
    const FrameRange& range = split == Split::train ? opt.train : opt.test;
    const std::string npz_path = (dir / "poses" / (std::string("anim_nerf_") + split_name(split) + ".npz")).string();
    const std::vector<int> idx = range.indices(int(image_list.size()));
    if (idx.empty()) continue;
    if (!fs::is_regular_file(npz_path, ec)) fail(npz_path, "missing");
    const Npz poses = Npz::read(npz_path);
    const int64_t n = int64_t(idx.size());
    const NpyArray& go = poses.get("global_orient");
    if (go.ndim() != 2 || go.shape[1] != 3)
      fail(npz_path + ": global_orient", "shape " + shape_string(go.shape) + ", expected (N, 3)");
    if (go.shape[0] != n)
      fail(npz_path, std::to_string(go.shape[0]) + " pose rows, but frames " + range.str() + " of the " +
                         std::to_string(image_list.size()) + " images are " + std::to_string(n) +
                         " (set the frame range of this split)");
    const std::vector<double> orient = npz_numbers(poses, "global_orient", {n, 3});
    // SMPL's 23 joints (69), or already the 21 SMPL-X body joints (63).
    const NpyArray& bp = poses.get("body_pose");
    const int64_t bw = bp.ndim() == 2 && bp.shape[1] == 63 ? 63 : 69;
    const std::vector<double> body = npz_numbers(poses, "body_pose", {n, bw});
    const std::vector<double> transl = npz_numbers(poses, "transl", {n, 3});
    std::vector<float> betas;  // SMPL shape space: given to the fit, which finds SMPL-X's
    if (poses.has("betas")) {
      const NpyArray& b = poses.get("betas");
      if (b.size() > 300 || (b.ndim() == 2 && b.shape[0] != 1) || b.ndim() > 2)
        fail(npz_path + ": betas", "shape " + shape_string(b.shape) + ", expected (1, B) or (B,)");
      for (double v : npz_numbers(poses, "betas", b.shape)) betas.push_back(float(v));
    }

    // Keep subsampling options consistent with the other readers.
    std::vector<int> rows(idx.size());
    for (size_t k = 0; k < rows.size(); ++k) rows[k] = int(k);
    for (int r : subsample(rows, opt.every, opt.max_frames)) {
      const int img = idx[size_t(r)];
      if (!used.insert(img).second)
        fail(image_list[size_t(img)], "selected by both the train and the test frame range");
      const ImageInfo info = read_image_info(image_list[size_t(img)]);
      if (info.width != int(w) || info.height != int(h))
        fail(image_list[size_t(img)], "image is " + std::to_string(info.width) + "x" + std::to_string(info.height) +
                                          ", cameras.npz says " + std::to_string(int(w)) + "x" + std::to_string(int(h)));
      DatasetFrame f;
      f.split = split;
      f.camera = cam;
      f.source_index = images.begin()->first + img;
      f.image_path = image_list[size_t(img)];
      f.mask_path = mask_list[size_t(img)];
      double pose72[72] = {};
      for (int c = 0; c < 3; ++c) pose72[c] = orient[size_t(r) * 3 + c];
      for (int c = 0; c < bw; ++c) pose72[3 + c] = body[size_t(r * bw + c)];
      smpl.push_back(smpl_params(pose72, betas, &transl[size_t(r) * 3]));
      source_frames.push_back(f.source_index);
      ds.frames.push_back(std::move(f));
      files.emplace_back(image_list[size_t(img)], mask_list[size_t(img)]);
    }
  }
  if (ds.frames.empty()) fail(opt.dir, "the frame ranges select no frames");
  const std::vector<SmplxParams> fits = opt.fit_smpl(smpl, source_frames);
  if (fits.size() != ds.frames.size()) fail(opt.dir, "the SMPL-X fit returned the wrong number of frames");
  for (size_t i = 0; i < fits.size(); ++i) ds.frames[i].params = fits[i];
  ds.loader = [files = std::move(files), tr](int i, Image& rgb, Image& mask) {
    const auto& [img_path, mask_path] = files.at(size_t(i));
    const Image color = read_rgb(img_path);
    const Image m = read_mask_npy(mask_path);
    if (m.width != color.width || m.height != color.height)
      fail(mask_path, "mask is " + std::to_string(m.width) + "x" + std::to_string(m.height) + ", its image " +
                          std::to_string(color.width) + "x" + std::to_string(color.height));
    rgb = tr.apply(color);
    mask = tr.apply(m);
  };
  return ds;
}

}  // namespace haha
