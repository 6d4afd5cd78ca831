// glTF animations in the .glb (format/animation_pack.h, format/animation_unpack.h): a packed
// motion reads back within the rotation quantization's bound, a file without animations is
// the file it always was, and a malformed animation is rejected with a one-line message.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <functional>

#include "body/rotation.h"
#include "core/error.h"
#include "format/animation.h"
#include "format/avatar_loader.h"
#include "format/avatar_pack.h"
#include "format/avatar_unpack.h"
#include "format/glb.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

// A smooth motion moving the root and every body joint (hands and face still), with a
// root turn past pi so keys cross the quaternion sign boundary, and a travelling root.
Motion test_motion(int frames, double fps) {
  Motion m;
  m.fps = fps;
  m.source = "test_motion";
  for (int k = 0; k < frames; ++k) {
    const double t = k / fps;
    SmplxParams p;
    for (int j = 0; j <= 21; ++j)
      for (int c = 0; c < 3; ++c) p.pose[size_t(3 * j + c)] = float(0.6 * std::sin(0.7 * (j + 1) * t + 1.3 * c + 0.2 * j));
    p.pose[1] = float(0.9 * t);  // the root keeps turning about +Y
    p.transl = {float(0.3 * t), float(0.05 * std::sin(4 * t)), float(-0.1 * t)};
    m.frames.push_back(p);
  }
  return m;
}

double rotation_angle(const float* a, const float* b) {
  const Quat<double> qa = axis_angle_to_quat(Vec3<double>(a[0], a[1], a[2]));
  const Quat<double> qb = axis_angle_to_quat(Vec3<double>(b[0], b[1], b[2]));
  const double d = std::fabs(qa.w * qb.w + qa.x * qb.x + qa.y * qb.y + qa.z * qb.z);
  return 2 * std::acos(std::min(1.0, d));
}

std::vector<uint8_t> pack_with(const Motion& m, int bits, double tolerance = 0, const std::string& name = "walk") {
  PackOptions o;
  o.animations.push_back({name, m, tolerance});
  o.animation_bits = bits;
  return pack_avatar(test::make_test_avatar(40, 2, 8, 8), o);
}

// Largest joint-rotation angle (rad) and translation error (m) of the file's animation
// against the motion, at every frame time.
std::pair<double, double> worst_error(const std::vector<uint8_t>& glb, const Motion& m) {
  const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
  EXPECT_EQ(u.animations.size(), 1u);
  double angle = 0, move = 0;
  for (size_t k = 0; k < m.frames.size(); ++k) {
    const SmplxParams s = sample_animation(u.animations[0], double(k) / m.fps);
    for (int j = 0; j < kNumJoints; ++j)
      angle = std::max(angle, rotation_angle(&s.pose[size_t(3 * j)], &m.frames[k].pose[size_t(3 * j)]));
    for (int c = 0; c < 3; ++c) move = std::max(move, double(std::fabs(s.transl[size_t(c)] - m.frames[k].transl[size_t(c)])));
  }
  return {angle, move};
}

TEST(FormatAnimation, RoundTripIsWithinTheQuantizationBound) {
  const Motion m = test_motion(60, 30);
  for (int bits : {16, 8, 0}) {
    // A stored component is off by at most e = animation_component_error(bits); the angle
    // between unit quaternions is <= 2 |dq| <= 2 * 2e, plus float rounding.
    const double bound = 4 * animation_component_error(bits) + 2e-6;
    const auto [angle, move] = worst_error(pack_with(m, bits), m);
    EXPECT_LE(angle, bound) << bits << " bits";
    EXPECT_LE(move, 2e-6) << bits << " bits: translations are float32";
    std::printf("%2d bits: worst joint rotation error %.3g rad (bound %.3g), translation %.3g m\n", bits, angle, bound, move);
  }
}

