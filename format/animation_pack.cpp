#include "format/animation_pack.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <set>

#include "body/body_model.h"
#include "body/rotation.h"
#include "core/error.h"

namespace haha {

using glb::Json;

namespace {

constexpr int kFloat = 5126, kByte = 5120, kShort = 5122;

// One track's stored keys: rotation codes (x, y, z, w, glTF's order) or float translations.
struct Track {
  int node = 0;
  bool translation = false;
  std::vector<int32_t> codes;  // (K, 4) quantized rotations (or float bits when rotation_bits = 0)
  std::vector<float> floats;   // (K, 3) translations
  size_t keys() const { return translation ? floats.size() / 3 : codes.size() / 4; }
};

int32_t quantize(double v, int bits) {
  if (bits == 0) {
    const float f = float(v);
    int32_t i;
    std::memcpy(&i, &f, 4);
    return i;
  }
  const double full = bits == 16 ? 32767.0 : 127.0;
  return int32_t(std::lround(std::clamp(v, -1.0, 1.0) * full));
}

// Joint j's rotations over the motion, sign-continuous (each key in the hemisphere of the
// one before, so a viewer's slerp takes the short way), quantized.
Track rotation_track(const Motion& m, int j, int bits) {
  Track t;
  t.node = j;
  Quat<double> prev{1, 0, 0, 0};
  for (const SmplxParams& f : m.frames) {
    const Vec3<double> w(f.pose[size_t(3 * j)], f.pose[size_t(3 * j + 1)], f.pose[size_t(3 * j + 2)]);
    Quat<double> q = axis_angle_to_quat(w);
    if (q.w * prev.w + q.x * prev.x + q.y * prev.y + q.z * prev.z < 0) q = {-q.w, -q.x, -q.y, -q.z};
    prev = q;
    for (double c : {q.x, q.y, q.z, q.w}) t.codes.push_back(quantize(c, bits));
  }
  return t;
}

// The root node's translation over the motion: rest J0 + transl (spec section 2).
Track translation_track(const Motion& m, const std::vector<double>& rest_joints) {
  Track t;
  t.translation = true;
  for (const SmplxParams& f : m.frames)
    for (int c = 0; c < 3; ++c) t.floats.push_back(float(rest_joints[size_t(c)] + double(f.transl[size_t(c)])));
  return t;
}

// Keeps one key of a track whose keys are all equal; true when that key is the node's rest
// value (identity rotation, rest translation): such a track can be left out.
bool collapse(Track& t, int bits, const std::vector<double>& rest_joints) {
  const size_t n = t.translation ? 3 : 4;
  const size_t K = t.keys();
  bool equal = true;
  for (size_t k = 1; k < K && equal; ++k)
    for (size_t c = 0; c < n; ++c) {
      equal = equal && (t.translation ? t.floats[k * n + c] == t.floats[c] : t.codes[k * n + c] == t.codes[c]);
    }
  if (!equal) return false;
  if (t.translation) {
    t.floats.resize(3);
    for (int c = 0; c < 3; ++c)
      if (t.floats[size_t(c)] != float(rest_joints[size_t(c)])) return false;
    return true;
  }
  t.codes.resize(4);
  return t.codes[0] == 0 && t.codes[1] == 0 && t.codes[2] == 0 && t.codes[3] == quantize(1.0, bits);
}

void append(std::vector<uint8_t>& bytes, const void* p, size_t n) {
  const auto* b = static_cast<const uint8_t*>(p);
  bytes.insert(bytes.end(), b, b + n);
}

void check_motion(const AnimationSource& s) {
  const std::string where = s.motion.source.empty() ? s.name : s.motion.source;
  if (s.motion.frames.empty()) fail(where, "motion has no frames");
  if (!(s.motion.fps > 0) || !std::isfinite(s.motion.fps)) fail(where, "frame rate must be positive");
  for (size_t k = 0; k < s.motion.frames.size(); ++k) {
    const SmplxParams& f = s.motion.frames[k];
    for (float v : f.pose)
      if (!std::isfinite(v)) fail(where, "frame " + std::to_string(k) + ": pose is not finite");
    for (float v : f.transl)
      if (!std::isfinite(v)) fail(where, "frame " + std::to_string(k) + ": translation is not finite");
  }
}

// One animation: its bytes in one bufferView (key times, the one-key time, translations,
// rotations), an accessor per sampler input/output, a channel per kept track.
Json pack_one(glb::BinWriter& bin, Json& accessors, const AnimationSource& s, const std::vector<double>& rest_joints,
              int bits, size_t* bytes_out) {
  const Motion& m = s.motion;
  const size_t K = m.frames.size();
  std::vector<Track> tracks;
  Track tr = translation_track(m, rest_joints);
  if (!collapse(tr, bits, rest_joints)) tracks.push_back(std::move(tr));
  for (int j = 0; j < kNumJoints; ++j) {
    Track r = rotation_track(m, j, bits);
    // The root keeps every key, so the file says the clip's length and rate.
    if (j == 0 || !collapse(r, bits, rest_joints)) tracks.push_back(std::move(r));
  }
  std::vector<float> times(K);
  for (size_t k = 0; k < K; ++k) times[k] = float(double(k) / m.fps);
  std::vector<uint8_t> bytes;
  append(bytes, times.data(), K * 4);
  const size_t one_key_offset = bytes.size();
  const float zero = 0.0f;
  append(bytes, &zero, 4);
  std::vector<size_t> offsets;
  for (const Track& t : tracks) {
    offsets.push_back(bytes.size());
    if (t.translation) {
      append(bytes, t.floats.data(), t.floats.size() * 4);
      continue;
    }
    for (int32_t c : t.codes) {
      if (bits == 16) { const int16_t v = int16_t(c); append(bytes, &v, 2); }
      else if (bits == 8) { const int8_t v = int8_t(c); append(bytes, &v, 1); }
      else append(bytes, &c, 4);
    }
  }
  const int view = bin.add_view(bytes.data(), bytes.size());
  *bytes_out = bytes.size();
  auto add = [&](Json acc) {
    acc["bufferView"] = view;
    accessors.push_back(std::move(acc));
    return int(accessors.size()) - 1;
  };
  const int all_keys = add({{"byteOffset", 0}, {"componentType", kFloat}, {"count", K}, {"type", "SCALAR"},
                            {"min", {glb::json_float(times[0])}}, {"max", {glb::json_float(times[K - 1])}}});
  const int one_key = add({{"byteOffset", one_key_offset}, {"componentType", kFloat}, {"count", 1}, {"type", "SCALAR"},
                           {"min", {0.0}}, {"max", {0.0}}});
  Json samplers = Json::array(), channels = Json::array();
  for (size_t i = 0; i < tracks.size(); ++i) {
    const Track& t = tracks[i];
    Json out = {{"byteOffset", offsets[i]}, {"count", t.keys()}, {"type", t.translation ? "VEC3" : "VEC4"}};
    out["componentType"] = t.translation || bits == 0 ? kFloat : bits == 16 ? kShort : kByte;
    if (!t.translation && bits != 0) out["normalized"] = true;
    samplers.push_back({{"input", t.keys() == K ? all_keys : one_key}, {"output", add(out)}, {"interpolation", "LINEAR"}});
    channels.push_back({{"sampler", i}, {"target", {{"node", t.node}, {"path", t.translation ? "translation" : "rotation"}}}});
  }
  return {{"name", s.name}, {"samplers", samplers}, {"channels", channels}};
}

}  // namespace

double animation_component_error(int rotation_bits) {
  return rotation_bits == 16 ? 0.5 / 32767.0 : rotation_bits == 8 ? 0.5 / 127.0 : 0.0;
}

Json pack_animations(glb::BinWriter& bin, Json& accessors, const std::vector<AnimationSource>& sources,
                     const std::vector<double>& rest_joints, int rotation_bits, std::vector<size_t>* bytes_each) {
  if (rotation_bits != 0 && rotation_bits != 8 && rotation_bits != 16) {
    fail("--animation-bits", "must be 16 (normalized short), 8 (normalized byte) or 0 (float32), got " + std::to_string(rotation_bits));
  }
  std::set<std::string> names;
  Json animations = Json::array();
  for (const AnimationSource& s : sources) {
    if (s.name.empty()) fail(s.motion.source, "animation has an empty name");
    if (!names.insert(s.name).second) fail(s.name, "two animations have this name (give --animation-name)");
    check_motion(s);
    Motion m = s.motion;
    motion_to_y_up(m, {rest_joints[0], rest_joints[1], rest_joints[2]});
    size_t bytes = 0;
    animations.push_back(pack_one(bin, accessors, {s.name, std::move(m)}, rest_joints, rotation_bits, &bytes));
    if (bytes_each) bytes_each->push_back(bytes);
  }
  return animations;
}

}  // namespace haha
