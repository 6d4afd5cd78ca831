// An independent glTF loader (tinygltf, with its own Draco decoding) reads the packed file
// as a plain skinned, textured avatar: 55 joints with identity rest rotations, inverse bind
// matrices that undo the joint translations, and the body's faces in the body's order.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_ENABLE_DRACO
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define STB_IMAGE_IMPLEMENTATION
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <cmath>
#include <cstring>

#include "body/face_frames.h"
#include "format/avatar_pack.h"
#include "support/format_test_avatar.h"

namespace haha {
namespace {

template <class T>
std::vector<T> read_accessor(const tinygltf::Model& m, int index, int comps) {
  const tinygltf::Accessor& acc = m.accessors[size_t(index)];
  const tinygltf::BufferView& bv = m.bufferViews[size_t(acc.bufferView)];
  const tinygltf::Buffer& buf = m.buffers[size_t(bv.buffer)];
  std::vector<T> out(acc.count * size_t(comps));
  std::memcpy(out.data(), buf.data.data() + bv.byteOffset + acc.byteOffset, out.size() * sizeof(T));
  return out;
}

TEST(FormatInterop, TinyGltfLoadsASkinnedTexturedMeshInBodyFaceOrder) {
  const Avatar a = test::make_test_avatar(50, 2, 16, 16);
  PackOptions opt;
  opt.texture_codec = TextureCodec::png;  // stb_image decodes png/jpg (not webp)
  const std::vector<uint8_t> bytes = pack_avatar(a, opt);
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromMemory(&m, &err, &warn, bytes.data(), unsigned(bytes.size()))) << err;
  EXPECT_TRUE(err.empty()) << err;
  ASSERT_EQ(m.skins.size(), 1u);
  ASSERT_EQ(m.skins[0].joints.size(), 55u);
  ASSERT_EQ(m.meshes.size(), 1u);
  ASSERT_EQ(m.images.size(), 1u);
  EXPECT_EQ(m.images[0].width, 16);
  EXPECT_EQ(m.images[0].height, 16);

  // Joint j's world rest transform is the sum of translations along its chain (rotations
  // identity); its inverse bind matrix must be the inverse: translation by -world.
  const std::vector<float> ibm = read_accessor<float>(m, m.skins[0].inverseBindMatrices, 16);
  std::vector<double> world(55 * 3, 0.0);
  for (int j = 0; j < 55; ++j) {
    const tinygltf::Node& n = m.nodes[size_t(m.skins[0].joints[size_t(j)])];
    EXPECT_TRUE(n.rotation.empty() || (n.rotation[3] == 1 && n.rotation[0] == 0));
    const int p = a.body.parents[size_t(j)];
    for (int k = 0; k < 3; ++k) world[size_t(j) * 3 + k] = n.translation[size_t(k)] + (p >= 0 ? world[size_t(p) * 3 + k] : 0.0);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(ibm[size_t(j) * 16 + 12 + k], -world[size_t(j) * 3 + k], 1e-6);
  }

  // Decoded by tinygltf's Draco path: corner c of face f sits at the body's vertex
  // faces[f][c] in the rest shape (16-bit positions).
  const tinygltf::Primitive& prim = m.meshes[0].primitives[0];
  const std::vector<float> pos = read_accessor<float>(m, prim.attributes.at("POSITION"), 3);
  const std::vector<uint16_t> idx = read_accessor<uint16_t>(m, prim.indices, 1);
  ASSERT_EQ(idx.size(), a.body.faces.size());
  const std::vector<float> rest = baked_rest_vertices(a);
  for (size_t c = 0; c < idx.size(); ++c)
    for (int k = 0; k < 3; ++k)
      ASSERT_NEAR(pos[size_t(idx[c]) * 3 + k], rest[size_t(a.body.faces[c]) * 3 + k], 5e-5) << "corner " << c;
  EXPECT_TRUE(prim.attributes.count("JOINTS_0") && prim.attributes.count("WEIGHTS_0") && prim.attributes.count("TEXCOORD_0"));
}

TEST(FormatInterop, KhrGaussianSplattingPrimitiveHoldsTheRestPoseGaussians) {
  const Avatar a = test::make_test_avatar(80, 2, 16, 16);
  PackOptions opt;
  opt.texture_codec = TextureCodec::png;
  opt.khr_gaussian_splatting = true;
  const std::vector<uint8_t> bytes = pack_avatar(a, opt);
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromMemory(&m, &err, &warn, bytes.data(), unsigned(bytes.size()))) << err;
  ASSERT_EQ(m.meshes.size(), 2u);
  const tinygltf::Primitive& p = m.meshes[1].primitives[0];
  EXPECT_EQ(p.mode, TINYGLTF_MODE_POINTS);
  ASSERT_TRUE(p.extensions.count("KHR_gaussian_splatting"));
  EXPECT_EQ(p.extensions.at("KHR_gaussian_splatting").Get("kernel").Get<std::string>(), "ellipse");
  EXPECT_EQ(p.extensions.at("KHR_gaussian_splatting").Get("colorSpace").Get<std::string>(), "srgb_rec709_display");
  const std::vector<float> pos = read_accessor<float>(m, p.attributes.at("POSITION"), 3);
  const std::vector<float> rot = read_accessor<float>(m, p.attributes.at("KHR_gaussian_splatting:ROTATION"), 4);
  const std::vector<float> scl = read_accessor<float>(m, p.attributes.at("KHR_gaussian_splatting:SCALE"), 3);
  const std::vector<float> op = read_accessor<float>(m, p.attributes.at("KHR_gaussian_splatting:OPACITY"), 1);
  const std::vector<float> sh = read_accessor<float>(m, p.attributes.at("KHR_gaussian_splatting:SH_DEGREE_0_COEF_0"), 3);
  // Expected: the face frames of the baked rest mesh applied to the local Gaussians.
  const int N = a.gaussians.size();
  std::vector<float> mean(size_t(N) * 3), quat(size_t(N) * 4), scale(size_t(N) * 3);
  const std::vector<float> rest = baked_rest_vertices(a);
  pose_gaussians(rest.data(), a.body, a.face_scale_divisor, a.gaussians, mean.data(), quat.data(), scale.data());
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(pos[size_t(i) * 3 + k], mean[size_t(i) * 3 + k]);
      ASSERT_EQ(scl[size_t(i) * 3 + k], scale[size_t(i) * 3 + k]);  // linear, not log
      ASSERT_NEAR(sh[size_t(i) * 3 + k] * 0.2820948f + 0.5f, a.gaussians.color[size_t(i) * 3 + k], 1e-6f);
    }
    const float* q = &quat[size_t(i) * 4];
    const float n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(rot[size_t(i) * 4 + k], q[k + 1] / n, 1e-6f);  // x, y, z
    ASSERT_NEAR(rot[size_t(i) * 4 + 3], q[0] / n, 1e-6f);                                   // w last
    ASSERT_EQ(op[size_t(i)], a.gaussians.opacity[size_t(i)]);
  }
}