// Keyframe reduction: every frame of the motion plays back within the tolerance plus the
// quantization bound (rotations) or the tolerance in metres (translation); smooth tracks keep
// fewer keys than frames, each track ends on the last frame (the clip's length is the
// largest input), tracks with the same kept frames share one input, and the file says the rate.
TEST(FormatAnimation, ReducedKeysStayWithinTheTolerance) {
  const Motion m = test_motion(300, 30);
  for (auto [tol, bits] : {std::pair{1e-3, 16}, {1e-2, 16}, {1e-3, 8}}) {
    const std::vector<uint8_t> glb = pack_with(m, bits, tol);
    const auto [angle, move] = worst_error(glb, m);
    // The reduction's error on the motion plus the quantization's at the kept keys.
    const double bound = tol + 4 * animation_component_error(bits) + 2e-6;
    EXPECT_LE(angle, bound) << tol << " rad, " << bits << " bits";
    EXPECT_LE(move, tol + 2e-6) << tol;
    const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
    const AvatarAnimation& a = u.animations[0];
    EXPECT_EQ(a.frames, 300);
    EXPECT_NEAR(animation_rate(a), 30.0, 1e-3);
    size_t keys = 0;
    for (const AnimationTrack& t : a.tracks) {
      keys += t.times.size();
      EXPECT_EQ(t.times.front(), 0.0f);
      EXPECT_NEAR(t.times.back(), 299 / 30.0, 1e-6) << "joint " << t.joint;
    }
    EXPECT_LT(keys, a.tracks.size() * 300) << "nothing was dropped";
    const glb::Glb g = glb::parse_glb(glb.data(), glb.size(), "mem.glb");
    std::map<int, size_t> inputs;  // input accessor -> its key count
    std::set<std::vector<float>> key_sets;
    for (const AnimationTrack& t : a.tracks) key_sets.insert(t.times);
    for (const auto& s : g.json["animations"][0]["samplers"]) inputs[s["input"].get<int>()] = 0;
    EXPECT_EQ(inputs.size(), key_sets.size()) << "tracks with the same keys share one input";
    std::printf("%d bits, tolerance %.0e rad: %zu of %zu keys kept, %zu inputs, worst rotation error %.3g rad, translation %.3g m\n",
                bits, tol, keys, a.tracks.size() * 300, inputs.size(), angle, move);
  }
  // A still motion: every track keeps its first and last frames (only), so the clip keeps its
  // length; so does a still track with every key asked for.
  Motion still = m;
  for (SmplxParams& f : still.frames) f = m.frames[0];
  const std::vector<uint8_t> glb = pack_with(still, 16, 1e-3);
  const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
  EXPECT_NEAR(u.animations[0].duration, 299 / 30.0, 1e-6);
  for (const AnimationTrack& t : u.animations[0].tracks) EXPECT_EQ(t.times.size(), 2u);
  const std::vector<uint8_t> every = pack_with(still, 16, 0.0);
  const UnpackedAvatar ue = unpack_avatar(every.data(), every.size(), "mem.glb");
  for (const AnimationTrack& t : ue.animations[0].tracks) EXPECT_EQ(t.times.size(), 2u);
  PackOptions bad;
  bad.animations.push_back({"walk", m, -1.0});
  EXPECT_THROW(pack_avatar(test::make_test_avatar(40, 2, 8, 8), bad), Error);
}

TEST(FormatAnimation, SamplesBetweenKeysLikeTheMotionsResampler) {
  const Motion m = test_motion(31, 30);
  const std::vector<uint8_t> glb = pack_with(m, 0);
  const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
  const AvatarAnimation& a = u.animations[0];
  EXPECT_EQ(a.name, "walk");
  EXPECT_EQ(a.tracks[0].times.size(), 31u);  // tolerance 0: every key
  EXPECT_EQ(a.frames, 31);
  EXPECT_NEAR(a.duration, 1.0, 1e-6);
  EXPECT_NEAR(animation_rate(a), 30.0, 1e-4);
  const Motion fine = resample_motion(m, 75);  // slerp between the motion's frames
  const Motion played = animation_motion(a, 75);
  ASSERT_EQ(played.frames.size(), fine.frames.size());
  double worst = 0;
  for (size_t k = 0; k < fine.frames.size(); ++k)
    for (int j = 0; j < kNumJoints; ++j)
      worst = std::max(worst, rotation_angle(&played.frames[k].pose[size_t(3 * j)], &fine.frames[k].pose[size_t(3 * j)]));
  EXPECT_LE(worst, 1e-5);
}

TEST(FormatAnimation, WithoutAnimationsTheFileIsUnchanged) {
  const Avatar a = test::make_test_avatar(40, 2, 8, 8);
  PackOptions plain, empty;
  empty.animation_bits = 8;  // no animation: the setting must not matter
  const std::vector<uint8_t> x = pack_avatar(a, plain), y = pack_avatar(a, empty);
  EXPECT_EQ(x, y);
  EXPECT_EQ(glb::parse_glb(x.data(), x.size(), "x").json.count("animations"), 0u);
  EXPECT_TRUE(unpack_avatar(x.data(), x.size(), "x").animations.empty());
  // Adding an animation appends: the avatar's own parts keep their bytes.
  const std::vector<uint8_t> z = pack_with(test_motion(10, 30), 16);
  const glb::Glb gx = glb::parse_glb(x.data(), x.size(), "x"), gz = glb::parse_glb(z.data(), z.size(), "z");
  ASSERT_GT(gz.bin.size(), gx.bin.size());
  EXPECT_TRUE(std::equal(gx.bin.begin(), gx.bin.end(), gz.bin.begin()));
}

