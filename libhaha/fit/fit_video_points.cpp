// BlazePose -> SMPL-X correspondence (fit/fit_video_points.h).
#include "fit/fit_video_points.h"

#include <algorithm>
#include <functional>
#include <initializer_list>

#include "body/lbs.h"
#include "core/error.h"
#include "io/keypoints_json.h"

namespace haha {

namespace {

namespace bp = blazepose;

constexpr int kSmplxVerts = 10475;

// SMPL-X vertex ids of the surface keypoints, as used by SMPL-X fitting code (SMPLify-X's
// OpenPose face / foot points): nose tip, the eyes, the ears, the heels and the big toes.
struct TableEntry {
  int blazepose, vertex;
};
constexpr TableEntry kSmplxTable[] = {
    {bp::nose, 9120},      {bp::left_eye, 9448},   {bp::right_eye, 9929},   {bp::left_ear, 6},
    {bp::right_ear, 616},  {bp::left_heel, 8846},  {bp::right_heel, 8635},  {bp::left_foot_index, 5770},
    {bp::right_foot_index, 8463},
};

// SMPL-X joints.
enum : int {
  jLHip = 1, jRHip = 2, jLKnee = 4, jRKnee = 5, jLAnkle = 7, jRAnkle = 8, jLFoot = 10, jRFoot = 11, jHead = 15,
  jLShoulder = 16, jRShoulder = 17, jLElbow = 18, jRElbow = 19, jLWrist = 20, jRWrist = 21, jJaw = 22,
  jLEye = 23, jREye = 24
};

struct Rest {
  std::vector<float> verts, joints;
  std::vector<int> dominant;  // per vertex: the joint with the largest skinning weight
};

Rest rest_body(const BodyModel& body) {
  Rest r;
  r.verts.resize(size_t(body.num_verts) * 3);
  r.joints.resize(size_t(kNumJoints) * 3);
  Lbs<float>(body).forward(SmplxParams{}, r.verts.data(), r.joints.data(), nullptr);
  r.dominant.resize(size_t(body.num_verts));
  for (int v = 0; v < body.num_verts; ++v) {
    const float* w = body.weights.data() + size_t(v) * kNumJoints;
    r.dominant[size_t(v)] = int(std::max_element(w, w + kNumJoints) - w);
  }
  return r;
}

bool in(int j, std::initializer_list<int> set) { return std::find(set.begin(), set.end(), j) != set.end(); }

// The joints a surface point's vertex must be skinned to, mostly.
bool plausible(int blazepose, int dominant) {
  switch (blazepose) {
    case bp::nose: case bp::left_ear: case bp::right_ear: return in(dominant, {jHead, jJaw, jLEye, jREye});
    case bp::left_eye: case bp::right_eye: return in(dominant, {jHead, jLEye, jREye});
    case bp::left_heel: case bp::left_foot_index: return in(dominant, {jLAnkle, jLFoot});
    case bp::right_heel: case bp::right_foot_index: return in(dominant, {jRAnkle, jRFoot});
    default: return false;
  }
}

// argmax of score over vertices passing `keep`, or -1.
int best_vertex(const Rest& r, const std::function<bool(int, const float*)>& keep,
                const std::function<double(const float*)>& score) {
  int best = -1;
  double best_s = 0;
  for (size_t v = 0; v < r.dominant.size(); ++v) {
    const float* p = r.verts.data() + 3 * v;
    if (!keep(int(v), p)) continue;
    const double s = score(p);
    if (best < 0 || s > best_s) best = int(v), best_s = s;
  }
  return best;
}

int geometric_vertex(const Rest& r, int blazepose) {
  const float* J = r.joints.data();
  const double eye_y = 0.5 * (J[3 * jLEye + 1] + J[3 * jREye + 1]);
  auto dom = [&](int v) { return r.dominant[size_t(v)]; };
  switch (blazepose) {
    case bp::nose:
      return best_vertex(r, [&](int v, const float* p) { return in(dom(v), {jHead, jJaw}) && p[1] > eye_y - 0.06 && p[1] < eye_y + 0.02; },
                         [](const float* p) { return p[2]; });
    case bp::left_eye: case bp::right_eye: {
      const int je = blazepose == bp::left_eye ? jLEye : jREye;
      const int v = best_vertex(r, [&](int v, const float*) { return dom(v) == je; }, [](const float* p) { return p[2]; });
      if (v >= 0) return v;
      // No eyeball: the foremost head vertex in front of the eye joint.
      return best_vertex(r, [&](int v, const float* p) {
        return dom(v) == jHead && std::abs(p[0] - J[3 * je]) < 0.015 && std::abs(p[1] - J[3 * je + 1]) < 0.015; },
                         [](const float* p) { return p[2]; });
    }
    case bp::left_ear: case bp::right_ear: {
      const double side = blazepose == bp::left_ear ? 1 : -1;
      return best_vertex(r, [&](int v, const float* p) { return dom(v) == jHead && std::abs(p[1] - eye_y) < 0.04; },
                         [&](const float* p) { return side * p[0]; });
    }
    case bp::left_heel: case bp::right_heel: case bp::left_foot_index: case bp::right_foot_index: {
      const bool left = blazepose == bp::left_heel || blazepose == bp::left_foot_index;
      const bool heel = blazepose == bp::left_heel || blazepose == bp::right_heel;
      const int ja = left ? jLAnkle : jRAnkle, jf = left ? jLFoot : jRFoot;
      return best_vertex(r, [&](int v, const float* p) { return in(dom(v), {ja, jf}) && p[1] < J[3 * ja + 1]; },
                         [&](const float* p) { return heel ? -p[2] : p[2]; });
    }
    default: return -1;
  }
}

}  // namespace

std::vector<FitVideoBone> fit_video_bones(const std::vector<FitVideoPoint>& points) {
  constexpr int kBones[][2] = {{bp::left_shoulder, bp::left_elbow}, {bp::left_elbow, bp::left_wrist},
                               {bp::right_shoulder, bp::right_elbow}, {bp::right_elbow, bp::right_wrist},
                               {bp::left_hip, bp::left_knee},        {bp::left_knee, bp::left_ankle},
                               {bp::right_hip, bp::right_knee},      {bp::right_knee, bp::right_ankle},
                               {bp::right_shoulder, bp::left_shoulder}, {bp::right_hip, bp::left_hip}};
  auto find = [&](int blaze) {
    for (size_t k = 0; k < points.size(); ++k)
      if (points[k].blazepose == blaze && points[k].joint >= 0) return int(k);
    return -1;
  };
  std::vector<FitVideoBone> bones;
  for (const auto& b : kBones) {
    const int a = find(b[0]), c = find(b[1]);
    if (a >= 0 && c >= 0) bones.push_back({a, c});
  }
  return bones;
}

std::vector<FitVideoPoint> fit_video_points(const BodyModel& body) {
  const std::string where = body.source.empty() ? "video fit" : body.source;
  std::vector<FitVideoPoint> pts;
  auto joint = [&](int b, int j, double w, bool torso, const char* name) { pts.push_back({b, j, -1, w, torso, name}); };
  joint(bp::left_shoulder, jLShoulder, 1, true, "left shoulder");
  joint(bp::right_shoulder, jRShoulder, 1, true, "right shoulder");
  joint(bp::left_elbow, jLElbow, 1, false, "left elbow");
  joint(bp::right_elbow, jRElbow, 1, false, "right elbow");
  joint(bp::left_wrist, jLWrist, 1, false, "left wrist");
  joint(bp::right_wrist, jRWrist, 1, false, "right wrist");
  joint(bp::left_hip, jLHip, kFitVideoHipWeight, true, "left hip");
  joint(bp::right_hip, jRHip, kFitVideoHipWeight, true, "right hip");
  joint(bp::left_knee, jLKnee, 1, false, "left knee");
  joint(bp::right_knee, jRKnee, 1, false, "right knee");
  joint(bp::left_ankle, jLAnkle, 1, false, "left ankle");
  joint(bp::right_ankle, jRAnkle, 1, false, "right ankle");

  const Rest rest = rest_body(body);
  for (const TableEntry& e : kSmplxTable) {
    int v = -1;
    if (body.num_verts == kSmplxVerts && plausible(e.blazepose, rest.dominant[size_t(e.vertex)])) v = e.vertex;
    if (v < 0) v = geometric_vertex(rest, e.blazepose);
    const bool face = e.blazepose <= bp::right_ear;
    const char* names[] = {"nose", "left eye", "right eye", "left ear", "right ear", "left heel", "right heel",
                           "left toe", "right toe"};
    const char* name = names[&e - kSmplxTable];
    if (v < 0) fail(where, std::string("no body vertex for the ") + name + " keypoint");
    // The face points tell which way the body faces: the first stage uses them too.
    pts.push_back({e.blazepose, -1, v, face ? kFitVideoFaceWeight : kFitVideoFootWeight, face, name});
  }
  return pts;
}

}  // namespace haha
