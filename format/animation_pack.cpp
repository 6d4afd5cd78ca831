#include "format/animation_pack.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>

#include "body/body_model.h"
#include "body/rotation.h"
#include "core/error.h"
#include "io/motion.h"

namespace haha {

using glb::Json;

namespace {

constexpr int kFloat = 5126, kByte = 5120, kShort = 5122;

// One track's stored keys: rotation codes (x, y, z, w, glTF's order) or float translations,
// one per frame of the motion, and the frames the reduction keeps (all by default).
struct Track {
  int node = 0;
  bool translation = false;
  std::vector<int32_t> codes;  // (K, 4) quantized rotations (or float bits when rotation_bits = 0)
  std::vector<Quat<double>> exact;  // (K) the motion's rotations, sign-continuous
  std::vector<float> floats;   // (K, 3) translations
  std::vector<uint32_t> kept;  // frames stored, increasing, the first and the last among them
  size_t frames() const { return translation ? floats.size() / 3 : codes.size() / 4; }
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
    t.exact.push_back(q);
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

// True when every frame of the track is the node's rest value (identity rotation, rest
// translation): the track can be left out.
bool at_rest(const Track& t, int bits, const std::vector<double>& rest_joints) {
  for (size_t k = 0; k < t.frames(); ++k) {
    if (t.translation) {
      for (size_t c = 0; c < 3; ++c)
        if (t.floats[k * 3 + c] != float(rest_joints[c])) return false;
    } else if (t.codes[k * 4] != 0 || t.codes[k * 4 + 1] != 0 || t.codes[k * 4 + 2] != 0 || t.codes[k * 4 + 3] != quantize(1.0, bits)) {
      return false;
    }
  }
  return true;
}

// The largest error at the frames strictly between frames a and b of the interpolation of a
// and b at the key times (slerp / lerp, as a reader does) against the motion: the angle in
// radians, or the distance in metres. On the motion's exact rotations, so the quantization
// adds its own bound (at the kept keys) instead of stopping every reduction at 8 bits.
double span_error(const Track& t, size_t a, size_t b, const std::vector<float>& times) {
  double worst = 0;
  const Quat<double> qa = t.translation ? Quat<double>{} : t.exact[a];
  const Quat<double> qb = t.translation ? Quat<double>{} : t.exact[b];
  for (size_t k = a + 1; k < b; ++k) {
    const double s = (double(times[k]) - times[a]) / (double(times[b]) - times[a]);
    if (t.translation) {
      double d2 = 0;
      for (size_t c = 0; c < 3; ++c) {
        const double x = t.floats[a * 3 + c], y = t.floats[b * 3 + c];
        d2 += std::pow(x + s * (y - x) - t.floats[k * 3 + c], 2);
      }
      worst = std::max(worst, std::sqrt(d2));
      continue;
    }
    const Quat<double> q = slerp_shortest(qa, qb, s), r = t.exact[k];
    const double dot = std::abs(q.w * r.w + q.x * r.x + q.y * r.y + q.z * r.z);
    worst = std::max(worst, 2 * std::acos(std::min(dot, 1.0)));
  }
  return worst;
}

// True when every stored frame equals the first (bit for bit).
bool constant(const Track& t) {
  const size_t n = t.translation ? 3 : 4;
  for (size_t k = 1; k < t.frames(); ++k)
    for (size_t c = 0; c < n; ++c)
      if (t.translation ? t.floats[k * n + c] != t.floats[c] : t.codes[k * n + c] != t.codes[c]) return false;
  return true;
}

// The frames to store: greedily, each kept frame is followed by the farthest frame (at most
// kMaxSpan frames on) whose interpolation with it reproduces every frame in between within
// `tolerance`; the first and the last frames are always kept. tolerance 0 keeps every frame
// of a track that moves (a still one keeps its first and last).
constexpr size_t kMaxSpan = 256;  // bounds the work on long, nearly still tracks

void reduce(Track& t, double tolerance, const std::vector<float>& times) {
  const size_t K = t.frames();
  t.kept = {0};
  if (K > 1 && constant(t)) {  // held still: the first and the last key, whatever the tolerance
    t.kept.push_back(uint32_t(K - 1));
    return;
  }
  for (size_t a = 0; a + 1 < K;) {
    size_t b = a + 1;
    while (tolerance > 0 && b + 1 < K && b + 1 - a <= kMaxSpan && span_error(t, a, b + 1, times) <= tolerance) ++b;
    t.kept.push_back(uint32_t(b));
    a = b;
  }
}

void append(std::vector<uint8_t>& bytes, const void* p, size_t n) {
  const auto* b = static_cast<const uint8_t*>(p);
  bytes.insert(bytes.end(), b, b + n);
}

void check_motion(const AnimationSource& s) {
  const std::string where = s.motion.source.empty() ? s.name : s.motion.source;
  if (s.motion.frames.empty()) fail(where, "motion has no frames");
  if (!(s.motion.fps > 0) || !std::isfinite(s.motion.fps)) fail(where, "frame rate must be positive");
  if (!(s.tolerance >= 0) || !std::isfinite(s.tolerance)) fail(where, "--animation-tolerance must be a non-negative number of radians");
  for (size_t k = 0; k < s.motion.frames.size(); ++k) {
    const SmplxParams& f = s.motion.frames[k];
    for (float v : f.pose)
      if (!std::isfinite(v)) fail(where, "frame " + std::to_string(k) + ": pose is not finite");
    for (float v : f.transl)
      if (!std::isfinite(v)) fail(where, "frame " + std::to_string(k) + ": translation is not finite");
  }
}

// Where keyframe reduction pays. Tracks with the same kept frames share one input (4 B a key
// time and ~120 B of JSON); a track keeping every frame shares the full input. Of "every track
// reduced" and "each track kept whole where that is cheaper than its share of its own
// input", keeps the smaller in bytes.
void keep_reductions_that_pay(std::vector<Track>& tracks, int bits) {
  if (tracks.empty()) return;
  const size_t K = tracks[0].frames();
  auto value_bytes = [&](const Track& t) -> size_t { return t.translation ? 12 : bits == 16 ? 8 : bits == 8 ? 4 : 16; };
  auto input_bytes = [](size_t keys) { return 4 * keys + 120; };
  std::map<std::vector<uint32_t>, size_t> sharing;
  for (const Track& t : tracks) ++sharing[t.kept];
  size_t all_reduced = 0;
  for (const Track& t : tracks) all_reduced += t.kept.size() * value_bytes(t);
  for (const auto& [kept, n] : sharing) all_reduced += input_bytes(kept.size());
  std::vector<bool> full(tracks.size(), false);
  std::set<std::vector<uint32_t>> inputs;
  size_t mixed = input_bytes(K);
  for (size_t i = 0; i < tracks.size(); ++i) {
    const Track& t = tracks[i];
    const size_t share = input_bytes(t.kept.size()) / sharing[t.kept];
    full[i] = K * value_bytes(t) <= t.kept.size() * value_bytes(t) + share;
    mixed += full[i] ? K * value_bytes(t) : t.kept.size() * value_bytes(t);
    if (!full[i]) inputs.insert(t.kept);
  }
  for (const std::vector<uint32_t>& kept : inputs) mixed += input_bytes(kept.size());
  if (all_reduced <= mixed) return;
  for (size_t i = 0; i < tracks.size(); ++i) {
    if (!full[i]) continue;
    tracks[i].kept.resize(K);
    for (size_t k = 0; k < K; ++k) tracks[i].kept[k] = uint32_t(k);
  }
}

// The tracks of one motion: the root's translation unless it rests, the root's rotation
// always (so every animation has a channel), every other joint's unless it rests; each
// reduced to the frames it needs.
std::vector<Track> kept_tracks(const AnimationSource& s, const std::vector<double>& rest_joints, int bits,
                               const std::vector<float>& times) {
  std::vector<Track> tracks;
  Track tr = translation_track(s.motion, rest_joints);
  if (!at_rest(tr, bits, rest_joints)) tracks.push_back(std::move(tr));
  for (int j = 0; j < kNumJoints; ++j) {
    Track r = rotation_track(s.motion, j, bits);
    if (j == 0 || !at_rest(r, bits, rest_joints)) tracks.push_back(std::move(r));
  }
  // A translation tolerance of `tolerance` metres: what the rotation tolerance moves a point
  // 1 m from the joint by (about the body's reach from the pelvis).
  for (Track& t : tracks) reduce(t, s.tolerance, times);
  keep_reductions_that_pay(tracks, bits);
  return tracks;
}

// One animation: its bytes in one bufferView (the key times of each distinct set of kept
// frames, translations, rotations), an accessor per sampler input/output, a channel per track.
Json pack_one(glb::BinWriter& bin, Json& accessors, const AnimationSource& s, const std::vector<double>& rest_joints,
              int bits, size_t* bytes_out) {
  const Motion& m = s.motion;
  const size_t K = m.frames.size();
  std::vector<float> times(K);
  for (size_t k = 0; k < K; ++k) times[k] = float(double(k) / m.fps);
  const std::vector<Track> tracks = kept_tracks(s, rest_joints, bits, times);
  std::vector<uint8_t> bytes;
  std::map<std::vector<uint32_t>, size_t> input_of;  // kept frames -> index into inputs
  std::vector<std::pair<size_t, const std::vector<uint32_t>*>> inputs;  // byte offset, frames
  for (const Track& t : tracks) {
    if (!input_of.emplace(t.kept, inputs.size()).second) continue;
    inputs.push_back({bytes.size(), &t.kept});
    for (uint32_t k : t.kept) append(bytes, &times[k], 4);
  }
  std::vector<size_t> offsets(tracks.size());
  for (int pass = 0; pass < 2; ++pass)  // translations (float) first, then rotations
    for (size_t i = 0; i < tracks.size(); ++i) {
      const Track& t = tracks[i];
      if (t.translation != (pass == 0)) continue;
      offsets[i] = bytes.size();
      for (uint32_t k : t.kept) {
        if (t.translation) { append(bytes, &t.floats[k * 3], 12); continue; }
        for (size_t c = 0; c < 4; ++c) {
          const int32_t code = t.codes[k * 4 + c];
          if (bits == 16) { const int16_t v = int16_t(code); append(bytes, &v, 2); }
          else if (bits == 8) { const int8_t v = int8_t(code); append(bytes, &v, 1); }
          else append(bytes, &code, 4);
        }
      }
    }
  const int view = bin.add_view(bytes.data(), bytes.size());
  *bytes_out = bytes.size();
  auto add = [&](Json acc) {
    acc["bufferView"] = view;
    accessors.push_back(std::move(acc));
    return int(accessors.size()) - 1;
  };
  std::vector<int> input_accessor;
  for (const auto& [offset, kept] : inputs) {
    input_accessor.push_back(add({{"byteOffset", offset}, {"componentType", kFloat}, {"count", kept->size()}, {"type", "SCALAR"},
                                  {"min", {glb::json_float(times[kept->front()])}}, {"max", {glb::json_float(times[kept->back()])}}}));
  }
  Json samplers = Json::array(), channels = Json::array();
  for (size_t i = 0; i < tracks.size(); ++i) {
    const Track& t = tracks[i];
    Json out = {{"byteOffset", offsets[i]}, {"count", t.kept.size()}, {"type", t.translation ? "VEC3" : "VEC4"}};
    out["componentType"] = t.translation || bits == 0 ? kFloat : bits == 16 ? kShort : kByte;
    if (!t.translation && bits != 0) out["normalized"] = true;
    samplers.push_back({{"input", input_accessor[input_of.at(t.kept)]}, {"output", add(out)}, {"interpolation", "LINEAR"}});
    channels.push_back({{"sampler", i}, {"target", {{"node", t.node}, {"path", t.translation ? "translation" : "rotation"}}}});
  }
  // The rate the motion was sampled at (the reduced tracks' keys no longer say it).
  return {{"name", s.name}, {"samplers", samplers}, {"channels", channels}, {"extras", {{"fps", m.fps}}}};
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
    animations.push_back(pack_one(bin, accessors, {s.name, std::move(m), s.tolerance}, rest_joints, rotation_bits, &bytes));
    if (bytes_each) bytes_each->push_back(bytes);
  }
  return animations;
}

}  // namespace haha
