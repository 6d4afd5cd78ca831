#include "app/rig_import.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <map>

#include "core/error.h"
#include "io/motion.h"

namespace haha {

namespace {

using V3 = Vec3<double>;

// Bounds that keep a hostile file from asking for unbounded memory.
constexpr size_t kMaxNodes = 10000;
constexpr double kMaxSamples = 1e7;  // frames x nodes (about 1 GB of transforms)

Affine affine_of(const aiMatrix4x4& a) {
  Affine r;
  const double m[3][4] = {{a.a1, a.a2, a.a3, a.a4}, {a.b1, a.b2, a.b3, a.b4}, {a.c1, a.c2, a.c3, a.c4}};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.m.a[i][j] = m[i][j];
    r.t[i] = m[i][3];
  }
  return r;
}

void collect(const aiNode* n, int parent, RigAnimation& rig, std::map<std::string, int>& index) {
  if (rig.names.size() >= kMaxNodes) fail(rig.source, "more than " + std::to_string(kMaxNodes) + " nodes");
  const int me = int(rig.names.size());
  rig.names.emplace_back(n->mName.C_Str());
  rig.parents.push_back(parent);
  rig.rest.push_back(affine_of(n->mTransformation));
  index.emplace(rig.names.back(), me);  // a repeated name: the first (closest to the root) wins
  for (unsigned c = 0; c < n->mNumChildren; ++c) collect(n->mChildren[c], me, rig, index);
}

template <class Key>
size_t key_before(const Key* keys, unsigned n, double t) {  // last key at or before t (0 if none)
  size_t lo = 0, hi = n;
  while (hi - lo > 1) {
    const size_t mid = (lo + hi) / 2;
    (keys[mid].mTime <= t ? lo : hi) = mid;
  }
  return lo;
}

double weight(double t0, double t1, double t) { return t1 > t0 ? std::clamp((t - t0) / (t1 - t0), 0.0, 1.0) : 0.0; }

V3 sample(const aiVectorKey* k, unsigned n, double t, const V3& fallback) {
  if (n == 0) return fallback;
  const size_t i = key_before(k, n, t), j = std::min<size_t>(i + 1, n - 1);
  const double s = weight(k[i].mTime, k[j].mTime, t);
  const V3 a(k[i].mValue.x, k[i].mValue.y, k[i].mValue.z), b(k[j].mValue.x, k[j].mValue.y, k[j].mValue.z);
  return a + s * (b - a);
}

Mat3<double> sample(const aiQuatKey* k, unsigned n, double t, const Mat3<double>& fallback) {
  if (n == 0) return fallback;
  const size_t i = key_before(k, n, t), j = std::min<size_t>(i + 1, n - 1);
  const auto q = [](const aiQuaternion& a) {
    const double l = std::sqrt(double(a.w) * a.w + double(a.x) * a.x + double(a.y) * a.y + double(a.z) * a.z);
    return l > 0 && std::isfinite(l) ? Quat<double>(a.w / l, a.x / l, a.y / l, a.z / l) : Quat<double>();
  };
  return quat_to_mat(slerp_shortest(q(k[i].mValue), q(k[j].mValue), weight(k[i].mTime, k[j].mTime, t)));
}

// The rest transform split into translation, rotation and per-axis scale (columns), the
// parts a channel without keys for them keeps.
struct Trs {
  V3 t, s;
  Mat3<double> r;
};
Trs split(const Affine& a) {
  Trs p{a.t, V3(1, 1, 1), Mat3<double>::identity()};
  V3 c[3];
  for (int j = 0; j < 3; ++j) {
    c[j] = a.m.col(j);
    p.s[j] = norm(c[j]);
    if (!(p.s[j] > 0)) return p;
    c[j] = c[j] / p.s[j];
  }
  p.r = Mat3<double>::from_cols(c[0], c[1], c[2]);
  return p;
}

// The frame spacing in ticks: the median gap between rotation keys of the busiest channel.
double frame_ticks(const aiAnimation* a) {
  const aiNodeAnim* busiest = nullptr;
  for (unsigned c = 0; c < a->mNumChannels; ++c)
    if (!busiest || a->mChannels[c]->mNumRotationKeys > busiest->mNumRotationKeys) busiest = a->mChannels[c];
  std::vector<double> gaps;
  for (unsigned k = 1; busiest && k < busiest->mNumRotationKeys; ++k) {
    const double g = busiest->mRotationKeys[k].mTime - busiest->mRotationKeys[k - 1].mTime;
    if (g > 0 && std::isfinite(g)) gaps.push_back(g);
  }
  if (gaps.empty()) return 0;
  std::nth_element(gaps.begin(), gaps.begin() + long(gaps.size() / 2), gaps.end());
  return gaps[gaps.size() / 2];
}

void sample_animation(const aiAnimation* a, const std::map<std::string, int>& index, RigAnimation& rig) {
  const double tps = a->mTicksPerSecond > 0 && std::isfinite(a->mTicksPerSecond) ? a->mTicksPerSecond : 25.0;
  double t0 = INFINITY, t1 = -INFINITY;
  for (unsigned c = 0; c < a->mNumChannels; ++c) {
    const aiNodeAnim* ch = a->mChannels[c];
    for (unsigned k = 0; k < ch->mNumRotationKeys; ++k) t0 = std::min(t0, ch->mRotationKeys[k].mTime), t1 = std::max(t1, ch->mRotationKeys[k].mTime);
    for (unsigned k = 0; k < ch->mNumPositionKeys; ++k) t0 = std::min(t0, ch->mPositionKeys[k].mTime), t1 = std::max(t1, ch->mPositionKeys[k].mTime);
  }
  if (!(t1 >= t0) || !std::isfinite(t1 - t0)) fail(rig.source, "animation '" + rig.take + "' has no keys");
  double step = frame_ticks(a);
  if (!(step > 0)) step = tps / 30;
  const double n = std::floor((t1 - t0) / step + 1e-6) + 1;
  if (!(n * double(rig.names.size()) <= kMaxSamples)) fail(rig.source, "animation '" + rig.take + "' is too long to sample");
  rig.fps = tps / step;
  if (!(rig.fps > 0 && rig.fps <= 10000)) fail(rig.source, "animation '" + rig.take + "' has no usable frame rate");
  std::vector<const aiNodeAnim*> channel(rig.names.size(), nullptr);
  for (unsigned c = 0; c < a->mNumChannels; ++c) {
    const auto it = index.find(a->mChannels[c]->mNodeName.C_Str());
    if (it != index.end()) channel[size_t(it->second)] = a->mChannels[c];
  }
  std::vector<Trs> parts;
  for (const Affine& r : rig.rest) parts.push_back(split(r));
  rig.frames.assign(size_t(n), rig.rest);
  for (size_t f = 0; f < rig.frames.size(); ++f) {
    const double t = t0 + double(f) * step;
    for (size_t i = 0; i < channel.size(); ++i) {
      const aiNodeAnim* ch = channel[i];
      if (!ch) continue;
      const Trs& p = parts[i];
      const V3 s = sample(ch->mScalingKeys, ch->mNumScalingKeys, t, p.s);
      const Mat3<double> r = sample(ch->mRotationKeys, ch->mNumRotationKeys, t, p.r);
      Affine& out = rig.frames[f][i];
      out.t = sample(ch->mPositionKeys, ch->mNumPositionKeys, t, p.t);
      out.m = Mat3<double>::from_cols(s.x * r.col(0), s.y * r.col(1), s.z * r.col(2));
    }
  }
}

bool finite(const Affine& a) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!std::isfinite(a.m.a[i][j])) return false;
  return std::isfinite(a.t.x) && std::isfinite(a.t.y) && std::isfinite(a.t.z);
}

