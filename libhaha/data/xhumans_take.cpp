// A dataset as X-Humans takes (data/xhumans_take.h).
#include "data/xhumans_take.h"

#include <cstdio>
#include <filesystem>

#include "body/lbs.h"
#include "core/error.h"
#include "io/image.h"
#include "io/npy.h"
#include "io/pickle_write.h"

namespace haha {

namespace fs = std::filesystem;

void write_xhumans_take(Dataset& ds, Split split, const BodyModel& body, const std::string& take_dir,
                        const XHumansTakeOptions& opt) {
  const std::vector<int> idx = ds.indices(split);
  if (idx.empty()) fail(take_dir, std::string("the dataset has no ") + split_name(split) + " frames");
  const int W = ds.width, H = ds.height;
  if (W > opt.width || H > opt.height || (opt.width - W) % 2 || (opt.height - H) % 2)
    fail(take_dir, std::to_string(W) + "x" + std::to_string(H) + " frames do not sit centred on a " +
                       std::to_string(opt.width) + "x" + std::to_string(opt.height) + " canvas");
  const int x0 = (opt.width - W) / 2, y0 = (opt.height - H) / 2;
  const Camera& c0 = ds.frames[size_t(idx[0])].camera;
  for (int i : idx) {
    const Camera& c = ds.frames[size_t(i)].camera;
    if (c.fx != c0.fx || c.fy != c0.fy || c.cx != c0.cx || c.cy != c0.cy)
      fail(take_dir, "frame " + std::to_string(i) + " has other intrinsics: an X-Humans take has one");
  }
  const fs::path root(take_dir);
  for (const char* sub : {"render/image", "render/depth", "SMPLX"}) fs::create_directories(root / sub);

  const Lbs<float> lbs(body);
  std::vector<float> verts(size_t(body.num_verts) * 3), joints(kNumJoints * 3);
  std::vector<double> extrinsic;
  for (size_t k = 0; k < idx.size(); ++k) {
    const int i = idx[k], number = int(k) + 1;
    ds.load_frame(i);
    DatasetFrame& f = ds.frames[size_t(i)];
    char name[64];
    Image color(opt.width, opt.height, 3);
    Image depth(opt.width, opt.height, 1);
    lbs.forward(f.params, verts.data(), joints.data(), nullptr);
    const Vec3f pelvis = f.camera.to_camera(Vec3f(joints[0], joints[1], joints[2]));
    const float near_mm = 1000.0f * pelvis.z, far_mm = near_mm + float(opt.far_mm);
    std::fill(depth.data.begin(), depth.data.end(), far_mm);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t src = size_t(y) * size_t(W) + size_t(x), dst = size_t(y + y0) * size_t(opt.width) + size_t(x + x0);
        for (int ch = 0; ch < 3; ++ch) color.data[dst * 3 + size_t(ch)] = f.image.data[src * 3 + size_t(ch)];
        if (f.mask.data[src] >= 0.5f) depth.data[dst] = near_mm;
      }
    std::snprintf(name, sizeof name, "color_%06d.png", number);
    write_image((root / "render/image" / name).string(), color);
    std::snprintf(name, sizeof name, "depth_%06d.tiff", number);
    write_image((root / "render/depth" / name).string(), depth);

    // The fit, as X-Humans pickles it (10 betas, 10 expression values).
    const SmplxParams& p = f.params;
    auto range = [&](int joint, int n) { return std::vector<float>(p.pose.begin() + 3 * joint, p.pose.begin() + 3 * (joint + n)); };
    auto padded = [](const std::vector<float>& v, size_t n) {
      std::vector<float> out(n, 0.0f);
      for (size_t j = 0; j < std::min(n, v.size()); ++j) out[j] = v[j];
      return out;
    };
    for (size_t j = 10; j < p.betas.size(); ++j)
      if (p.betas[j] != 0.0f) fail(take_dir, "frame " + std::to_string(i) + " has more than the 10 betas X-Humans stores");
    for (size_t j = 10; j < p.expression.size(); ++j)
      if (p.expression[j] != 0.0f) fail(take_dir, "frame " + std::to_string(i) + " has more than 10 expression values");
    std::snprintf(name, sizeof name, "mesh-f%05d_smplx.pkl", number);
    write_pickle_float_arrays((root / "SMPLX" / name).string(),
                              {{"global_orient", range(kGlobalOrient, 1), {}},
                               {"transl", std::vector<float>(p.transl.begin(), p.transl.end()), {}},
                               {"body_pose", range(kBodyFirst, 21), {}},
                               {"left_hand_pose", range(kLeftHandFirst, 15), {}},
                               {"right_hand_pose", range(kRightHandFirst, 15), {}},
                               {"jaw_pose", range(kJaw, 1), {}},
                               {"leye_pose", range(kLeftEye, 1), {}},
                               {"reye_pose", range(kRightEye, 1), {}},
                               {"expression", padded(p.expression, 10), {}},
                               {"betas", padded(p.betas, 10), {}}});
    const Camera& c = f.camera;
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) extrinsic.push_back(c.R.a[r][col]);
      extrinsic.push_back(c.t[r]);
    }
    for (double v : {0.0, 0.0, 0.0, 1.0}) extrinsic.push_back(v);
    f.image = Image();  // frames stream: keep one in memory at a time
    f.mask = Image();
  }
  // OpenCV intrinsics: pixel centres at integers (ours at +0.5), shifted by the padding.
  Npz cams;
  cams.set("intrinsic", NpyArray::from(std::vector<double>{c0.fx, 0, double(c0.cx) - 0.5 + x0, 0, c0.fy,
                                                            double(c0.cy) - 0.5 + y0, 0, 0, 1},
                                       {3, 3}));
  cams.set("extrinsic", NpyArray::from(extrinsic, {int64_t(idx.size()), 4, 4}));
  cams.write((root / "render/cameras.npz").string());
}

}  // namespace haha
