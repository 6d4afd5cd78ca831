// A PeopleSnapshot subject in InstantAvatar's layout (ROOT/SUBJECT/images/image_%04d.png,
// masks/mask_%04d.npy, cameras.npz, poses/anim_nerf_{train,test}.npz; docs/data.md) whose
// poses are SMPL fits of the SMPL-layout stand-in of the procedural body (body/smpl_standin.h:
// known template shift and shape), with the models `haha convert --from peoplesnapshot` needs
// beside it: ROOT/smplx.npz (the procedural body), ROOT/smpl.npz (the stand-in) and
// ROOT/corr.npz (smpl_to_smplx). Images are a fixed pattern, masks a centred rectangle; the
// pose files hold `train_rows` and `test_rows` random SMPL poses (hands at rest).
#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "body/procedural_body.h"
#include "body/smpl_standin.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/npy.h"
#include "io/smpl_model_io.h"

namespace haha::test {

struct PeopleSnapshotStandinOptions {
  std::string subject = "male-3-casual";
  int width = 16, height = 12;  // images; the camera's focal length scales with the width
  int frames = 6;               // image_0000.png ... numbered consecutively
  int train_rows = 2, test_rows = 1;
};

struct PeopleSnapshotStandin {
  std::filesystem::path subject, smplx, smpl, corr;  // ROOT/SUBJECT and the three model files
  SmplStandinOptions standin;                        // the stand-in's known offsets
  std::vector<std::array<double, 3>> transl;         // SMPL transl per pose row, train rows first
};

inline PeopleSnapshotStandin make_peoplesnapshot_standin(const std::filesystem::path& root,
                                                         const PeopleSnapshotStandinOptions& o = {}) {
  namespace fs = std::filesystem;
  PeopleSnapshotStandin r;
  r.subject = root / o.subject;
  r.smplx = root / "smplx.npz";
  r.smpl = root / "smpl.npz";
  r.corr = root / "corr.npz";
  for (const char* sub : {"images", "masks", "poses"}) fs::create_directories(r.subject / sub);

  const BodyModel smplx = make_procedural_body({BodyResolution::low, 2});
  save_body_model(smplx, r.smplx.string());
  r.standin.betas = {0.5f, -0.4f, 0.3f};
  r.standin.shift = {-0.015f, 0.022f, 0.01f};
  std::vector<int32_t> corr;
  save_smpl_model(make_smpl_standin(smplx, r.standin, &corr), r.smpl.string());
  Npz c;
  c.set("smpl_to_smplx", NpyArray::from(corr, {int64_t(corr.size())}));
  c.write(r.corr.string());

  const int W = o.width, H = o.height;
  for (int i = 0; i < o.frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "image_%04d.png", i);
    Image img(W, H, 3);
    for (size_t k = 0; k < img.data.size(); ++k) img.data[k] = float((k * 7 + size_t(i)) % 11) / 10.0f;
    write_image((r.subject / "images" / name).string(), img);
    std::snprintf(name, sizeof name, "mask_%04d.npy", i);
    std::vector<float> m(size_t(W * H), 0.0f);
    for (int y = H / 4; y < 3 * H / 4; ++y)
      for (int x = 5 * W / 16; x < 11 * W / 16; ++x) m[size_t(y * W + x)] = 1.0f;
    write_npy((r.subject / "masks" / name).string(), NpyArray::from(m, {H, W}));
  }
  const double f = 20.0 * W / 16;
  Npz cams;
  cams.set("intrinsic", NpyArray::from(std::vector<double>{f, 0, W / 2.0, 0, f, H / 2.0, 0, 0, 1}, {3, 3}));
  cams.set("extrinsic", NpyArray::from(std::vector<double>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 0, 0, 0, 1}, {4, 4}));
  cams.set("height", NpyArray::from(std::vector<int64_t>{H}, {}));
  cams.set("width", NpyArray::from(std::vector<int64_t>{W}, {}));
  cams.write((r.subject / "cameras.npz").string());

  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 0.25);
  for (const auto& [split, n] : {std::pair<const char*, int>{"train", o.train_rows}, {"test", o.test_rows}}) {
    std::vector<double> orient, body, t;
    for (int row = 0; row < n; ++row) {
      for (int k = 0; k < 3; ++k) orient.push_back(k == 1 ? 3 * g(rng) : g(rng));
      for (int k = 0; k < 69; ++k) body.push_back(k < 63 ? g(rng) : 0.0);  // SMPL hands at rest
      for (int k = 0; k < 3; ++k) t.push_back(g(rng));
      r.transl.push_back({t[t.size() - 3], t[t.size() - 2], t[t.size() - 1]});
    }
    Npz z;
    z.set("betas", NpyArray::from(std::vector<float>{0.2f, 0, 0, 0, 0, 0, 0, 0, 0, 0}, {1, 10}));
    z.set("global_orient", NpyArray::from(orient, {n, 3}));
    z.set("body_pose", NpyArray::from(body, {n, 69}));
    z.set("transl", NpyArray::from(t, {n, 3}));
    z.write((r.subject / "poses" / (std::string("anim_nerf_") + split + ".npz")).string());
  }
  return r;
}

}  // namespace haha::test
