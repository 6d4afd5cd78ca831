// Synthetic rigs for the retargeting tests: an SMPL-X motion replayed by a skeleton with
// other bone names, another rest pose (an A-pose) and other bone axes, written as BVH or
// glTF by the test itself, so that retargeting it back must give the original motion.
// Built from world quantities: each bone has a rest world frame Rs0 and position X, and per
// frame a world rotation Rs(t); the file's local transforms follow from them.
#pragma once

#include <cmath>
#include <cstring>
#include <cstdio>
#include <string>
#include <vector>

#include <tiny_gltf.h>

#include "app/motion_retarget.h"
#include "body/rest_skeleton.h"
#include "body/rotation.h"
#include "io/motion.h"
#include "io/motion_bvh.h"

namespace haha::test {

using V3 = Vec3<double>;
using M3 = Mat3<double>;

struct RigBone {
  std::string name;
  int parent = -1;      // index into the rig's bones
  int joint = -1;       // the SMPL-X joint it plays, or -1 (an extra bone)
  M3 rest_rot = M3::identity();  // Rs0: world frame at rest
  V3 rest_pos;                   // X: world position at rest
  std::vector<M3> rot;           // Rs(t)
};

struct Rig {
  std::vector<RigBone> bones;  // parents first
  std::vector<V3> root;        // root position per frame (world)
  double fps = 30;
  double units = 1;            // file units per metre (100: centimetres)
};

// World rotations of every SMPL-X joint in frame p (forward kinematics of the locals).
inline std::vector<M3> smplx_world(const SmplxParams& p, const RestSkeleton& s) {
  std::vector<M3> G(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) {
    const M3 L = rodrigues(V3(p.pose[size_t(3 * j)], p.pose[size_t(3 * j + 1)], p.pose[size_t(3 * j + 2)]));
    G[size_t(j)] = s.parents[size_t(j)] < 0 ? L : G[size_t(s.parents[size_t(j)])] * L;
  }
  return G;
}

inline M3 rot_z(double a) {
  M3 r = M3::identity();
  r.a[0][0] = r.a[1][1] = std::cos(a), r.a[0][1] = -std::sin(a), r.a[1][0] = std::sin(a);
  return r;
}

struct RigBoneSpec {
  const char* name;
  int joint;   // SMPL-X joint, or -1 for an extra bone
  int parent;  // index into the spec list
};

// The rig of `specs` playing `m` (Y-up, haha's world). `a_pose_deg`: the upper arms and
// forearms rest that far below horizontal (their rest bone directions turned down, the hands
// and fingers turned with the forearms). `axes_seed` != 0: every bone's rest frame is a different rotation
// (else identity, as BVH requires). An extra bone sits halfway between its parent and its
// first child, and wobbles.
inline Rig make_rig(const Motion& m, const RestSkeleton& s, const std::vector<RigBoneSpec>& specs, double a_pose_deg,
                    unsigned axes_seed, double units) {
  Rig rig;
  rig.fps = m.fps;
  rig.units = units;
  std::vector<M3> GA(kNumJoints, M3::identity());  // A-pose world rotation of each joint
  const double a = a_pose_deg * M_PI / 180;
  for (const auto& [j, child, sign] : {std::tuple{16, 18, -1}, std::tuple{18, 20, -1}, std::tuple{17, 19, 1}, std::tuple{19, 21, 1}}) {
    const V3 d = s.joints[size_t(child)] - s.joints[size_t(j)];
    const V3 dn = d / norm(d);
    GA[size_t(j)] = rotation_between(dn, rot_z(sign * a) * dn);
  }
  GA[20] = GA[18], GA[21] = GA[19];
  for (int j = kLeftHandFirst; j < kNumJoints; ++j) GA[size_t(j)] = j < kRightHandFirst ? GA[20] : GA[21];
  std::vector<V3> X(kNumJoints);  // A-pose rest positions
  for (int j = 0; j < kNumJoints; ++j) {
    const int p = s.parents[size_t(j)];
    X[size_t(j)] = p < 0 ? s.joints[0] : X[size_t(p)] + GA[size_t(p)] * (s.joints[size_t(j)] - s.joints[size_t(p)]);
  }
  unsigned state = axes_seed;
  const auto random_rot = [&state]() {
    state = state * 1664525u + 1013904223u;
    const double u = double(state >> 8) / double(1u << 24);
    state = state * 1664525u + 1013904223u;
    const double v = double(state >> 8) / double(1u << 24);
    return rodrigues(V3(2.5 * (u - 0.5), 1.7 * std::sin(7 * v), 0.9 + u * v));
  };
  std::vector<std::vector<M3>> G;
  for (const SmplxParams& p : m.frames) {
    G.push_back(smplx_world(p, s));
    rig.root.push_back(s.joints[0] + V3(p.transl[0], p.transl[1], p.transl[2]));
  }
  for (size_t b = 0; b < specs.size(); ++b) {
    RigBone bone{specs[b].name, specs[b].parent, specs[b].joint, M3::identity(), V3(), {}};
    const M3 frame = axes_seed ? random_rot() : M3::identity();
    if (bone.joint >= 0) {
      const int j = bone.joint;
      // BVH: rest frames are the world's, so Rs0 = I and Rs(t) = G(t) GA^-1; otherwise Rs0 = GA F.
      bone.rest_rot = axes_seed ? GA[size_t(j)] * frame : M3::identity();
      bone.rest_pos = X[size_t(j)];
      for (const auto& g : G) bone.rot.push_back(g[size_t(j)] * transpose(GA[size_t(j)]) * bone.rest_rot);
    } else {
      int child = -1;
      for (size_t c = b + 1; c < specs.size() && child < 0; ++c)
        if (specs[c].parent == int(b)) child = specs[c].joint;
      bone.rest_rot = frame;
      bone.rest_pos = 0.5 * (X[size_t(child)] + rig.bones[size_t(bone.parent)].rest_pos);
      for (size_t t = 0; t < G.size(); ++t)
        bone.rot.push_back(rodrigues(V3(0.3 * std::sin(0.4 * double(t)), 0.2, -0.25 * std::cos(0.3 * double(t)))) * frame);
    }
    rig.bones.push_back(bone);
  }
  return rig;
}

// The whole rig turned by W about the world origin (another up axis or facing). The bones'
// frames turn with the world (W R W^T), so world-aligned rest frames (BVH) stay so.
inline void turn_rig(Rig& r, const M3& W) {
  for (RigBone& b : r.bones) {
    b.rest_rot = W * b.rest_rot * transpose(W);
    b.rest_pos = W * b.rest_pos;
    for (M3& R : b.rot) R = W * R * transpose(W);
  }
  for (V3& p : r.root) p = W * p;
}

// Local rest translation (file units) and rotation of bone b; local rotation in frame t.
inline V3 rig_offset(const Rig& r, size_t b) {
  const RigBone& x = r.bones[b];
  if (x.parent < 0) return r.units * x.rest_pos;
  const RigBone& p = r.bones[size_t(x.parent)];
  return r.units * (transpose(p.rest_rot) * (x.rest_pos - p.rest_pos));
}
inline M3 rig_rest_local(const Rig& r, size_t b) {
  const RigBone& x = r.bones[b];
  return x.parent < 0 ? x.rest_rot : transpose(r.bones[size_t(x.parent)].rest_rot) * x.rest_rot;
}
inline M3 rig_local(const Rig& r, size_t b, size_t t) {
  const RigBone& x = r.bones[b];
  return x.parent < 0 ? x.rot[t] : transpose(r.bones[size_t(x.parent)].rot[t]) * x.rot[t];
}

// The rig as BVH (rest frames must be the world's: make_rig with axes_seed 0).
inline std::string rig_bvh(const Rig& r) {
  std::string out = "HIERARCHY\n";
  char buf[256];
  const auto write_bone = [&](auto&& self, size_t b, int depth) -> void {
    const std::string pad(size_t(2 * depth), ' ');
    const V3 o = r.bones[b].parent < 0 ? V3(0, 0, 0) : rig_offset(r, b);
    std::snprintf(buf, sizeof buf, "%s%s %s\n%s{\n%s  OFFSET %.6f %.6f %.6f\n", pad.c_str(), depth ? "JOINT" : "ROOT",
                  r.bones[b].name.c_str(), pad.c_str(), pad.c_str(), o.x, o.y, o.z);
    out += buf;
    out += pad + (depth ? "  CHANNELS 3 Zrotation Yrotation Xrotation\n" : "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n");
    bool leaf = true;
    for (size_t c = 0; c < r.bones.size(); ++c)
      if (r.bones[c].parent == int(b)) leaf = false, self(self, c, depth + 1);
    if (leaf) out += pad + "  End Site\n" + pad + "  {\n" + pad + "    OFFSET 0 5 0\n" + pad + "  }\n";
    out += pad + "}\n";
  };
  write_bone(write_bone, 0, 0);
  std::vector<size_t> order;
  const auto walk = [&](auto&& self, size_t b) -> void {
    order.push_back(b);
    for (size_t c = 0; c < r.bones.size(); ++c)
      if (r.bones[c].parent == int(b)) self(self, c);
  };
  walk(walk, 0);
  std::snprintf(buf, sizeof buf, "MOTION\nFrames: %zu\nFrame Time: %.9f\n", r.root.size(), 1.0 / r.fps);
  out += buf;
  for (size_t t = 0; t < r.root.size(); ++t) {
    const V3 p = r.units * r.root[t];
    std::snprintf(buf, sizeof buf, "%.6f %.6f %.6f", p.x, p.y, p.z);
    out += buf;
    for (size_t b : order) {
      const V3 e = (180 / M_PI) * matrix_to_euler_zyx(rig_local(r, b, t));
      std::snprintf(buf, sizeof buf, " %.6f %.6f %.6f", e.x, e.y, e.z);
      out += buf;
    }
    out += "\n";
  }
  return out;
}

// The rig as a binary glTF (.glb) with one animation `take`: node rotations per frame
// (LINEAR), the root's translation.
inline void write_rig_glb(const Rig& r, const std::string& path, const std::string& take = "Take 001") {
  tinygltf::Model model;
  std::vector<float> data;
  const auto add_accessor = [&](const std::vector<float>& values, int type, int count) {
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = data.size() * 4;
    view.byteLength = values.size() * 4;
    model.bufferViews.push_back(view);
    data.insert(data.end(), values.begin(), values.end());
    tinygltf::Accessor acc;
    acc.bufferView = int(model.bufferViews.size() - 1);
    acc.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    acc.count = size_t(count);
    acc.type = type;
    if (type == TINYGLTF_TYPE_SCALAR) acc.minValues = {values.front()}, acc.maxValues = {values.back()};
    model.accessors.push_back(acc);
    return int(model.accessors.size() - 1);
  };
  const size_t T = r.root.size();
  std::vector<float> times;
  for (size_t t = 0; t < T; ++t) times.push_back(float(double(t) / r.fps));
  const int input = add_accessor(times, TINYGLTF_TYPE_SCALAR, int(T));
  tinygltf::Animation anim;
  anim.name = take;
  // One LINEAR channel of `path` on `node`, its keys `values` (T of them).
  const auto add_channel = [&](const std::vector<float>& values, int type, int node, const char* path) {
    tinygltf::AnimationSampler sampler;
    sampler.input = input;
    sampler.output = add_accessor(values, type, int(T));
    sampler.interpolation = "LINEAR";
    anim.samplers.push_back(sampler);
    tinygltf::AnimationChannel ch;
    ch.sampler = int(anim.samplers.size() - 1);
    ch.target_node = node;
    ch.target_path = path;
    anim.channels.push_back(ch);
  };
  for (size_t b = 0; b < r.bones.size(); ++b) {
    tinygltf::Node node;
    node.name = r.bones[b].name;
    const V3 o = rig_offset(r, b);
    node.translation = {o.x, o.y, o.z};
    const Quat<double> q = mat_to_quat(rig_rest_local(r, b));
    node.rotation = {q.x, q.y, q.z, q.w};
    for (size_t c = 0; c < r.bones.size(); ++c)
      if (r.bones[c].parent == int(b)) node.children.push_back(int(c));
    model.nodes.push_back(node);
    std::vector<float> rot;
    for (size_t t = 0; t < T; ++t) {
      const Quat<double> k = mat_to_quat(rig_local(r, b, t));
      rot.insert(rot.end(), {float(k.x), float(k.y), float(k.z), float(k.w)});
    }
    add_channel(rot, TINYGLTF_TYPE_VEC4, int(b), "rotation");
  }
  std::vector<float> root;
  for (const V3& p : r.root) root.insert(root.end(), {float(r.units * p.x), float(r.units * p.y), float(r.units * p.z)});
  add_channel(root, TINYGLTF_TYPE_VEC3, 0, "translation");
  model.animations.push_back(anim);
  tinygltf::Buffer buffer;
  buffer.data.resize(data.size() * 4);
  std::memcpy(buffer.data.data(), data.data(), buffer.data.size());
  model.buffers.push_back(buffer);
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  model.asset.version = "2.0";
  tinygltf::TinyGLTF writer;
  writer.WriteGltfSceneToFile(&model, path, false, true, false, true);
}

}  // namespace haha::test
