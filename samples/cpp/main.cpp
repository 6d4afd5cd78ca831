// haha_sample_cpp: the engine pattern with libhaha_runtime.so.
//
//   haha_sample_cpp AVATAR.glb MOTION.npz [--model BODY.npz] [--builtin-render OUTDIR] [--size N]
//
// Load the avatar once; every frame repose it and hand the posed mesh (vertices, normals,
// fixed faces) and the posed Gaussians to the engine's own renderer, here a stand-in that
// reports what it received and the per-frame cost. With --builtin-render the runtime's own
// merged renderer draws the frames too (OUTDIR/frame_%05d.png).
#include "haha/haha_runtime.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// C status -> C++ exception carrying the library's one-line message.
void check(haha_status s, const char* what) {
  if (s != HAHA_OK) throw std::runtime_error(std::string(what) + ": " + haha_status_string(s) + ": " + haha_last_error());
}

// Owning handles: each object is freed by its own haha_*_free.
using Avatar = std::unique_ptr<haha_avatar, decltype(&haha_avatar_free)>;
using Posed = std::unique_ptr<haha_posed, decltype(&haha_posed_free)>;
using Motion = std::unique_ptr<haha_motion, decltype(&haha_motion_free)>;

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

struct Box {
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  void add(const float* xyz, size_t n) {
    for (size_t i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], xyz[3 * i + k]);
        hi[k] = std::max(hi[k], xyz[3 * i + k]);
      }
  }
  std::string str() const {
    char b[160];
    std::snprintf(b, sizeof b, "[%.3f %.3f %.3f]..[%.3f %.3f %.3f]", lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    return b;
  }
};

// Stand-in for an engine's renderer: the index buffer is uploaded once; each frame
// receives vertex positions + normals and the Gaussians (structure of arrays).
class EngineRenderer {
 public:
  void upload_topology(std::vector<uint32_t> indices) { indices_ = std::move(indices); }
  void draw(int frame, const std::vector<float>& verts, const std::vector<float>& normals,
            const std::vector<float>& means, const std::vector<float>& opacities, double pose_ms) {
    Box vb, gb;
    vb.add(verts.data(), verts.size() / 3);
    gb.add(means.data(), means.size() / 3);
    double opacity = 0;
    for (float o : opacities) opacity += o;
    std::printf("frame %5d: repose+readback %6.2f ms | mesh %zu verts %zu tris %s, normals %zu | %zu Gaussians %s, mean opacity %.3f\n",
                frame, pose_ms, verts.size() / 3, indices_.size() / 3, vb.str().c_str(), normals.size() / 3,
                means.size() / 3, means.empty() ? "-" : gb.str().c_str(),
                opacities.empty() ? 0.0 : opacity / double(opacities.size()));
  }

 private:
  std::vector<uint32_t> indices_;
};

// A front camera (looking along world -Z, OpenCV axes) framing the box with a margin.
haha_camera framing_camera(const Box& b, int size) {
  haha_camera c{};
  c.width = c.height = size;
  c.fx = c.fy = 1.5f * float(size);
  c.cx = c.cy = 0.5f * float(size);
  const float half = 0.5f * 1.15f * std::max(b.hi[0] - b.lo[0], b.hi[1] - b.lo[1]);
  const float dist = half * c.fx / (0.5f * float(size)) + 0.5f * (b.hi[2] - b.lo[2]);
  const float eye[3] = {0.5f * (b.lo[0] + b.hi[0]), 0.5f * (b.lo[1] + b.hi[1]), 0.5f * (b.lo[2] + b.hi[2]) + dist};
  const float R[9] = {1, 0, 0, 0, -1, 0, 0, 0, -1};
  std::copy(R, R + 9, c.rotation);
  c.translation[0] = -eye[0], c.translation[1] = eye[1], c.translation[2] = eye[2];  // -R eye
  c.far_plane = 4 * dist + 10;
  return c;
}

