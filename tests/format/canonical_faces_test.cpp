// The canonical face order (format/canonical_faces.h) depends only on which vertices each
// face joins and its orientation: reordering the faces or rotating a face's corners gives
// the same canonical faces, and each input face is found again with its rotation.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>

#include "format/canonical_faces.h"

namespace haha {
namespace {

using Tri = std::array<int32_t, 3>;

std::vector<Tri> canonical_list(const std::vector<int32_t>& faces) {
  const CanonicalFaces c = canonical_faces(faces.data(), int(faces.size() / 3));
  std::vector<Tri> out;
  for (int32_t f : c.order) {
    const int r = c.rotation[size_t(f)];
    out.push_back({faces[size_t(f) * 3 + size_t(r)], faces[size_t(f) * 3 + size_t((r + 1) % 3)], faces[size_t(f) * 3 + size_t((r + 2) % 3)]});
  }
  return out;
}

std::vector<int32_t> random_faces(int F, int V, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int32_t> v(0, V - 1);
  std::vector<int32_t> faces;
  for (int f = 0; f < F; ++f) {
    int32_t a = v(rng), b = v(rng), c = v(rng);
    while (b == a) b = v(rng);
    while (c == a || c == b) c = v(rng);
    faces.insert(faces.end(), {a, b, c});
  }
  return faces;
}

TEST(CanonicalFaces, SortedSmallestFirstAndOrientationKept) {
  const std::vector<int32_t> faces = random_faces(500, 200, 1);
  const std::vector<Tri> c = canonical_list(faces);
  ASSERT_EQ(c.size(), 500u);
  EXPECT_TRUE(std::is_sorted(c.begin(), c.end()));
  for (const Tri& t : c) EXPECT_TRUE(t[0] < t[1] && t[0] < t[2]) << t[0] << " " << t[1] << " " << t[2];
}

TEST(CanonicalFaces, InvariantUnderFaceOrderAndCornerRotation) {
  const std::vector<int32_t> faces = random_faces(800, 300, 2);
  std::mt19937 rng(7);
  std::vector<int> perm(800);
  for (int i = 0; i < 800; ++i) perm[size_t(i)] = i;
  std::shuffle(perm.begin(), perm.end(), rng);
  std::vector<int32_t> moved;
  for (int f : perm) {
    const int r = int(rng() % 3);
    for (int i = 0; i < 3; ++i) moved.push_back(faces[size_t(f) * 3 + size_t((r + i) % 3)]);
  }
  EXPECT_EQ(canonical_list(faces), canonical_list(moved));
  // A flipped face is another triangle: it sorts elsewhere.
  std::vector<int32_t> flipped = faces;
  std::swap(flipped[1], flipped[2]);
  EXPECT_NE(canonical_list(faces), canonical_list(flipped));
}

TEST(CanonicalFaces, RepeatedVerticesAndDuplicateFacesAreStable) {
  // A degenerate face (a repeated vertex) takes its smallest rotation whichever corner
  // comes first; two copies of one triangle keep their input order.
  const std::vector<int32_t> a = {5, 7, 5, 1, 2, 3, 1, 2, 3, 9, 4, 6};
  const std::vector<int32_t> b = {7, 5, 5, 2, 3, 1, 3, 1, 2, 4, 6, 9};
  EXPECT_EQ(canonical_list(a), canonical_list(b));
  const CanonicalFaces c = canonical_faces(a.data(), 4);
  EXPECT_EQ(c.order, (std::vector<int32_t>{1, 2, 3, 0}));
  EXPECT_EQ(canonical_list(a)[3], (Tri{5, 5, 7}));
}

TEST(CanonicalFaces, EmptyMesh) {
  const CanonicalFaces c = canonical_faces(nullptr, 0);
  EXPECT_TRUE(c.order.empty());
  EXPECT_TRUE(c.rotation.empty());
}

}  // namespace
}  // namespace haha