void check_finite(const RigAnimation& rig) {
  for (size_t f = 0; f <= rig.frames.size(); ++f) {
    const std::vector<Affine>& local = f == 0 ? rig.rest : rig.frames[f - 1];
    for (size_t i = 0; i < local.size(); ++i)
      if (!finite(local[i]))
        fail(rig.source, "node '" + rig.names[i] + "': non-finite transform " + (f == 0 ? "at rest" : "in frame " + std::to_string(f - 1)));
  }
}

}  // namespace

Affine operator*(const Affine& a, const Affine& b) { return {a.m * b.m, a.m * b.t + a.t}; }

RigAnimation read_rig_animation(const std::string& path, const std::string& take) {
  Assimp::Importer importer;
  importer.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);  // one node per FBX bone
  const aiScene* scene = importer.ReadFile(path, aiProcess_ValidateDataStructure);
  if (!scene || !scene->mRootNode) {
    std::string why = importer.GetErrorString();
    fail(path, "cannot read a scene" + (why.empty() ? std::string() : ": " + why));
  }
  RigAnimation rig;
  rig.source = path;
  std::map<std::string, int> index;
  collect(scene->mRootNode, -1, rig, index);
  if (rig.names.size() < 2) fail(path, "no skeleton (the scene has no node hierarchy)");
  const aiAnimation* chosen = nullptr;
  for (unsigned a = 0; a < scene->mNumAnimations; ++a) {
    const aiAnimation* an = scene->mAnimations[a];
    rig.takes.emplace_back(an->mName.C_Str());
    if (!chosen && an->mNumChannels > 0 && (take.empty() || rig.takes.back() == take)) chosen = an;
  }
  if (rig.takes.empty()) fail(path, "no animation");
  if (!chosen && !take.empty()) {
    std::string list;
    for (const std::string& t : rig.takes) list += (list.empty() ? "'" : ", '") + t + "'";
    fail(path, "no take '" + take + "' (takes: " + list + ")");
  }
  if (!chosen) fail(path, "no animation (no animated node)");
  rig.take = chosen->mName.C_Str();
  sample_animation(chosen, index, rig);
  check_finite(rig);
  return rig;
}

std::vector<Affine> world_transforms(const RigAnimation& rig, const std::vector<Affine>& local) {
  std::vector<Affine> w(local.size());
  for (size_t i = 0; i < local.size(); ++i) w[i] = rig.parents[i] < 0 ? local[i] : w[size_t(rig.parents[i])] * local[i];
  return w;
}

}  // namespace haha
