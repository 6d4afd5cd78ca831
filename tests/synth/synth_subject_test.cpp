// The synthetic subject (libhaha/synth/synth_subject.cpp): garments and hair well formed,
// skinned and outside the body, subject 1 byte-exact, bad options. Subject 2:
// synth_coat_test.cpp; motions, renders: synth_motion_test.cpp, synth_render_test.cpp; the
// dataset on disk: tests/data/synth_dataset_test.cpp. Low-resolution procedural body.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "body/rotation.h"
#include "core/error.h"
#include "support/expect_error.h"
#include "support/low_body.h"
#include "support/synth_mesh_checks.h"
#include "support/synth_low_subject.h"
#include "synth/synth_internal.h"

namespace haha {
namespace {

using test::low_body;

using test::low_subject;

using haha::test::expect_error;

// ---------------------------------------------------------------------------------------
// Subject

TEST(SynthSubject, GarmentMeshesAreWellFormedAndSkinned) {
  const SynthSubject& s = low_subject();
  std::map<std::string, const SynthMesh*> by;
  for (const SynthMesh& m : s.meshes) by[m.name] = &m;
  ASSERT_TRUE(by.count("hair") && by.count("ponytail") && by.count("skirt"));
  for (const SynthMesh& m : s.meshes) {
    SCOPED_TRACE(m.name);
    ASSERT_GT(m.num_faces(), 20);
    test::expect_synth_mesh_well_formed(m);
  }
  // The skirt follows the thighs: its hem is skinned to both hips, its waist to the pelvis.
  const SynthMesh& sk = *by["skirt"];
  const int last = sk.num_verts() - 1;
  bool hips = false;
  for (int k = sk.w_start[last]; k < sk.w_start[last + 1]; ++k) hips |= (sk.w_joint[k] == 1 || sk.w_joint[k] == 2);
  EXPECT_TRUE(hips);
  EXPECT_EQ(sk.w_start[1] - sk.w_start[0], 1);
  EXPECT_EQ(sk.w_joint[0], 0);
  for (const Image* t : {&s.body_texture, &s.garment_texture}) {
    ASSERT_FALSE(t->empty());
    for (float x : t->data) ASSERT_TRUE(x >= 0 && x <= 1);
  }
}

// Whether a ray from o along d crosses triangle (a, b, c) at t > 0 (Moller-Trumbore).
bool ray_hits(synth::V3 o, synth::V3 d, synth::V3 a, synth::V3 b, synth::V3 c) {
  const synth::V3 e1 = b - a, e2 = c - a, p = cross(d, e2);
  const double det = dot(e1, p);
  if (std::abs(det) < 1e-14) return false;
  const synth::V3 s = o - a;
  const double u = dot(s, p) / det;
  if (u < 0 || u > 1) return false;
  const synth::V3 q = cross(s, e1);
  const double v = dot(d, q) / det;
  if (v < 0 || u + v > 1) return false;
  return dot(e2, q) / det > 0;
}

// Vertices of `mesh` inside some closed part of the low procedural body (rest pose).
// Parts overlap, so parity is taken per part.
int vertices_inside_body(const SynthMesh& mesh) {
  const SynthSubject& s = low_subject();
  const BodyModel& body = low_body();
  ProceduralBodyInfo info;
  ProceduralBodyOptions po;
  po.resolution = BodyResolution::low;
  make_procedural_body(po, &info);
  auto P = [&](const std::vector<float>& v, int i) { return synth::V3(v[3 * i], v[3 * i + 1], v[3 * i + 2]); };
  const synth::V3 dir = synth::unit(synth::V3(1, 0.31, 0.17));  // generic: no edge-on hits
  int inside = 0;
  for (int v = 0; v < mesh.num_verts(); ++v) {
    const synth::V3 p = P(mesh.rest, v);
    bool in = false;
    for (const ProceduralPart& part : info.parts) {
      int crossings = 0;
      for (int f = part.first_face; f < part.first_face + part.num_faces; ++f)
        crossings += ray_hits(p, dir, P(s.rest_verts, body.faces[3 * f]), P(s.rest_verts, body.faces[3 * f + 1]),
                              P(s.rest_verts, body.faces[3 * f + 2]));
      in |= crossings % 2 == 1;
    }
    inside += in;
  }
  return inside;
}

// Largest distance from a vertex of `mesh` to its nearest body vertex (rest pose).
double max_gap_to_body(const SynthMesh& mesh) {
  const SynthSubject& s = low_subject();
  double gap = 0;
  for (int v = 0; v < mesh.num_verts(); ++v) {
    double nearest = 1e9;
    for (size_t b = 0; b < s.rest_verts.size(); b += 3)
      nearest = std::min<double>(nearest, std::hypot(s.rest_verts[b] - mesh.rest[3 * v], s.rest_verts[b + 1] - mesh.rest[3 * v + 1],
                                             s.rest_verts[b + 2] - mesh.rest[3 * v + 2]));
    gap = std::max(gap, nearest);
  }
  return gap;
}

const SynthMesh& mesh_named(const std::string& name) {
  for (const SynthMesh& m : low_subject().meshes)
    if (m.name == name) return m;
  throw std::runtime_error("no mesh " + name);
}

TEST(SynthSubject, HairAndSkirtLieOutsideTheBodyAndLeaveItsSurface) {
  const SynthMesh& hair = mesh_named("hair");
  const SynthMesh& skirt = mesh_named("skirt");
  ASSERT_GT(hair.num_verts(), 50);
  EXPECT_EQ(vertices_inside_body(hair), 0);
  EXPECT_EQ(vertices_inside_body(skirt), 0);
  const double hair_gap = max_gap_to_body(hair), skirt_gap = max_gap_to_body(skirt);
  EXPECT_GT(hair_gap, 0.015);  // up to ~3.5 cm of hair
  EXPECT_LT(hair_gap, 0.06);
  EXPECT_GT(skirt_gap, 0.08);  // the flared hem stands well off the thighs
  EXPECT_LT(skirt_gap, 0.4);
}

// Subject 1 (the default sample) must not change when other subjects are added: hashes
// of 8-bit quantised renders, textures and a whole small dataset, measured on the code
// before subject 2 existed (commit f0cffd6). Quantising to 8 bits keeps the check about
// the pictures rather than the last bit of a float.
uint64_t fnv1a(uint64_t h, const void* data, size_t n) {
  const auto* b = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001B3ull;
  return h;
}
uint64_t hash_image(uint64_t h, const Image& img) {
  std::vector<unsigned char> q(img.data.size());
  for (size_t i = 0; i < q.size(); ++i) q[i] = (unsigned char)std::lround(std::clamp(img.data[i], 0.0f, 1.0f) * 255.0f);
  return fnv1a(h, q.data(), q.size());
}

TEST(SynthSubject, SubjectOneRendersExactlyAsBefore) {
  const SynthSubject& s = low_subject();
  uint64_t h = 0xCBF29CE484222325ull;
  h = hash_image(h, s.body_texture);
  h = hash_image(h, s.garment_texture);
  const SynthMotion motion = make_synth_motion(low_body(), s, 8, 4, 0);
  SynthRenderer r(low_body(), s);
  std::vector<const SmplxParams*> all;
  for (const auto& p : motion.train) all.push_back(&p);
  for (const auto& p : motion.test) all.push_back(&p);
  const Camera cam = synth_camera(r, all, 64);
  Image rgb, mask;
  for (const SmplxParams* p : {&motion.train[0], &motion.train[3], &motion.test[1]}) {
    r.render(cam, *p, 3, kSynthAll, rgb, mask);
    h = hash_image(h, rgb);
    h = hash_image(h, mask);
  }
  EXPECT_EQ(h, 8023900718762434255ull);
}

TEST(SynthSubject, NeedsAUvMapAndASaneTextureSize) {
  BodyModel b = low_body();
  b.vt.clear();
  expect_error([&] { make_synth_subject(b); }, "UV map");
  SynthSubjectOptions o;
  o.texture_size = 4;
  expect_error([&] { make_synth_subject(low_body(), o); }, "texture size");
}

}  // namespace
}  // namespace haha
