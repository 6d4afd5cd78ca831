// The .glb avatar reader (format/avatar_unpack.h), glTF + HAHA_gaussian_avatar + Draco +
// the texture codecs. Two passes per input: with the checksums on (the normal path) and
// off (so mutations reach the Draco and image decoders).
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "fuzz_target.h"
#include "support/format_test_avatar.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (bool checksums : {true, false}) {
    haha::UnpackOptions opt;
    opt.verify_checksums = checksums;
    haha::fuzz::expect_result_or_error([&] { haha::unpack_avatar(data, size, "fuzz.glb", opt); });
  }
  return 0;
}

// Small valid files: the default pack, lossless, webp.
void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  const haha::Avatar a = haha::test::make_test_avatar(40, 2, 8, 8);
  haha::PackOptions lossy, lossless, webp;
  lossless.lossless = true;
  webp.texture_codec = haha::TextureCodec::webp;
  int k = 0;
  for (const haha::PackOptions& o : {lossy, lossless, webp})
    haha::fuzz::write_seed(dir, "seed" + std::to_string(k++) + ".glb", haha::pack_avatar(a, o));
}