TEST(FormatAnimation, InfoListsNamesFramesAndBytes) {
  PackOptions o;
  o.animations.push_back({"walk", test_motion(30, 30)});
  o.animations.push_back({"still", test_motion(1, 30)});
  PackedSizes sz;
  const std::vector<uint8_t> glb = pack_avatar(test::make_test_avatar(40, 2, 8, 8), o, &sz);
  const UnpackedAvatar u = unpack_avatar(glb.data(), glb.size(), "mem.glb");
  ASSERT_EQ(u.animations.size(), 2u);
  EXPECT_EQ(u.animations[1].name, "still");
  EXPECT_EQ(u.animations[1].frames, 1);
  EXPECT_EQ(u.animations[1].duration, 0.0);
  EXPECT_EQ(u.info.sizes.animations, sz.animations);
  EXPECT_EQ(u.animations[0].bytes + u.animations[1].bytes, sz.animations);
  EXPECT_EQ(find_animation(u.animations, "still", "mem.glb"), 1u);
  EXPECT_EQ(find_animation(u.animations, "0", "mem.glb"), 0u);
  EXPECT_THROW(find_animation(u.animations, "run", "mem.glb"), Error);
  o.animations[1].name = "walk";
  EXPECT_THROW(pack_avatar(test::make_test_avatar(40, 2, 8, 8), o), Error);  // names are unique
}

// The packed file with its JSON changed by `edit`; unpacking it must fail naming the file
// and the animation.
void expect_rejected(const std::function<void(glb::Json&)>& edit, const std::string& needle,
                     const std::function<void(glb::Glb&)>& edit_bin = nullptr) {
  const std::vector<uint8_t> good = pack_with(test_motion(8, 30), 16, kDefaultAnimationTolerance);
  glb::Glb g = glb::parse_glb(good.data(), good.size(), "good.glb");
  edit(g.json);
  if (edit_bin) edit_bin(g);
  const std::vector<uint8_t> bad = glb::write_glb(g.json, g.bin);
  try {
    unpack_avatar(bad.data(), bad.size(), "bad.glb");
    ADD_FAILURE() << "accepted a file with " << needle;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind("bad.glb: ", 0), 0u) << msg;
    EXPECT_NE(msg.find(needle), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST(FormatAnimation, MalformedAnimationsAreRejectedWithAMessage) {
  using J = glb::Json;
  auto sampler = [](J& j) -> J& { return j["animations"][0]["samplers"][1]; };
  expect_rejected([&](J& j) { sampler(j)["interpolation"] = "CUBICSPLINE"; }, "not supported");
  expect_rejected([&](J& j) { sampler(j)["output"] = 100000; }, "accessors[100000]");
  expect_rejected([&](J& j) { j["animations"][0]["channels"][1]["target"]["path"] = "scale"; }, "scale");
  expect_rejected([&](J& j) { j["animations"][0]["channels"][1]["target"]["node"] = 3; j["animations"][0]["channels"][1]["target"]["path"] = "translation"; }, "root");
  expect_rejected([&](J& j) { j["animations"][0]["channels"] = J::array(); }, "channels");
  expect_rejected([&](J& j) { j["animations"][0]["channels"].push_back(j["animations"][0]["channels"][1]); }, "same joint");
  expect_rejected([&](J& j) {  // the key times accessor read as decreasing: point it at the rotations
    const int out = sampler(j)["output"].get<int>();
    j["accessors"][size_t(out)]["count"] = 1000000;
  }, "animations[0]");
  expect_rejected([](J&) {}, "increasing", [&](glb::Glb& g) {  // the second key time of sampler 1 set to the first
    const J& acc = g.json["accessors"][size_t(sampler(g.json)["input"].get<int>())];
    const size_t at = g.json["bufferViews"][size_t(acc["bufferView"].get<int>())].value("byteOffset", size_t(0)) +
                      acc.value("byteOffset", size_t(0));
    std::memcpy(&g.bin[at + 4], &g.bin[at], 4);
  });
}

TEST(FormatAnimation, LoaderPlaysTheFilesAnimation) {
  const Motion m = test_motion(20, 30);
  const std::string path = testing::TempDir() + "/haha-animation-test.glb";
  {
    PackOptions o;
    o.animations.push_back({"walk", m, 0.0});
    write_avatar_glb(test::make_test_avatar(40, 2, 8, 8), path, o);
  }
  const AvatarLoader loader = AvatarLoader::load(path);
  ASSERT_EQ(loader.animations().size(), 1u);
  PosedAvatar from_file, from_motion;
  loader.repose(sample_animation(loader.animations()[0], 10 / 30.0), from_file);
  loader.repose(m.frames[10], from_motion);
  double worst = 0;
  for (size_t i = 0; i < from_file.verts.size(); ++i) worst = std::max(worst, double(std::fabs(from_file.verts[i] - from_motion.verts[i])));
  EXPECT_LE(worst, 1e-4);  // metres: the 16-bit rotations move a ~1 m body by well under a millimetre
}

}  // namespace
}  // namespace haha
