// Writes the Python package test's inputs into OUTDIR: avatar.glb (a realistic-size avatar on
// the full procedural SMPL-X-layout body, packed with the defaults: Draco mesh, JPEG texture,
// embedded pose correctives), motion.npz (3 frames, the AMASS layout `haha motion` writes)
// animated.glb (a small avatar carrying that motion as the glTF animation "fixture") and
// coverage.glb (a small avatar with a mesh coverage: vertex v has 0, 1, 0.3 for v % 3 = 0, 1, 2).
//   python_avatar_fixture OUTDIR
#include <cstdio>
#include <exception>
#include <filesystem>
#include <vector>

#include "format/avatar_pack.h"
#include "io/motion.h"
#include "io/npy.h"
#include "support/format_realistic_avatar.h"
#include "support/format_test_avatar.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUTDIR\n", argv[0]);
    return 2;
  }
  try {
    const std::filesystem::path out = argv[1];
    std::filesystem::create_directories(out);
    haha::write_avatar_glb(haha::test::make_realistic_avatar(6000, 128), (out / "avatar.glb").string(),
                           haha::PackOptions{});
    const int T = 3;
    std::vector<float> poses(size_t(T) * 165, 0.0f), trans(size_t(T) * 3, 0.0f);
    for (int t = 0; t < T; ++t) {
      poses[size_t(t) * 165 + 3 * 16 + 2] = -0.6f * float(t);  // left shoulder down
      poses[size_t(t) * 165 + 3 * 18 + 1] = -0.4f * float(t);  // left elbow
      poses[size_t(t) * 165 + 1] = 0.3f * float(t);            // turn
      trans[size_t(t) * 3] = 0.05f * float(t);
    }
    haha::Npz z;
    z.set("poses", haha::NpyArray::from(poses, {T, 165}));
    z.set("trans", haha::NpyArray::from(trans, {T, 3}));
    z.set("mocap_frame_rate", haha::NpyArray::from(std::vector<double>{30.0}, {}));
    z.write((out / "motion.npz").string());
    haha::PackOptions animated;
    animated.animations.push_back({"fixture", haha::read_motion((out / "motion.npz").string())});
    haha::write_avatar_glb(haha::test::make_realistic_avatar(500, 32), (out / "animated.glb").string(), animated);
    haha::write_avatar_glb(haha::test::with_test_coverage(haha::test::make_realistic_avatar(500, 32)),
                           (out / "coverage.glb").string(), haha::PackOptions{});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "python_avatar_fixture: %s\n", e.what());
    return 1;
  }
  return 0;
}
