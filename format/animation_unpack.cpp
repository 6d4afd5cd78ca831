#include "format/animation_unpack.h"

#include <cmath>
#include <map>
#include <set>

#include "body/body_model.h"
#include "core/error.h"

namespace haha {

using glb::Json;

namespace {

// Reads each accessor once, and no more values in all than the BIN chunk has bytes (every
// stored component takes at least one byte, so only accessors aliasing the same bytes could
// ask for more).
class AccessorCache {
 public:
  AccessorCache(const glb::Glb& g, const std::string& where) : g_(g), where_(where), budget_(g.bin.size()) {}

  const glb::AccessorValues& get(int64_t index, int components, const std::string& what) {
    auto it = cache_.find(index);
    if (it != cache_.end()) {
      if (int(it->second.values.size() / size_t(it->second.count)) != components) {
        fail(where_, what + ": accessors[" + std::to_string(index) + "] is used with two different types");
      }
      return it->second;
    }
    const Json& acc = glb::element(g_.json, "accessors", index, where_);
    const int64_t count = glb::as_int(glb::member(acc, "count", where_, what), where_, what + ".count", 1, INT64_MAX / 64);
    if (uint64_t(count) * uint64_t(components) > budget_) {
      fail(where_, what + ": accessors[" + std::to_string(index) + "] holds more values than the file has bytes");
    }
    budget_ -= uint64_t(count) * uint64_t(components);
    const glb::AccessorValues v = glb::read_accessor(g_, index, components, where_, what);
    views_[index] = glb::as_int(glb::member(acc, "bufferView", where_, what), where_, what + ".bufferView", 0, INT32_MAX);
    return cache_.emplace(index, v).first->second;
  }
  // The bufferView of an accessor read so far, -1 for one never read.
  int64_t view_of(int64_t index) const {
    const auto it = views_.find(index);
    return it == views_.end() ? -1 : it->second;
  }

