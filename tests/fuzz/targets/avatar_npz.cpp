// The run's avatar.npz reader (format/avatar_npz.h), with the body attached as `haha pack`
// and `haha eval` attach it: the optional rest displacement of the clothed surface and the
// garment appended to the body included.
#include <filesystem>

#include "format/avatar_npz.h"
#include "fuzz_target.h"
#include "support/format_test_avatar.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = haha::fuzz::as_file(data, size, ".npz");
  haha::fuzz::expect_result_or_error([&] {
    haha::Avatar a = haha::load_avatar_npz(path);
    haha::attach_body(a, haha::test::make_test_body(4, 5), path);
  });
  return 0;
}

// An avatar without and one with a rest displacement, one with a garment and one with a mesh
// coverage too, on the fuzz body (4 rings x 5 segments).
void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  haha::Avatar a = haha::test::make_test_avatar(10, 2, 8, 8);
  const std::string p = (std::filesystem::temp_directory_path() / "haha-fuzz-seed.npz").string();
  haha::save_avatar_npz(a, p);
  haha::fuzz::write_seed(dir, "bare.npz", haha::fuzz::file_bytes(p));
  const haha::BodyModel small = haha::test::make_test_body(4, 5);
  a.body.rest_offsets.assign(small.v_template.size(), 0.01f);
  haha::save_avatar_npz(a, p);
  haha::fuzz::write_seed(dir, "clothed.npz", haha::fuzz::file_bytes(p));
  // The test garment, with the displacement covering it too.
  a.garment = haha::test::make_test_garment();
  a.body.rest_offsets.assign(small.v_template.size() + a.garment.verts.size(), 0.01f);
  haha::save_avatar_npz(a, p);
  haha::fuzz::write_seed(dir, "garment.npz", haha::fuzz::file_bytes(p));
  // A mesh coverage on every vertex of the body with its garment.
  a.mesh_coverage.resize(small.v_template.size() / 3 + a.garment.verts.size() / 3);
  for (size_t v = 0; v < a.mesh_coverage.size(); ++v) a.mesh_coverage[v] = v % 3 == 0 ? 0.0f : v % 3 == 1 ? 1.0f : 0.3f;
  haha::save_avatar_npz(a, p);
  haha::fuzz::write_seed(dir, "coverage.npz", haha::fuzz::file_bytes(p));
  std::filesystem::remove(p);
}
