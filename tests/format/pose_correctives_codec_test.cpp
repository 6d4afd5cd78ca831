// The compact pose-corrective codec (format/pose_correctives_codec.h): exact at full rank
// without quantization, the rank it picks, and every malformed stream refused.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "body/procedural_body.h"
#include "core/error.h"
#include "format/draco_io.h"
#include "format/pose_correctives_codec.h"
#include "support/expect_error.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

std::vector<float> roundtrip(const std::vector<float>& pd, int V, const PoseCorrectiveCodec& c, EncodedPoseCorrectives* out = nullptr) {
  const EncodedPoseCorrectives e = encode_pose_correctives(pd, V, c);
  if (out) *out = e;
  return decode_pose_correctives(e.draco.data(), e.draco.size(), e.count, e.rank, e.ids.data(), e.mixing.data(), V, "t", "pc");
}

double max_abs(const std::vector<float>& x) {
  double m = 0;
  for (float v : x) m = std::max(m, double(std::fabs(v)));
  return m;
}

TEST(PoseCorrectivesCodec, FullRankFloatIsExactToRounding) {
  const BodyModel b = test::make_test_body();  // dense random posedirs: rank 9 per joint
  PoseCorrectiveCodec c;
  c.threshold = 0;
  c.rank = 9;
  c.energy = 1;
  c.bits = 0;
  EncodedPoseCorrectives e;
  const std::vector<float> q = roundtrip(b.posedirs, b.num_verts, c, &e);
  EXPECT_EQ(e.rank, 9);
  EXPECT_EQ(e.count, b.num_verts * (kNumJoints - 1));
  const double m = max_abs(b.posedirs);
  for (size_t i = 0; i < q.size(); ++i) ASSERT_NEAR(q[i], b.posedirs[i], 1e-5 * m) << i;
}

TEST(PoseCorrectivesCodec, ProceduralBodyNeedsOneRowPerJoint) {
  // Its correctives push a vertex along its normal by one scalar per (vertex, joint) times
  // the trace features: every joint's blocks are rank 1, which the energy rule finds.
  const BodyModel b = make_procedural_body({BodyResolution::low, 0});
  PoseCorrectiveCodec c;
  c.threshold = 0;
  c.bits = 0;
  EncodedPoseCorrectives e;
  const std::vector<float> q = roundtrip(b.posedirs, b.num_verts, c, &e);
  EXPECT_EQ(e.rank, 1);
  const double m = max_abs(b.posedirs);
  for (size_t i = 0; i < q.size(); ++i) ASSERT_NEAR(q[i], b.posedirs[i], 1e-5 * m) << i;
  // A threshold drops blocks: fewer points, never more.
  c.threshold = 0.2;
  EncodedPoseCorrectives e2;
  roundtrip(b.posedirs, b.num_verts, c, &e2);
  EXPECT_LT(e2.count, e.count);
}

TEST(PoseCorrectivesCodec, AllZeroCorrectivesStoreNoPoints) {
  const int V = 7;
  const std::vector<float> zero(size_t(V) * 3 * kNumPoseFeatures, 0.0f);
  EncodedPoseCorrectives e;
  const std::vector<float> q = roundtrip(zero, V, PoseCorrectiveCodec{}, &e);
  EXPECT_EQ(e.count, 0);
  EXPECT_TRUE(e.draco.empty());
  EXPECT_EQ(q, zero);
}

// A stream laid out like the encoder's, from explicit arrays (rank 1).
std::vector<uint8_t> stream(std::vector<uint8_t> joint, std::vector<uint16_t> vertex, std::vector<float> cx) {
  using dracoio::AttrIn;
  using dracoio::Kind;
  using dracoio::Type;
  const int n = int(joint.size());
  return dracoio::encode(n,
                         {{"JOINT", Kind::generic, Type::u8, 1, joint.data(), 0},
                          {"VERTEX", Kind::generic, Type::u16, 1, vertex.data(), 0},
                          {"COEF_X", Kind::generic, Type::f32, 1, cx.data(), 0},
                          {"COEF_Y", Kind::generic, Type::f32, 1, cx.data(), 0},
                          {"COEF_Z", Kind::generic, Type::f32, 1, cx.data(), 0}},
                         nullptr, 0)
      .bytes;
}

TEST(PoseCorrectivesCodec, RefusesMalformedStreams) {
  const int V = 5;
  const int ids[5] = {0, 1, 2, 3, 4};
  std::vector<float> mixing(size_t(kNumJoints - 1) * 9, 0.5f);
  auto decode = [&](const std::vector<uint8_t>& s, int count, const float* mix) {
    decode_pose_correctives(s.data(), s.size(), count, 1, ids, mix, V, "f.glb", "pc");
  };
  const std::vector<uint8_t> ok = stream({1, 1, 54}, {0, 4, 2}, {0.5f, -1.0f, 1.0f});
  EXPECT_NO_THROW(decode(ok, 3, mixing.data()));
  test::expect_error_at("f.glb", [&] { decode(ok, 2, mixing.data()); }, {"points, the file says"});
  test::expect_error_at("f.glb", [&] { decode(stream({0}, {0}, {1.0f}), 1, mixing.data()); }, {"joint 0 out of range"});
  test::expect_error_at("f.glb", [&] { decode(stream({55}, {0}, {1.0f}), 1, mixing.data()); }, {"joint 55 out of range"});
  test::expect_error_at("f.glb", [&] { decode(stream({3}, {5}, {1.0f}), 1, mixing.data()); }, {"vertex 5 out of range"});
  test::expect_error_at("f.glb", [&] { decode(stream({3, 3}, {2, 2}, {1.0f, 1.0f}), 2, mixing.data()); }, {"strictly increasing"});
  test::expect_error_at("f.glb", [&] { decode(stream({4, 3}, {0, 1}, {1.0f, 1.0f}), 2, mixing.data()); }, {"strictly increasing"});
  const float nan = std::numeric_limits<float>::quiet_NaN();
  test::expect_error_at("f.glb", [&] { decode(stream({3}, {1}, {nan}), 1, mixing.data()); }, {"non-finite coefficient"});
  mixing[17] = INFINITY;
  test::expect_error_at("f.glb", [&] { decode(ok, 3, mixing.data()); }, {"non-finite mixing row"});
}

TEST(PoseCorrectivesCodec, ParsesAndRefusesCodecText) {
  const PoseCorrectiveCodec c = parse_pose_corrective_codec("t=0.1,b=7", "--x");
  EXPECT_EQ(c.threshold, 0.1);
  EXPECT_EQ(c.bits, 7);
  EXPECT_EQ(c.rank, PoseCorrectiveCodec{}.rank);
  for (const char* bad : {"t=1", "r=0", "r=10", "r=2.5", "b=31", "e=0", "x=1", "t=", "t=abc"})
    test::expect_error_at("--x", [&] { parse_pose_corrective_codec(bad, "--x"); }, {"bad entry"});
}

}  // namespace
}  // namespace haha
