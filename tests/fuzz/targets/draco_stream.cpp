// Draco streams as the avatar format reads them (format/draco_io.h): the header check, the
// decode, and every accessor with each attribute id and component count the format uses.
#include "format/draco_io.h"
#include "fuzz_target.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (bool mesh : {true, false}) {
    haha::fuzz::expect_result_or_error([&] {
      const haha::dracoio::Decoded d(data, size, mesh, "fuzz.glb", mesh ? "body mesh" : "gaussians");
      (void)d.num_points();
      (void)d.faces();
      for (int id = 0; id < 6; ++id)
        for (int components : {1, 2, 3, 4}) {
          haha::fuzz::expect_result_or_error([&] { (void)d.floats(id, components, "attribute"); });
          haha::fuzz::expect_result_or_error([&] { (void)d.ints(id, components, "attribute"); });
        }
    });
  }
  return 0;
}

// A two-triangle mesh (positions quantized, UVs raw, an integer attribute; sequential and
// edgebreaker) and a point
// cloud (quantized floats, an unpredicted attribute), written by the format's encoder.
void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  using namespace haha::dracoio;
  const std::vector<float> pos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0.5f};
  const std::vector<float> uv = {0, 0, 1, 0, 1, 1, 0, 1};
  const std::vector<int32_t> ids = {3, 1, 4, 1};
  const std::vector<int32_t> faces = {0, 1, 2, 0, 2, 3};
  AttrIn p{"POSITION", Kind::position, Type::f32, 3, pos.data(), 14};
  AttrIn t{"TEXCOORD_0", Kind::texcoord, Type::f32, 2, uv.data(), 0};
  AttrIn i{"BODY_VERTEX", Kind::generic, Type::i32, 1, ids.data(), 0};
  haha::fuzz::write_seed(dir, "mesh.drc", encode(4, {p, t, i}, faces.data(), 2).bytes);
  haha::fuzz::write_seed(dir, "mesh_edgebreaker.drc", encode(4, {p, t, i}, faces.data(), 2, Method::edgebreaker).bytes);
  const std::vector<float> colour = {0.1f, 0.2f, 0.3f, 0.9f, 0.8f, 0.7f, 0.5f, 0.5f, 0.5f, 0.0f, 1.0f, 0.25f};
  AttrIn c{"COLOR", Kind::generic, Type::f32, 3, colour.data(), 8};
  AttrIn f{"FACE", Kind::generic, Type::i32, 1, ids.data(), 0, false};
  haha::fuzz::write_seed(dir, "points.drc", encode(4, {c, f}, nullptr, 0).bytes);
}
