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

// Small valid files: the default pack, lossless, webp, and (version 3) a plain mesh with
// skinned splats, an edgebreaker mesh, a lossless pack of a displaced (clothed) body, and
// (version 4) a body with a garment as the mesh's second primitive, Draco and plain, and
// that body with a mesh coverage (Draco, plain, lossless). The
// corpus also keeps seeds of older versions written by earlier packers (seed0-4: version 2;
// seed8: version 3, the garment inside primitive 0).
void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  const haha::Avatar a = haha::test::make_test_avatar(40, 2, 8, 8);
  haha::PackOptions lossy, lossless, webp, plain;
  lossless.lossless = true;
  webp.texture_codec = haha::TextureCodec::webp;
  plain.mesh_compression = haha::MeshCompression::none;
  plain.khr_gaussian_splatting = true;
  int k = 0;
  for (const haha::PackOptions& o : {lossy, lossless, webp})
    haha::fuzz::write_seed(dir, "seed" + std::to_string(k++) + ".glb", haha::pack_avatar(a, o));
  haha::fuzz::write_seed(dir, "seed5_v3_plain_splats.glb", haha::pack_avatar(a, plain));
  haha::fuzz::write_seed(dir, "seed6_v3_edgebreaker.glb", haha::pack_avatar(haha::test::without_degenerate_face(a), lossy));
  haha::Avatar clothed = a;  // a body with the clothed surface's rest displacement
  clothed.body.rest_offsets.assign(a.body.v_template.size(), 0.01f);
  haha::fuzz::write_seed(dir, "seed7_v3_clothed_lossless.glb", haha::pack_avatar(clothed, lossless));
  const haha::Avatar garment = haha::test::with_test_garment(haha::test::without_degenerate_face(a));
  haha::fuzz::write_seed(dir, "seed9_v4_garment.glb", haha::pack_avatar(garment, lossy));
  plain.khr_gaussian_splatting = false;
  haha::fuzz::write_seed(dir, "seed10_v4_garment_plain.glb", haha::pack_avatar(garment, plain));
  // A mesh coverage (COLOR_0 alpha, alphaMode MASK) on the garment avatar: Draco (8-bit),
  // plain accessors, and lossless (float32 in the Draco stream).
  const haha::Avatar covered = haha::test::with_test_coverage(garment);
  haha::fuzz::write_seed(dir, "seed11_v4_coverage.glb", haha::pack_avatar(covered, lossy));
  haha::fuzz::write_seed(dir, "seed12_v4_coverage_plain.glb", haha::pack_avatar(covered, plain));
  haha::fuzz::write_seed(dir, "seed13_v4_coverage_lossless.glb", haha::pack_avatar(covered, lossless));
}
