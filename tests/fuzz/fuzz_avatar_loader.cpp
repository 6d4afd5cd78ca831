// libFuzzer target for the avatar reader: any byte string must give either an Avatar or a
// haha::Error, never a crash, hang or sanitizer report. Two passes per input: with the
// checksums on (the normal path) and off (so mutations reach the Draco and image decoders).
//
// Build (clang; not part of the default build or CI):
//   CC=clang CXX=clang++ cmake -S tests/fuzz -B build-fuzz -G Ninja
//   cmake --build build-fuzz --target fuzz_avatar_loader
//   build-fuzz/fuzz_avatar_loader -max_total_time=300 -max_len=200000 CORPUS_DIR
// A seed corpus is written by `fuzz_avatar_loader --write-seeds DIR` (small valid files).
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "support/format_test_avatar.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (bool checksums : {true, false}) {
    haha::UnpackOptions opt;
    opt.verify_checksums = checksums;
    try {
      haha::unpack_avatar(data, size, "fuzz.glb", opt);
    } catch (const haha::Error&) {
    }
  }
  return 0;
}

// `--write-seeds DIR`: valid files (default, lossless, webp) to start the corpus from.
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i) {
    if (std::strcmp((*argv)[i], "--write-seeds") != 0) continue;
    const std::filesystem::path dir = (*argv)[i + 1];
    std::filesystem::create_directories(dir);
    const haha::Avatar a = haha::test::make_test_avatar(40, 2, 8, 8);
    haha::PackOptions lossy, lossless, webp;
    lossless.lossless = true;
    webp.texture_codec = haha::TextureCodec::webp;
    int k = 0;
    for (const haha::PackOptions& o : {lossy, lossless, webp}) {
      const std::vector<uint8_t> b = haha::pack_avatar(a, o);
      std::ofstream(dir / ("seed" + std::to_string(k++) + ".glb"), std::ios::binary)
          .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
    }
    std::exit(0);
  }
  return 0;
}
