// The glTF animations of a .glb (format/animation_unpack.h): key times, samplers, channels
// and their accessors, read on their own so mutations reach them without the rest of the
// avatar having to decode first.
#include "format/animation_pack.h"
#include "format/animation_unpack.h"
#include "format/avatar_pack.h"
#include "fuzz_target.h"
#include "support/format_test_avatar.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  haha::fuzz::expect_result_or_error([&] {
    for (const haha::AvatarAnimation& a : haha::read_glb_animations(data, size, "fuzz.glb"))
      (void)haha::sample_animation(a, 0.5 * a.duration);
  });
  return 0;
}

// A small avatar with two short animations: 16-bit rotations with a moving and a still
// root, and float32 rotations.
void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  const haha::Avatar a = haha::test::make_test_avatar(20, 2, 8, 8);
  haha::Motion m;
  m.fps = 30;
  for (int k = 0; k < 4; ++k) {
    haha::SmplxParams p;
    p.pose[1] = 0.4f * float(k);
    p.pose[3 * 16 + 2] = -0.3f * float(k);
    p.transl = {0.1f * float(k), 0.0f, 0.0f};
    m.frames.push_back(p);
  }
  haha::Motion still = m;
  for (haha::SmplxParams& p : still.frames) p.transl = {0, 0, 0};
  for (int bits : {16, 0}) {
    haha::PackOptions o;
    o.animation_bits = bits;
    o.animations = {{"moving", m}, {"still_root", still}};
    o.pose_correctives = haha::PoseCorrectives::none;  // small seeds: the animations are what is fuzzed
    haha::fuzz::write_seed(dir, "seed_bits" + std::to_string(bits) + ".glb", haha::pack_avatar(a, o));
  }
}