 private:
  const glb::Glb& g_;
  const std::string& where_;
  uint64_t budget_;
  std::map<int64_t, glb::AccessorValues> cache_;
  std::map<int64_t, int64_t> views_;
};

// Node index -> joint (skins[0].joints order) and the root's rest translation.
struct Skeleton {
  std::map<int64_t, int> joint_of;
  double rest_root[3] = {0, 0, 0};
};

Skeleton skeleton_of(const glb::Glb& g, const std::string& where) {
  Skeleton s;
  const Json& joints = glb::member(glb::element(g.json, "skins", 0, where), "joints", where, "skins[0]");
  if (!joints.is_array() || joints.empty()) fail(where, "skins[0].joints: not a non-empty array");
  for (size_t j = 0; j < joints.size() && j < size_t(kNumJoints); ++j) {
    const int64_t node = glb::as_int(joints[j], where, "skins[0].joints[" + std::to_string(j) + "]", 0, INT32_MAX);
    glb::element(g.json, "nodes", node, where);
    s.joint_of.emplace(node, int(j));
  }
  const Json& root = glb::element(g.json, "nodes", glb::as_int(joints[0], where, "skins[0].joints[0]", 0, INT32_MAX), where);
  if (const Json* t = glb::find_member(root, "translation")) {
    const std::vector<float> v = glb::as_float_array(*t, where, "root joint's translation", 3);
    if (v.size() != 3) fail(where, "root joint's translation: expected 3 values");
    for (int c = 0; c < 3; ++c) s.rest_root[c] = v[size_t(c)];
  }
  return s;
}

// Key times of a sampler: finite, non-negative, strictly increasing.
std::vector<float> key_times(AccessorCache& cache, int64_t index, const std::string& where, const std::string& what) {
  const glb::AccessorValues& v = cache.get(index, 1, what);
  if (v.component_type != 5126) fail(where, what + ": key times must be float");
  std::vector<float> t(v.values.begin(), v.values.end());
  for (size_t k = 0; k < t.size(); ++k) {
    if (!std::isfinite(t[k]) || t[k] < 0) fail(where, what + ": key time " + std::to_string(k) + " is negative or not finite");
    if (k > 0 && !(t[k] > t[k - 1])) fail(where, what + ": key times are not strictly increasing at key " + std::to_string(k));
  }
  return t;
}

// One channel's track; false when the channel does not move the skeleton.
bool read_track(const Json& anim, const Json& ch, const Skeleton& sk, AccessorCache& cache,
                const std::string& where, const std::string& what, AnimationTrack& tr) {
  const Json& target = glb::member(ch, "target", where, what);
  const std::string path = glb::as_string(glb::member(target, "path", where, what + ".target"), where, what + ".target.path");
  const Json* node = glb::find_member(target, "node");
  if (!node || path == "weights") return false;
  const auto joint = sk.joint_of.find(glb::as_int(*node, where, what + ".target.node", 0, INT32_MAX));
  if (joint == sk.joint_of.end()) return false;
  tr.joint = joint->second;
  tr.translation = path == "translation";
  if (path == "scale") fail(where, what + ": scale channels on joints are not supported (SMPL-X poses rotate joints)");
  if (tr.translation && tr.joint != 0) fail(where, what + ": translation of a joint other than the root is not supported");
  if (path != "rotation" && path != "translation") fail(where, what + ".target.path: unknown path '" + path + "'");
  const Json& samplers = glb::member(anim, "samplers", where, what);
  const int64_t si = glb::as_int(glb::member(ch, "sampler", where, what), where, what + ".sampler", 0, INT32_MAX);
  if (!samplers.is_array() || size_t(si) >= samplers.size()) fail(where, what + ".sampler: index out of range");
  const Json& s = samplers[size_t(si)];
  const std::string sw = what + " sampler " + std::to_string(si);
  std::string interp = "LINEAR";
  if (const Json* i = glb::find_member(s, "interpolation")) interp = glb::as_string(*i, where, sw + ".interpolation");
  if (interp != "LINEAR" && interp != "STEP") fail(where, sw + ": interpolation '" + interp + "' is not supported");
  tr.step = interp == "STEP";
  tr.times = key_times(cache, glb::as_int(glb::member(s, "input", where, sw), where, sw + ".input", 0, INT32_MAX), where, sw + " input");
  const int n = tr.translation ? 3 : 4;
  const glb::AccessorValues& out = cache.get(glb::as_int(glb::member(s, "output", where, sw), where, sw + ".output", 0, INT32_MAX), n, sw + " output");
  if (size_t(out.count) != tr.times.size()) {
    fail(where, sw + ": " + std::to_string(out.count) + " output values for " + std::to_string(tr.times.size()) + " key times");
  }
  if (!tr.translation && out.component_type != 5126 && !out.normalized) fail(where, sw + ": integer rotations must be normalized");
  tr.values.resize(out.values.size());
  for (size_t k = 0; k < tr.times.size(); ++k) {
    const double* v = &out.values[k * size_t(n)];
    if (tr.translation) {
      for (int c = 0; c < 3; ++c) tr.values[k * 3 + c] = float(v[c] - sk.rest_root[c]);
    } else {
      const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
      if (!(len > 1e-3) || !std::isfinite(len)) fail(where, sw + ": rotation key " + std::to_string(k) + " is not a rotation");
      const double q[4] = {v[3], v[0], v[1], v[2]};  // glTF (x, y, z, w) -> (w, x, y, z)
      for (int c = 0; c < 4; ++c) tr.values[k * 4 + c] = float(q[c] / len);
    }
    for (int c = 0; c < n; ++c)
      if (!std::isfinite(tr.values[k * size_t(n) + c])) fail(where, sw + ": value " + std::to_string(k) + " is not finite");
  }
  return true;
}

AvatarAnimation read_one(const glb::Glb& g, const Json& anim, size_t i, const Skeleton& sk, AccessorCache& cache,
                         const std::string& where) {
  const std::string what = "animations[" + std::to_string(i) + "]";
  AvatarAnimation a;
  a.name = "animation_" + std::to_string(i);
  if (const Json* n = glb::find_member(anim, "name")) a.name = glb::as_string(*n, where, what + ".name");
  const Json& channels = glb::member(anim, "channels", where, what);
  if (!channels.is_array() || channels.empty()) fail(where, what + ".channels: not a non-empty array");
  std::set<std::pair<int, bool>> seen;
  std::set<int64_t> views;
  for (size_t c = 0; c < channels.size(); ++c) {
    AnimationTrack tr;
    const std::string cw = what + ".channels[" + std::to_string(c) + "]";
    if (!read_track(anim, channels[c], sk, cache, where, cw, tr)) continue;
    if (!seen.insert({tr.joint, tr.translation}).second) fail(where, cw + ": a second channel on the same joint and path");
    a.duration = std::max(a.duration, double(tr.times.back()));
    a.frames = std::max(a.frames, int(tr.times.size()));
    a.tracks.push_back(std::move(tr));
  }
  // The rate the packer sampled at (`extras.fps`): its reduced tracks' keys do not say it.
  // Without it (or with a value out of range) the longest track's keys give the frames.
  if (const Json* ex = glb::find_member(anim, "extras"); ex && ex->is_object() && a.duration > 0) {
    if (const Json* fps = glb::find_member(*ex, "fps"); fps && fps->is_number()) {
      const double f = fps->get<double>(), n = std::round(a.duration * f);
      if (f > 0 && f <= 1000 && n < 1e8) a.frames = std::max(a.frames, int(n) + 1);
    }
  }
  for (const Json& s : glb::member(anim, "samplers", where, what))
    for (const char* key : {"input", "output"})
      if (const Json* k = glb::find_member(s, key))
        if (k->is_number_integer() && cache.view_of(k->get<int64_t>()) >= 0) views.insert(cache.view_of(k->get<int64_t>()));
  for (int64_t v : views) a.bytes += glb::buffer_view(g, int(v), where).size;
  return a;
}

}  // namespace

std::vector<AvatarAnimation> read_animations(const glb::Glb& g, const std::string& where) {
  std::vector<AvatarAnimation> out;
  const Json* list = glb::find_member(g.json, "animations");
  if (!list) return out;
  if (!list->is_array()) fail(where, "animations: not an array");
  const Skeleton sk = skeleton_of(g, where);
  AccessorCache cache(g, where);
  for (size_t i = 0; i < list->size(); ++i) out.push_back(read_one(g, (*list)[i], i, sk, cache, where));
  return out;
}

std::vector<AvatarAnimation> read_glb_animations(const uint8_t* data, size_t size, const std::string& where) {
  try {
    return read_animations(glb::parse_glb(data, size, where), where);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail(where, std::string("corrupt file: ") + e.what());
  }
}

}  // namespace haha