// tinygltf reads the animations as a viewer would: one per motion, a rotation channel per
// moving joint node with normalized short (x, y, z, w) keys at k / fps (every key with
// tolerance 0), the root's translation J0 + transl; with the default keyframe reduction each
// channel's input still runs from 0 to the last frame's time.
TEST(FormatInterop, TinyGltfReadsTheAnimations) {
  const Avatar a = test::make_test_avatar(20, 2, 8, 8);
  Motion m;
  m.fps = 25;
  for (int k = 0; k < 10; ++k) {
    SmplxParams p;
    p.pose[3 * 16 + 2] = -0.1f * float(k);  // left shoulder about z
    p.transl = {0.0f, 0.01f * float(k), 0.0f};
    m.frames.push_back(p);
  }
  PackOptions opt;
  opt.texture_codec = TextureCodec::png;
  opt.animations = {{"lower_arm", m, 0.0}};
  const std::vector<uint8_t> bytes = pack_avatar(a, opt);
  tinygltf::TinyGLTF loader;
  tinygltf::Model g;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromMemory(&g, &err, &warn, bytes.data(), unsigned(bytes.size()))) << err;
  ASSERT_EQ(g.animations.size(), 1u);
  const tinygltf::Animation& an = g.animations[0];
  EXPECT_EQ(an.name, "lower_arm");
  bool shoulder = false, root_move = false;
  for (const tinygltf::AnimationChannel& ch : an.channels) {
    const tinygltf::AnimationSampler& s = an.samplers[size_t(ch.sampler)];
    EXPECT_EQ(s.interpolation, "LINEAR");
    const std::vector<float> t = read_accessor<float>(g, s.input, 1);
    if (ch.target_node == 16 && ch.target_path == "rotation") {
      shoulder = true;
      const tinygltf::Accessor& out = g.accessors[size_t(s.output)];
      EXPECT_EQ(out.componentType, TINYGLTF_COMPONENT_TYPE_SHORT);
      EXPECT_TRUE(out.normalized);
      const std::vector<int16_t> q = read_accessor<int16_t>(g, s.output, 4);
      ASSERT_EQ(t.size(), 10u);
      for (size_t k = 0; k < 10; ++k) {
        EXPECT_FLOAT_EQ(t[k], float(double(k) / 25));
        const double half = 0.05 * double(k);  // half the angle about -z
        EXPECT_NEAR(q[k * 4 + 2] / 32767.0, -std::sin(half), 1.0 / 32767);
        EXPECT_NEAR(q[k * 4 + 3] / 32767.0, std::cos(half), 1.0 / 32767);
      }
    }
    if (ch.target_node == 0 && ch.target_path == "translation") {
      root_move = true;
      const std::vector<float> v = read_accessor<float>(g, s.output, 3);
      EXPECT_NEAR(v[9 * 3 + 1] - g.nodes[0].translation[1], 0.09, 1e-6);
    }
    EXPECT_TRUE(ch.target_node == 0 || ch.target_path == "rotation");
  }
  EXPECT_TRUE(shoulder && root_move);
  // Default reduction: the shoulder turns at a constant rate and the root moves in a line,
  // so both keep only their first and last keys; every input ends at the clip's end.
  opt.animations[0].tolerance = kDefaultAnimationTolerance;
  const std::vector<uint8_t> reduced = pack_avatar(a, opt);
  tinygltf::Model r;
  ASSERT_TRUE(loader.LoadBinaryFromMemory(&r, &err, &warn, reduced.data(), unsigned(reduced.size()))) << err;
  for (const tinygltf::AnimationChannel& ch : r.animations[0].channels) {
    const std::vector<float> t = read_accessor<float>(r, r.animations[0].samplers[size_t(ch.sampler)].input, 1);
    EXPECT_EQ(t.front(), 0.0f);
    EXPECT_FLOAT_EQ(t.back(), float(9.0 / 25));
    if (ch.target_node == 16 || ch.target_path == "translation") EXPECT_EQ(t.size(), 2u) << ch.target_node;
  }
}

}  // namespace
}  // namespace haha