int run(int argc, char** argv) {
  std::string avatar_path, motion_path, model_path, render_dir;
  int size = 512;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--builtin-render" && i + 1 < argc) render_dir = argv[++i];
    else if (a == "--model" && i + 1 < argc) model_path = argv[++i];
    else if (a == "--size" && i + 1 < argc) size = std::atoi(argv[++i]);
    else if (avatar_path.empty()) avatar_path = a;
    else if (motion_path.empty()) motion_path = a;
    else throw std::runtime_error("unexpected argument " + a);
  }
  if (motion_path.empty())
    throw std::runtime_error("usage: haha_sample_cpp AVATAR.glb MOTION.npz [--model BODY.npz] [--builtin-render OUTDIR] [--size N]");

  // Load once.
  haha_avatar* a = nullptr;
  auto t0 = std::chrono::steady_clock::now();
  check(haha_avatar_load(avatar_path.c_str(), model_path.empty() ? nullptr : model_path.c_str(), &a), "load avatar");
  Avatar avatar(a, haha_avatar_free);
  const double load_ms = ms_since(t0);
  haha_avatar_info info{};
  check(haha_avatar_get_info(avatar.get(), &info), "avatar info");
  std::printf("haha runtime %s; %s loaded in %.1f ms: %d vertices, %d faces, %d Gaussians\n", haha_version_string(),
              avatar_path.c_str(), load_ms, info.num_vertices, info.num_faces, info.num_gaussians);

  if (!render_dir.empty()) std::filesystem::create_directories(render_dir);

  haha_motion* m = nullptr;
  check(haha_motion_load_for_avatar(motion_path.c_str(), avatar.get(), &m), "load motion");
  Motion motion(m, haha_motion_free);
  int32_t frames = 0;
  double fps = 0;
  check(haha_motion_info(motion.get(), &frames, &fps), "motion info");

  haha_posed* p = nullptr;
  check(haha_posed_create(avatar.get(), &p), "pose state");
  Posed posed(p, haha_posed_free);

  EngineRenderer engine;
  std::vector<uint32_t> indices(3 * size_t(info.num_faces));
  check(haha_avatar_faces(avatar.get(), indices.data(), indices.size()), "faces");
  engine.upload_topology(std::move(indices));

  // Per-frame buffers, allocated once.
  const size_t V = size_t(info.num_vertices), N = size_t(info.num_gaussians);
  std::vector<float> verts(3 * V), normals(3 * V), means(3 * N), rotations(4 * N), scales(3 * N), colors(3 * N),
      opacities(N);
  haha_gaussian_arrays g{N, means.data(), rotations.data(), scales.data(), colors.data(), opacities.data()};
  std::vector<uint8_t> rgb(3 * size_t(size) * size_t(size));
  haha_camera cam{};
  const float white[3] = {1, 1, 1};
  float pose[HAHA_NUM_POSE_VALUES], transl[3];
  double total_pose = 0, total_render = 0;

  for (int32_t f = 0; f < frames; ++f) {
    check(haha_motion_frame(motion.get(), f, pose, transl), "motion frame");
    t0 = std::chrono::steady_clock::now();
    check(haha_repose(posed.get(), pose, transl, nullptr, 0, nullptr, 0), "repose");
    check(haha_posed_vertices(posed.get(), verts.data(), verts.size()), "vertices");
    check(haha_posed_normals(posed.get(), normals.data(), normals.size()), "normals");
    check(haha_posed_gaussians(posed.get(), &g), "gaussians");
    const double pose_ms = ms_since(t0);
    total_pose += pose_ms;
    engine.draw(f, verts, normals, means, opacities, pose_ms);

    if (!render_dir.empty()) {
      if (f == 0) {  // frame the first pose
        Box b;
        b.add(verts.data(), V);
        cam = framing_camera(b, size);
      }
      t0 = std::chrono::steady_clock::now();
      check(haha_render(posed.get(), &cam, white, 0, HAHA_PIXEL_RGB8, rgb.data(), rgb.size()), "render");
      const double render_ms = ms_since(t0);
      total_render += render_ms;
      char path[4096];
      std::snprintf(path, sizeof path, "%s/frame_%05d.png", render_dir.c_str(), int(f));
      check(haha_write_png(path, size, size, 3, rgb.data()), "write png");
      std::printf("             built-in render %6.2f ms -> %s\n", render_ms, path);
    }
  }
  std::printf("%d frames at %.3g fps: mean repose+readback %.2f ms", int(frames), fps, total_pose / frames);
  if (!render_dir.empty()) std::printf(", mean built-in render (%dx%d) %.2f ms", size, size, total_render / frames);
  std::printf("\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "haha_sample_cpp: %s\n", e.what());
    return 1;
  }
}
