// Procedural SMPL-X-layout body (see procedural_body.h). Structure:
//   build_body(params)  -> tube definitions (axis, cross-section profile, joints, skinning
//                          boundaries) for given proportions, all in metres;
//   make_layout(base)   -> rings per tube (fixed once, at the base proportions, so that
//                          vertex positions are smooth functions of the proportions);
//   eval_vertices(...)  -> positions; shape/expression directions are central differences
//                          of eval_vertices w.r.t. the proportions (exact for the linear
//                          expression fields).
// Each tube is a closed surface: a pole, `rings` rings of `columns` vertices, a pole.
#include "body/procedural_body.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>
#include <utility>

#include "core/error.h"
#include "core/math.h"

namespace haha {
namespace {

using V3 = Vec3<double>;
constexpr double kPi = 3.14159265358979323846;

V3 unit(V3 v) {
  const double n = norm(v);
  return n > 0 ? v / n : v;
}
double smoothstep(double e0, double e1, double x) {
  const double t = clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// SMPL-X kinematic tree (docs/method.md section 1).
constexpr int kParents[kNumJoints] = {-1, 0,  0,  0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  9,
                                      9,  12, 13, 14, 16, 17, 18, 19, 15, 15, 15, 20, 25, 26,
                                      20, 28, 29, 20, 31, 32, 20, 34, 35, 20, 37, 38, 21, 40,
                                      41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53};
enum : int {
  jPelvis = 0, jHipL = 1, jSpine1 = 3, jKneeL = 4, jSpine2 = 6, jAnkleL = 7, jSpine3 = 9,
  jFootL = 10, jNeck = 12, jCollarL = 13, jHead = 15, jShoulderL = 16, jElbowL = 18,
  jWristL = 20, jJawJ = 22, jEyeL = 23,
};
// Fingers in SMPL-X joint order: index, middle, pinky, ring, thumb (3 joints each).
enum : int { fIndex = 0, fMiddle = 1, fPinky = 2, fRing = 3, fThumb = 4 };
int hand_joint(int finger, int segment) { return 25 + 3 * finger + segment; }  // left hand

// Joint of the right side for a left-side (or centre) joint.
int mirror_joint(int j) {
  switch (j) {
    case 1: case 4: case 7: case 10: case 13: case 16: case 18: case 20: case 23: return j + 1;
    default: return (j >= 25 && j < 40) ? j + 15 : j;
  }
}

// ---- generator parameters. Shape parameters are multiplicative (1 = base) except the
// additive belly; one unit of beta moves a parameter by kShapeUnit.
enum : int { pHeight, pGirth, pLeg, pShoulder, pArm, pHead, pBelly, pHip, pChest, pNeck, kShapeParams };
constexpr int kExprParams = 10;
constexpr int kParams = kShapeParams + kExprParams;
constexpr double kShapeUnit[kShapeParams] = {0.04, 0.08, 0.04, 0.06, 0.04, 0.04, 0.015, 0.05, 0.06, 0.12};

struct Details {  // seed-varied details that are not shape directions
  double finger_len[5] = {1, 1, 1, 1, 1};
  double eye_spacing = 1, nose = 1, lips = 1, ears = 1, brows = 1;
};
struct Params {
  std::array<double, kParams> p{};
  Details d;
};

struct Key {
  double a, r1, r2, c1, c2;  // axial position (m), half-axes along e1/e2, centre offsets
};
struct Boundary {
  double a;
  int joint;
  double half;  // half-width (m) of the smooth blend around a
};
enum class Extra { none, torso, head, palm };

struct TubeDef {
  std::string name;
  V3 origin, dir, e1;  // e2 = dir x e1 (right-handed, so triangles face outward)
  double length = 0, cap0 = 0, cap1 = 0, exponent = 2;
  std::vector<Key> keys;
  std::vector<std::pair<double, int>> joints;  // (a, joint): joint = average of that ring
  int regress_all = -1;                        // joint = average of all vertices (eyes)
  int owner = 0;                               // skinning joint at a = 0
  std::vector<Boundary> bounds;                // owner changes along the axis
  Extra extra = Extra::none;
  bool face = false;  // head: facial displacement
  double uv_density = 1;
  int columns = 0, rings = 0;
  // palm: knuckle z and first joint of the four fingers
  std::array<double, 4> finger_z{};
  std::array<int, 4> finger_joint{};
  V3 e2() const { return cross(dir, e1); }
};

struct Face {  // facial frame and features of the head tube
  double y_eye = 0, hs = 1, eye_x = 0.032, z_jaw = 0, y_mouth = 0, y_neck_lo = 0, y_neck_hi = 0;
  double ear_z = 0;
  Details d;
  std::array<double, kExprParams> expr{};
};

struct Body {
  std::vector<TubeDef> tubes;
  Face face;
  double y_shoulder = 0, y_hip = 0;
};

// ---- profile: cubic Hermite through the keys (finite-difference tangents), smooth in
// the key positions, with rounded caps at both ends.
struct Prof {
  double r1, r2, c1, c2;
};
Prof eval_profile(const TubeDef& d, double a) {
  const auto& k = d.keys;
  const int n = int(k.size());
  auto val = [&](int i, int c) { return c == 0 ? k[i].r1 : c == 1 ? k[i].r2 : c == 2 ? k[i].c1 : k[i].c2; };
  double out[4];
  if (a <= k.front().a || n == 1) {
    for (int c = 0; c < 4; ++c) out[c] = val(0, c);
  } else if (a >= k.back().a) {
    for (int c = 0; c < 4; ++c) out[c] = val(n - 1, c);
  } else {
    int i = 0;
    while (i + 2 < n && a > k[i + 1].a) ++i;
    const double h = k[i + 1].a - k[i].a, s = (a - k[i].a) / h;
    const double h00 = 2 * s * s * s - 3 * s * s + 1, h10 = s * s * s - 2 * s * s + s;
    const double h01 = -2 * s * s * s + 3 * s * s, h11 = s * s * s - s * s;
    for (int c = 0; c < 4; ++c) {
      auto tangent = [&](int j) {
        const int lo = std::max(j - 1, 0), hi = std::min(j + 1, n - 1);
        return (val(hi, c) - val(lo, c)) / (k[hi].a - k[lo].a);
      };
      out[c] = h00 * val(i, c) + h10 * h * tangent(i) + h01 * val(i + 1, c) + h11 * h * tangent(i + 1);
    }
  }
  double cap = 1;
  if (a < d.cap0) cap *= std::sqrt(std::max(0.0, 1 - std::pow((d.cap0 - a) / d.cap0, 2)));
  if (a > d.length - d.cap1) cap *= std::sqrt(std::max(0.0, 1 - std::pow((a - d.length + d.cap1) / d.cap1, 2)));
  return {out[0] * cap, out[1] * cap, out[2], out[3]};
}

double superellipse(double c, double e) { return std::copysign(std::pow(std::abs(c), 2 / e), c); }

// ---- the body for given proportions
TubeDef mirror(const TubeDef& t) {
  TubeDef m = t;
  m.name = t.name.substr(0, t.name.size() - 1) + "r";
  auto mx = [](V3 v) { return V3(-v.x, v.y, v.z); };
  m.origin = mx(t.origin);
  m.dir = mx(t.dir);
  m.e1 = mx(t.e1);
  for (auto& k : m.keys) k.c2 = -k.c2;  // e2 = dir x e1 flips under a reflection
  for (auto& j : m.joints) j.second = mirror_joint(j.second);
  m.owner = mirror_joint(t.owner);
  for (auto& b : m.bounds) b.joint = mirror_joint(b.joint);
  if (m.regress_all >= 0) m.regress_all = mirror_joint(m.regress_all);
  for (auto& j : m.finger_joint) j = mirror_joint(j);
  return m;
}

void sort_keys(TubeDef& t) {
  std::sort(t.keys.begin(), t.keys.end(), [](const Key& a, const Key& b) { return a.a < b.a; });
}

// Heights above the floor and the sizes the parts share, for given proportions; world y
// puts the pelvis joint at -0.35 (SMPL-X-like).
struct Measures {
  double s, g, leg, shw, arm, hs, belly, hipw, chest, neck;
  double torso;  // longer legs, shorter trunk: height kept
  double sg;
  double h_ankle, h_knee, h_hip, h_pelvis, h_sp1, h_sp2, h_sp3, h_sh, h_neck, h_headj, h_eye;
  double yoff;
  double head;   // head dimensions scale
  double eye_x;  // eye centre, off the midline
  double hip_x;
  // Arms and hands (T-pose along +X).
  double arm_z, collar_x, shoulder_x, elbow_x, wrist_x, hand, y_arm, palm_y;
  double Y(double h) const { return h + yoff; }
};

Measures measures(const Params& P) {
  const auto& p = P.p;
  Measures m;
  m.s = 0.98 * p[pHeight], m.g = p[pGirth], m.leg = p[pLeg], m.shw = p[pShoulder], m.arm = p[pArm];
  m.hs = p[pHead], m.belly = p[pBelly], m.hipw = p[pHip], m.chest = p[pChest], m.neck = p[pNeck];
  const double s = m.s, leg = m.leg;
  m.torso = 1 - (leg - 1) * 0.9;
  const double torso = m.torso;
  m.sg = std::sqrt(m.g);
  m.h_ankle = 0.08 * s, m.h_knee = m.h_ankle + 0.40 * s * leg, m.h_hip = m.h_knee + 0.40 * s * leg;
  m.h_pelvis = m.h_hip + 0.05 * s * torso;
  m.h_sp1 = m.h_pelvis + 0.10 * s * torso, m.h_sp2 = m.h_pelvis + 0.23 * s * torso;
  m.h_sp3 = m.h_pelvis + 0.36 * s * torso, m.h_sh = m.h_pelvis + 0.45 * s * torso;
  m.h_neck = m.h_pelvis + 0.535 * s * torso, m.h_headj = m.h_neck + 0.08 * s * m.neck;
  m.h_eye = m.h_headj + 0.055 * s * m.hs;
  m.yoff = -0.35 - m.h_pelvis;
  m.head = s * m.hs;
  m.eye_x = 0.032 * m.head * P.d.eye_spacing;
  m.hip_x = 0.085 * m.hipw;
  m.arm_z = -0.015;
  m.collar_x = 0.075 * m.shw, m.shoulder_x = 0.185 * m.shw;
  m.elbow_x = m.shoulder_x + 0.265 * s * m.arm, m.wrist_x = m.elbow_x + 0.25 * s * m.arm;
  m.hand = s * m.arm;
  m.y_arm = m.Y(m.h_sh);
  m.palm_y = m.y_arm - 0.002 * m.hand;
  return m;
}

// Torso: crotch to the top of the neck (its top is hidden inside the head).
TubeDef torso_tube(const Measures& M) {
  const double s = M.s, g = M.g, shw = M.shw, belly = M.belly, hipw = M.hipw, chest = M.chest, neck = M.neck;
  const double torso = M.torso, sg = M.sg, h_hip = M.h_hip, h_pelvis = M.h_pelvis, h_sp1 = M.h_sp1;
  const double h_sp2 = M.h_sp2, h_sp3 = M.h_sp3, h_sh = M.h_sh, h_neck = M.h_neck, h_headj = M.h_headj;
  TubeDef t;
  t.name = "torso";
  const double h0 = h_hip - 0.095 * s, h1 = h_headj + 0.012 * s;
  t.origin = V3(0, M.Y(h0), 0);
  t.dir = V3(0, 1, 0);
  t.e1 = V3(0, 0, -1);  // seam at the back; e2 = -X
  t.length = h1 - h0;
  t.cap0 = 0.07 * s;
  t.cap1 = 0.03 * s;
  t.exponent = 2.4;
  auto key = [&](double h, double rx, double rz, double cz) { t.keys.push_back({h - h0, rz, rx, -cz, 0}); };
  key(h0, 0.140 * hipw * g, 0.090 * g, -0.005);
  key(h_hip - 0.04 * s, 0.165 * hipw * g, 0.102 * g, -0.010);
  key(h_hip, 0.172 * hipw * g, 0.106 * g, -0.012);
  key(h_pelvis + 0.04 * s, 0.160 * hipw * g, 0.100 * g + 0.3 * belly, -0.005 + 0.15 * belly);
  key(h_sp1 + 0.02 * s, 0.135 * g, 0.095 * g + belly, 0.6 * belly);
  key(h_sp2, 0.148 * g, 0.100 * g * std::sqrt(chest) + 0.4 * belly, 0.008 + 0.3 * belly);
  key(h_sp2 + 0.09 * s * torso, 0.162 * g * shw, 0.108 * g * chest, 0.015 * chest);
  key(h_sp3 + 0.03 * s * torso, 0.175 * g * shw, 0.100 * g * chest, 0.0);
  key(h_sh - 0.005 * s, 0.185 * sg * shw, 0.084 * g, -0.012);
  key(h_sh + 0.04 * s, 0.125 * shw, 0.068 * g, -0.016);
  key(h_sh + 0.07 * s, 0.075 * sg, 0.060 * sg, -0.014);
  key(h_neck, 0.064 * sg, 0.058 * sg, -0.012);
  key(h_neck + 0.04 * s * neck, 0.054 * sg, 0.053 * sg, -0.006);
  key(h1, 0.050 * sg, 0.050 * sg, -0.004);
  sort_keys(t);
  t.joints = {{h_pelvis - h0, jPelvis}, {h_sp1 - h0, jSpine1}, {h_sp2 - h0, jSpine2},
              {h_sp3 - h0, jSpine3}, {h_neck - h0, jNeck}};
  t.owner = jPelvis;
  t.bounds = {{h_sp1 - h0, jSpine1, 0.045 * s}, {h_sp2 - h0, jSpine2, 0.045 * s},
              {h_sp3 - h0, jSpine3, 0.045 * s}, {h_neck - h0, jNeck, 0.03 * s},
              {h_headj - h0, jHead, 0.008 * s}};
  t.extra = Extra::torso;
  return t;
}

// Head: from inside the neck (under the chin) to the top of the skull; the face is
// displaced onto it (eval_vertices). Coordinates relative to eye level, scaled by `head`.
TubeDef head_tube(const Measures& M) {
  const double head = M.head, h_eye = M.h_eye;
  TubeDef t;
  t.name = "head";
  const double r0 = -0.135, r1 = 0.118;
  t.origin = V3(0, M.Y(h_eye + r0 * head), 0);
  t.dir = V3(0, 1, 0);
  t.e1 = V3(0, 0, -1);
  t.length = (r1 - r0) * head;
  t.cap0 = 0.012 * head;
  t.cap1 = 0.03 * head;
  auto key = [&](double yr, double rx, double rz, double cz) {
    t.keys.push_back({(yr - r0) * head, rz * head, rx * head, -cz * head, 0});
  };
  key(-0.135, 0.040, 0.035, 0.025);
  key(-0.120, 0.048, 0.052, 0.038);
  key(-0.105, 0.056, 0.062, 0.036);
  key(-0.080, 0.064, 0.074, 0.030);
  key(-0.050, 0.070, 0.086, 0.022);
  key(-0.020, 0.074, 0.094, 0.016);
  key(0.000, 0.076, 0.097, 0.013);
  key(0.040, 0.079, 0.099, 0.005);
  key(0.080, 0.075, 0.092, -0.002);
  key(0.118, 0.055, 0.068, -0.008);
  t.joints = {{M.h_headj - (h_eye + r0 * head), jHead}, {(-0.035 - r0) * head, jJawJ}};
  t.owner = jHead;
  t.extra = Extra::head;
  t.face = true;
  t.uv_density = 1.8;  // faces deserve texels
  return t;
}

Face head_face(const Measures& M, const Params& P) {
  const double head = M.head;
  Face f;
  f.y_eye = M.Y(M.h_eye);
  f.hs = head;
  f.eye_x = M.eye_x;
  f.z_jaw = 0.02 * head;
  f.y_mouth = M.Y(M.h_eye) - 0.064 * head;
  f.y_neck_lo = M.Y(M.h_eye) - 0.128 * head;
  f.y_neck_hi = M.Y(M.h_eye) - 0.100 * head;
  f.ear_z = -0.008 * head;
  f.d = P.d;
  for (int e = 0; e < kExprParams; ++e) f.expr[e] = P.p[kShapeParams + e];
  return f;
}

// Eyes: spheres behind the eyelids, rotating about their centres.
TubeDef eye_tube(const Measures& M) {
  const double head = M.head, eye_x = M.eye_x;
  // Undisplaced head surface in front of the eye: ellipse of the eye-level key.
  const double rx = 0.076 * head, rz = 0.097 * head, cz = 0.013 * head;
  const double zs = cz + rz * std::sqrt(std::max(0.0, 1 - (eye_x / rx) * (eye_x / rx)));
  const double re = 0.012 * head;
  TubeDef t;
  t.name = "eye_l";
  t.origin = V3(eye_x, M.Y(M.h_eye), zs - 0.001 * head - 2 * re);
  t.dir = V3(0, 0, 1);
  t.e1 = V3(0, -1, 0);
  t.length = 2 * re;
  t.cap0 = t.cap1 = re;
  t.keys = {{0, re, re, 0, 0}, {2 * re, re, re, 0, 0}};
  t.regress_all = jEyeL;
  t.owner = jEyeL;
  t.uv_density = 1.5;
  return t;
}

// Legs: from inside the pelvis down to the ankle (the bottom is hidden in the foot).
TubeDef leg_tube(const Measures& M) {
  const double s = M.s, g = M.g, leg = M.leg, sg = M.sg, h_ankle = M.h_ankle, h_knee = M.h_knee, h_hip = M.h_hip;
  TubeDef t;
  t.name = "leg_l";
  const double h0 = h_hip + 0.075 * s, h1 = h_ankle - 0.04 * s;
  t.origin = V3(M.hip_x, M.Y(h0), 0);
  t.dir = V3(0, -1, 0);
  t.e1 = V3(-1, 0, 0);  // seam on the inner side; e2 = -Z
  t.length = h0 - h1;
  t.cap0 = 0.06 * s;
  t.cap1 = 0.03 * s;
  auto key = [&](double h, double rx, double rz, double cz) { t.keys.push_back({h0 - h, rx, rz, 0, -cz}); };
  key(h0, 0.075 * g, 0.075 * g, 0);
  key(h_hip, 0.088 * g, 0.088 * g, -0.005);
  key(h_hip - 0.15 * s * leg, 0.077 * g, 0.078 * g, 0.0);
  key(h_knee + 0.07 * s, 0.057 * g, 0.058 * g, 0.003);
  key(h_knee, 0.050 * sg, 0.052 * sg, 0.005);
  key(h_knee - 0.11 * s, 0.054 * g, 0.060 * g, -0.012);
  key(h_knee - 0.26 * s, 0.039 * sg, 0.042 * sg, -0.005);
  key(h_ankle, 0.032, 0.036, 0);
  key(h1, 0.030, 0.032, 0);
  sort_keys(t);
  t.joints = {{h0 - h_hip, jHipL}, {h0 - h_knee, jKneeL}, {h0 - h_ankle, jAnkleL}};
  t.owner = jPelvis;
  t.bounds = {{h0 - h_hip, jHipL, 0.05 * s}, {h0 - h_knee, jKneeL, 0.04 * s}, {h0 - h_ankle, jAnkleL, 0.025 * s}};
  return t;
}

// Feet: heel to toes along +Z (slightly turned out), sole on the floor.
TubeDef foot_tube(const Measures& M) {
  const double s = M.s;
  TubeDef t;
  t.name = "foot_l";
  t.origin = V3(M.hip_x + 0.005, M.Y(0), -0.06 * s);
  t.dir = unit(V3(0.08, 0, 1));
  t.e1 = V3(0, -1, 0);  // seam under the sole; e2 = +X
  t.length = 0.255 * s;
  t.cap0 = 0.03 * s;
  t.cap1 = 0.025 * s;
  t.exponent = 2.6;
  auto key = [&](double a, double rv, double rw, double cw) { t.keys.push_back({a * s, rv * s, rw * s, -rv * s, cw * s}); };
  key(0.0, 0.035, 0.030, 0);
  key(0.04, 0.045, 0.034, 0);
  key(0.075, 0.052, 0.037, 0);
  key(0.13, 0.036, 0.044, 0.003);
  key(0.175, 0.021, 0.047, 0.004);
  key(0.22, 0.016, 0.042, 0.002);
  key(0.255, 0.014, 0.035, 0);
  t.joints = {{0.175 * s, jFootL}};
  t.owner = jAnkleL;
  t.bounds = {{0.175 * s, jFootL, 0.02 * s}};
  return t;
}

// Arms: T-pose along +X from inside the chest (collar) past the wrist.
TubeDef arm_tube(const Measures& M) {
  const double g = M.g, sg = M.sg, shw = M.shw, hand = M.hand;
  const double collar_x = M.collar_x, shoulder_x = M.shoulder_x, elbow_x = M.elbow_x, wrist_x = M.wrist_x;
  TubeDef t;
  t.name = "arm_l";
  const double x0 = 0.045 * shw, x1 = wrist_x + 0.02 * hand;
  t.origin = V3(x0, M.y_arm, M.arm_z);
  t.dir = V3(1, 0, 0);
  t.e1 = V3(0, -1, 0);  // seam underneath; e2 = -Z
  t.length = x1 - x0;
  t.cap0 = 0.04;
  t.cap1 = 0.018 * hand;
  auto key = [&](double x, double rv, double rd) { t.keys.push_back({x - x0, rv, rd, 0, 0}); };
  key(x0, 0.045 * sg, 0.045 * sg);
  key(collar_x, 0.050 * g, 0.050 * g);
  key(shoulder_x - 0.03, 0.060 * g, 0.057 * g);
  key(shoulder_x + 0.06, 0.052 * g, 0.050 * g);
  key(elbow_x - 0.06, 0.041 * g, 0.043 * g);
  key(elbow_x, 0.036 * sg, 0.039 * sg);
  key(elbow_x + 0.07, 0.041 * g, 0.046 * g);
  key(wrist_x - 0.06, 0.028 * sg, 0.034 * sg);
  key(wrist_x, 0.021 * hand, 0.030 * hand);
  key(x1, 0.020 * hand, 0.029 * hand);
  sort_keys(t);
  t.joints = {{collar_x - x0, jCollarL}, {shoulder_x - x0, jShoulderL}, {elbow_x - x0, jElbowL}, {wrist_x - x0, jWristL}};
  t.owner = jCollarL;
  t.bounds = {{shoulder_x - x0, jShoulderL, 0.045}, {elbow_x - x0, jElbowL, 0.035}, {wrist_x - x0, jWristL, 0.02 * hand}};
  return t;
}

// Hands: palm (wrist to knuckles), four fingers and a thumb; palm down, thumb forward.
constexpr double kKnuckleX[4] = {0.088, 0.090, 0.079, 0.086};  // index, middle, pinky, ring
constexpr double kKnuckleZ[4] = {0.028, 0.009, -0.028, -0.010};
constexpr double kFingerSpread[4] = {0.10, 0.02, -0.17, -0.07};  // radians about Y, toward +Z
constexpr double kSegLen[5][3] = {{0.042, 0.025, 0.021}, {0.047, 0.029, 0.023}, {0.034, 0.020, 0.019},
                                  {0.044, 0.027, 0.022}, {0.040, 0.032, 0.027}};
constexpr double kFingerR[5] = {0.0095, 0.0098, 0.0082, 0.0092, 0.0110};

TubeDef palm_tube(const Measures& M) {
  const double hand = M.hand, arm_z = M.arm_z;
  TubeDef t;
  t.name = "palm_l";
  const double x0 = M.wrist_x - 0.012 * hand;
  t.origin = V3(x0, M.palm_y, arm_z);
  t.dir = V3(1, 0, 0);
  t.e1 = V3(0, 0, -1);  // seam along the little-finger edge; e2 = +Y
  t.length = 0.10 * hand;
  t.cap0 = 0.012 * hand;
  t.cap1 = 0.010 * hand;
  t.exponent = 2.6;
  auto key = [&](double a, double rw, double rt) { t.keys.push_back({a * hand, rw * hand, rt * hand, 0, 0}); };
  key(0.0, 0.026, 0.017);
  key(0.02, 0.034, 0.018);
  key(0.06, 0.041, 0.016);
  key(0.09, 0.044, 0.0135);
  key(0.10, 0.043, 0.012);
  t.owner = jWristL;
  t.extra = Extra::palm;
  t.uv_density = 1.2;
  for (int f = 0; f < 4; ++f) {
    t.finger_z[f] = arm_z + kKnuckleZ[f] * hand;
    t.finger_joint[f] = hand_joint(f, 0);
  }
  return t;
}

TubeDef finger_tube(const Measures& M, const Details& d, int f) {
  static const char* kFingerNames[5] = {"index_l", "middle_l", "pinky_l", "ring_l", "thumb_l"};
  const double hand = M.hand, wrist_x = M.wrist_x, palm_y = M.palm_y, arm_z = M.arm_z;
  TubeDef t;
  t.name = kFingerNames[f];
  const double r = kFingerR[f] * hand;
  const double l1 = kSegLen[f][0] * hand * d.finger_len[f], l2 = kSegLen[f][1] * hand * d.finger_len[f];
  const double l3 = kSegLen[f][2] * hand * d.finger_len[f];
  V3 base;
  double back;  // part of the tube inside the palm
  if (f == fThumb) {
    base = V3(wrist_x + 0.018 * hand, palm_y - 0.008 * hand, arm_z + 0.020 * hand);
    t.dir = unit(V3(0.75, -0.25, 0.85));
    back = 0.012 * hand;
  } else {
    base = V3(wrist_x + kKnuckleX[f] * hand, palm_y + 0.001 * hand, arm_z + kKnuckleZ[f] * hand);
    t.dir = V3(std::cos(kFingerSpread[f]), 0, std::sin(kFingerSpread[f]));
    back = 0.016 * hand;
  }
  t.origin = base - back * t.dir;
  const V3 down(0, -1, 0);
  t.e1 = unit(down - dot(down, t.dir) * t.dir);  // seam on the palm side
  t.length = back + l1 + l2 + l3;
  t.cap0 = 0.006 * hand;
  t.cap1 = 0.75 * r;
  const double thick = f == fThumb ? 1.15 : 1.0;
  t.keys = {{0, 0.9 * r, 0.95 * r, 0, 0},
            {back, thick * r, thick * 1.05 * r, 0, 0},
            {back + l1, 0.88 * r, 0.92 * r, 0, 0},
            {back + l1 + 0.5 * l2, 0.85 * r, 0.88 * r, 0, 0},
            {back + l1 + l2, 0.80 * r, 0.84 * r, 0, 0},
            {t.length, 0.72 * r, 0.75 * r, 0, 0}};
  t.joints = {{back, hand_joint(f, 0)}, {back + l1, hand_joint(f, 1)}, {back + l1 + l2, hand_joint(f, 2)}};
  t.owner = jWristL;
  t.bounds = {{back, hand_joint(f, 0), 0.007 * hand},
              {back + l1, hand_joint(f, 1), 0.005 * hand},
              {back + l1 + l2, hand_joint(f, 2), 0.004 * hand}};
  t.uv_density = 1.2;
  return t;
}

void add_pair(Body& body, const TubeDef& left) {
  body.tubes.push_back(left);
  body.tubes.push_back(mirror(left));
}

// Tube order is the vertex order of the model: keep it.
Body build_body(const Params& P) {
  const Measures M = measures(P);
  Body body;
  body.y_shoulder = M.Y(M.h_sh);
  body.y_hip = M.Y(M.h_hip);
  body.tubes.push_back(torso_tube(M));
  body.tubes.push_back(head_tube(M));
  body.face = head_face(M, P);
  add_pair(body, eye_tube(M));
  add_pair(body, leg_tube(M));
  add_pair(body, foot_tube(M));
  add_pair(body, arm_tube(M));
  add_pair(body, palm_tube(M));
  for (int f = 0; f < 5; ++f) add_pair(body, finger_tube(M, P.d, f));
  return body;
}

// ---- rings and columns (fixed at the base proportions)
struct PartLayout {
  int columns = 0;
  std::vector<double> ring_t;   // axial fraction of each ring, increasing in (0, 1)
  std::vector<int> joint_ring;  // ring of each TubeDef::joints entry
  int v0 = 0, f0 = 0, uv0 = 0;
  int num_verts() const { return int(ring_t.size()) * columns + 2; }
  int num_faces() const { return 2 * columns * int(ring_t.size()); }
  int num_uv() const { return (columns + 1) * int(ring_t.size()) + 2 * columns; }
  int vert(int ring, int col) const { return v0 + 1 + ring * columns + (col % columns); }
  int pole0() const { return v0; }
  int pole1() const { return v0 + 1 + int(ring_t.size()) * columns; }
};

struct Resolution {
  int columns, rings;
};
Resolution tube_resolution(const std::string& name, BodyResolution r) {
  const bool full = r == BodyResolution::full;
  const std::string kind = name.substr(0, name.find('_'));
  if (kind == "torso") return full ? Resolution{40, 52} : Resolution{16, 20};
  if (kind == "head") return full ? Resolution{52, 42} : Resolution{20, 14};
  if (kind == "leg") return full ? Resolution{24, 42} : Resolution{10, 16};
  if (kind == "foot") return full ? Resolution{20, 16} : Resolution{8, 8};
  if (kind == "arm") return full ? Resolution{20, 40} : Resolution{10, 16};
  if (kind == "palm") return full ? Resolution{16, 10} : Resolution{8, 5};
  if (kind == "eye") return full ? Resolution{12, 8} : Resolution{8, 5};
  return full ? Resolution{10, 14} : Resolution{6, 6};  // fingers
}

std::vector<PartLayout> make_layout(const Body& base, BodyResolution res) {
  std::vector<PartLayout> out;
  int v0 = 0, f0 = 0, uv0 = 0;
  for (const TubeDef& t : base.tubes) {
    const Resolution r = tube_resolution(t.name, res);
    PartLayout L;
    L.columns = r.columns;
    // Cumulative meridian length (axial, radial and centre movement) over the axis.
    constexpr int kSamples = 2000;
    std::vector<double> cost(kSamples + 1, 0.0);
    Prof prev = eval_profile(t, 0);
    for (int i = 1; i <= kSamples; ++i) {
      const double a = t.length * i / kSamples;
      const Prof q = eval_profile(t, a);
      const double dr = 0.5 * ((q.r1 - prev.r1) + (q.r2 - prev.r2));
      const double dc = std::hypot(q.c1 - prev.c1, q.c2 - prev.c2);
      cost[i] = cost[i - 1] + std::sqrt(std::pow(t.length / kSamples, 2) + dr * dr + dc * dc);
      prev = q;
    }
    auto cost_at = [&](double tt) {
      const double x = clamp(tt, 0.0, 1.0) * kSamples;
      const int i = std::min(int(x), kSamples - 1);
      return cost[i] + (x - i) * (cost[i + 1] - cost[i]);
    };
    auto t_at = [&](double c) {
      const int i = int(std::upper_bound(cost.begin(), cost.end(), c) - cost.begin()) - 1;
      const int j = clamp(i, 0, kSamples - 1);
      const double f = (c - cost[j]) / std::max(cost[j + 1] - cost[j], 1e-12);
      return (j + clamp(f, 0.0, 1.0)) / kSamples;
    };
    // Joint rings are fixed knots; the free rings go to the gaps by meridian length.
    std::vector<double> knots = {0.0};
    for (const auto& j : t.joints) knots.push_back(j.first / t.length);
    knots.push_back(1.0);
    if (!std::is_sorted(knots.begin(), knots.end())) throw std::logic_error("procedural body: joints out of order in " + t.name);
    const int gaps = int(knots.size()) - 1;
    const int free_rings = r.rings - int(t.joints.size());
    std::vector<double> gap_cost(gaps);
    for (int i = 0; i < gaps; ++i) gap_cost[i] = cost_at(knots[i + 1]) - cost_at(knots[i]);
    const double total = std::accumulate(gap_cost.begin(), gap_cost.end(), 0.0);
    std::vector<int> count(gaps);
    std::vector<std::pair<double, int>> remainders;
    int used = 0;
    for (int i = 0; i < gaps; ++i) {
      const double share = free_rings * gap_cost[i] / total;
      count[i] = int(share);
      used += count[i];
      remainders.push_back({share - count[i], i});
    }
    std::sort(remainders.rbegin(), remainders.rend());
    for (int i = 0; used < free_rings; ++i, ++used) count[remainders[i % gaps].second]++;
    // Keep at least one ring between a pole and the nearest joint ring.
    for (int end : {0, gaps - 1}) {
      if (count[end] == 0) {
        const int donor = int(std::max_element(count.begin(), count.end()) - count.begin());
        count[donor]--;
        count[end]++;
      }
    }
    for (int i = 0; i < gaps; ++i) {
      const double c0 = cost_at(knots[i]), c1 = cost_at(knots[i + 1]);
      for (int k = 0; k < count[i]; ++k) L.ring_t.push_back(t_at(c0 + (c1 - c0) * (k + 1) / (count[i] + 1)));
      if (i + 1 < gaps) {
        L.joint_ring.push_back(int(L.ring_t.size()));
        L.ring_t.push_back(knots[i + 1]);
      }
    }
    for (size_t i = 1; i < L.ring_t.size(); ++i)
      if (!(L.ring_t[i] > L.ring_t[i - 1])) throw std::logic_error("procedural body: rings out of order in " + t.name);
    L.v0 = v0;
    L.f0 = f0;
    L.uv0 = uv0;
    v0 += L.num_verts();
    f0 += L.num_faces();
    uv0 += L.num_uv();
    out.push_back(std::move(L));
  }
  return out;
}

// ---- face: static features along the surface normal, expressions as vector fields
struct Bump {
  double x, y, sx, sy;  // centre (x, y relative to eye level) and widths, in head units
  double amp;
};
double gauss2(double x, double y, double cx, double cy, double sx, double sy) {
  return std::exp(-0.5 * ((x - cx) * (x - cx) / (sx * sx) + (y - cy) * (y - cy) / (sy * sy)));
}

V3 face_displacement(const Face& f, V3 pos, V3 normal) {
  const double hs = f.hs;
  const double x = pos.x / hs, y = (pos.y - f.y_eye) / hs;
  const double ex = f.eye_x / hs;
  const double front = smoothstep(0.15, 0.6, normal.z);
  V3 d(0, 0, 0);
  if (front > 0) {
    const Details& D = f.d;
    const Bump bumps[] = {
        {0, -0.005, 0.007, 0.018, 0.010 * D.nose},   // nose bridge
        {0, -0.030, 0.011, 0.014, 0.018 * D.nose},   // nose
        {0.012, -0.037, 0.006, 0.006, 0.004},        // nostril wings
        {-0.012, -0.037, 0.006, 0.006, 0.004},
        {ex, 0.0, 0.013, 0.010, -0.009},             // eye sockets
        {-ex, 0.0, 0.013, 0.010, -0.009},
        {0.030, 0.019, 0.018, 0.006, 0.004 * D.brows},  // brows
        {-0.030, 0.019, 0.018, 0.006, 0.004 * D.brows},
        {0.045, -0.020, 0.015, 0.015, 0.004},        // cheekbones
        {-0.045, -0.020, 0.015, 0.015, 0.004},
        {0, -0.057, 0.017, 0.005, 0.005 * D.lips},   // upper lip
        {0, -0.071, 0.015, 0.005, 0.005 * D.lips},   // lower lip
        {0, -0.064, 0.022, 0.0022, -0.003},          // mouth line
        {0, -0.100, 0.014, 0.010, 0.006},            // chin
    };
    double amp = 0;
    for (const Bump& b : bumps) amp += b.amp * gauss2(x, y, b.x, b.y, b.sx, b.sy);
    d += (front * amp * hs) * normal;
    // Expressions: per unit coefficient, a displacement field (head units), mirrored in x.
    struct Field {
      int e;
      double x, y, sx, sy;
      V3 v;
      bool mirror;
    };
    static const Field fields[] = {
        {0, 0.025, -0.064, 0.010, 0.010, V3(0.004, 0.004, -0.002), true},    // smile: corners up/out
        {0, 0.040, -0.035, 0.015, 0.015, V3(0.0, 0.002, 0.002), true},       //        cheeks up
        {1, 0.025, -0.064, 0.010, 0.012, V3(0.005, 0.0, -0.001), true},      // mouth stretch
        {2, 0.0, -0.064, 0.015, 0.012, V3(0.0, 0.0, 0.006), false},          // pucker: lips forward
        {2, 0.022, -0.064, 0.008, 0.010, V3(-0.003, 0.0, 0.0), true},        //         corners in
        {3, 0.030, 0.020, 0.015, 0.008, V3(0.0, 0.004, 0.001), true},        // brows up
        {4, 0.020, 0.018, 0.012, 0.008, V3(-0.002, -0.003, 0.0), true},      // frown
        {5, 0.045, -0.045, 0.015, 0.015, V3(0.004, 0.0, 0.003), true},       // cheek puff
        {6, 0.0, -0.057, 0.015, 0.005, V3(0.0, 0.003, 0.001), false},        // upper lip up
        {7, 0.0, -0.072, 0.015, 0.005, V3(0.0, -0.003, 0.001), false},       // lower lip down
        {8, 0.032, 0.008, 0.012, 0.004, V3(0.0, -0.003, 0.001), true},       // squint: upper lid
        {8, 0.032, -0.009, 0.012, 0.004, V3(0.0, 0.002, 0.0), true},         //         lower lid
        {9, 0.010, -0.025, 0.006, 0.008, V3(0.0, 0.003, 0.0015), true},       // nose wrinkle
    };
    for (const Field& fl : fields) {
      const double c = f.expr[fl.e];
      if (c == 0) continue;
      d += (c * front * hs * gauss2(x, y, fl.x, fl.y, fl.sx, fl.sy)) * fl.v;
      if (fl.mirror)  // the same field on the subject's right, mirrored
        d += (c * front * hs * gauss2(x, y, -fl.x, fl.y, fl.sx, fl.sy)) * V3(-fl.v.x, fl.v.y, fl.v.z);
    }
  }
  // Ears: bumps on the sides.
  const double side = smoothstep(0.6, 0.95, std::abs(normal.x));
  if (side > 0) {
    const double z = (pos.z - f.ear_z) / hs;
    d += (side * 0.011 * f.d.ears * hs * gauss2(z, y, 0, -0.012, 0.011, 0.024)) * normal;
  }
  return d;
}

// ---- vertex positions
void eval_tube(const TubeDef& t, const PartLayout& L, const Face* face, std::vector<V3>& out) {
  const V3 e1 = t.e1, e2 = t.e2();
  const int n = L.columns;
  auto centre = [&](double a, const Prof& q) { return t.origin + a * t.dir + q.c1 * e1 + q.c2 * e2; };
  {
    const Prof q = eval_profile(t, 0);
    out[L.pole0()] = centre(0, q);
    const Prof q1 = eval_profile(t, t.length);
    out[L.pole1()] = centre(t.length, q1);
  }
  for (int i = 0; i < int(L.ring_t.size()); ++i) {
    const double a = L.ring_t[i] * t.length;
    const Prof q = eval_profile(t, a);
    const V3 c = centre(a, q);
    for (int k = 0; k < n; ++k) {
      const double phi = 2 * kPi * k / n, cs = std::cos(phi), sn = std::sin(phi);
      V3 pos = c + (q.r1 * superellipse(cs, t.exponent)) * e1 + (q.r2 * superellipse(sn, t.exponent)) * e2;
      if (face) {
        const V3 normal = unit((cs / std::max(q.r1, 1e-9)) * e1 + (sn / std::max(q.r2, 1e-9)) * e2);
        pos += face_displacement(*face, pos, normal);
      }
      out[L.vert(i, k)] = pos;
    }
  }
}

std::vector<V3> eval_vertices(const Body& b, const std::vector<PartLayout>& layout) {
  std::vector<V3> v(layout.back().v0 + layout.back().num_verts());
  for (size_t i = 0; i < b.tubes.size(); ++i)
    eval_tube(b.tubes[i], layout[i], b.tubes[i].face ? &b.face : nullptr, v);
  return v;
}

// ---- skinning weights (sparse per vertex, then dense)
using Weights = std::vector<std::pair<int, double>>;
void add_weight(Weights& w, int j, double x) {
  if (x <= 0) return;
  for (auto& e : w)
    if (e.first == j) {
      e.second += x;
      return;
    }
  w.push_back({j, x});
}
Weights scaled(const Weights& w, double s) {
  Weights r;
  for (auto& e : w) add_weight(r, e.first, e.second * s);
  return r;
}

Weights chain_weights(const TubeDef& t, double a) {
  int prev = t.owner;
  for (const Boundary& b : t.bounds) {
    if (a <= b.a - b.half) break;
    if (a >= b.a + b.half) {
      prev = b.joint;
      continue;
    }
    const double s = smoothstep(b.a - b.half, b.a + b.half, a);
    Weights w;
    add_weight(w, prev, 1 - s);
    add_weight(w, b.joint, s);
    return w;
  }
  return {{prev, 1.0}};
}

Weights vertex_weights(const Body& body, const TubeDef& t, double a, V3 pos) {
  Weights w = chain_weights(t, a);
  switch (t.extra) {
    case Extra::none: break;
    case Extra::torso: {
      // Shoulder tops follow the collar bones, the buttocks and groin the hips.
      const double ax = std::abs(pos.x), ys = body.y_shoulder, yh = body.y_hip;
      const double wc = smoothstep(0.09, 0.16, ax) * smoothstep(ys - 0.13, ys - 0.05, pos.y) *
                        (1 - smoothstep(ys + 0.01, ys + 0.05, pos.y));
      const double wh = 0.8 * smoothstep(0.03, 0.12, ax) * (1 - smoothstep(yh - 0.01, yh + 0.07, pos.y));
      w = scaled(w, 1 - wc - wh);
      add_weight(w, pos.x > 0 ? jCollarL : mirror_joint(jCollarL), wc);
      add_weight(w, pos.x > 0 ? jHipL : mirror_joint(jHipL), wh);
      break;
    }
    case Extra::head: {
      // The bottom (inside the neck) follows the neck; above it, below the mouth line and
      // in front of the jaw joint, the jaw; the rest the head.
      const Face& f = body.face;
      const double nk = 1 - smoothstep(f.y_neck_lo, f.y_neck_hi, pos.y);
      const double jaw = (1 - nk) * (1 - smoothstep(f.y_mouth - 0.02 * f.hs, f.y_mouth + 0.004 * f.hs, pos.y)) *
                         smoothstep(f.z_jaw - 0.005 * f.hs, f.z_jaw + 0.04 * f.hs, pos.z);
      w = {};
      add_weight(w, jJawJ, jaw);
      add_weight(w, jNeck, nk);
      add_weight(w, jHead, 1 - jaw - nk);
      break;
    }
    case Extra::palm: {
      // Knuckle region blends into the first joint of the nearest fingers.
      const double wf = smoothstep(t.length - 0.03, t.length - 0.008, a);
      if (wf > 0) {
        double g[4], sum = 0;
        for (int f = 0; f < 4; ++f) sum += g[f] = std::exp(-0.5 * std::pow((pos.z - t.finger_z[f]) / 0.008, 2));
        w = scaled(w, 1 - wf);
        for (int f = 0; f < 4; ++f) add_weight(w, t.finger_joint[f], wf * g[f] / sum);
      }
      break;
    }
  }
  // At most four influences (the largest), none negligible; renormalised.
  std::sort(w.begin(), w.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  if (w.size() > 4) w.resize(4);
  Weights r;
  double sum = 0;
  for (auto& e : w)
    if (e.second >= 1e-3) {
      r.push_back(e);
      sum += e.second;
    }
  for (auto& e : r) e.second /= sum;
  return r;
}

// ---- UV atlas: one rectangular chart per tube (u around, v along the meridian), seams
// duplicated, pole triangles get their own pole UV; charts shelf-packed into [0,1]^2.
struct Chart {
  std::vector<Vec2<double>> uv;  // local chart coordinates, (0,0)..(w,h)
  double w = 0, h = 0;
  bool rotated = false;
  double x = 0, y = 0;  // placement
};

Chart make_chart(const TubeDef& t, const PartLayout& L, const std::vector<V3>& v) {
  const int n = L.columns, m = int(L.ring_t.size());
  std::vector<double> vv(m);
  auto ring_dist = [&](int i, int j) {
    double s = 0;
    for (int k = 0; k < n; ++k) s += norm(v[L.vert(i, k)] - v[L.vert(j, k)]);
    return s / n;
  };
  auto pole_dist = [&](int pole, int i) {
    double s = 0;
    for (int k = 0; k < n; ++k) s += norm(v[L.vert(i, k)] - v[pole]);
    return s / n;
  };
  vv[0] = pole_dist(L.pole0(), 0);
  for (int i = 1; i < m; ++i) vv[i] = vv[i - 1] + ring_dist(i - 1, i);
  const double H = vv[m - 1] + pole_dist(L.pole1(), m - 1);
  double W = 0;
  for (int i = 0; i < m; ++i) {
    double per = 0;
    for (int k = 0; k < n; ++k) per += norm(v[L.vert(i, k + 1)] - v[L.vert(i, k)]);
    W = std::max(W, per);
  }
  Chart c;
  const double s = t.uv_density;
  for (int i = 0; i < m; ++i)
    for (int k = 0; k <= n; ++k) c.uv.push_back({s * W * k / n, s * vv[i]});
  for (int k = 0; k < n; ++k) c.uv.push_back({s * W * (k + 0.5) / n, 0.0});
  for (int k = 0; k < n; ++k) c.uv.push_back({s * W * (k + 0.5) / n, s * H});
  c.w = s * W;
  c.h = s * H;
  return c;
}

constexpr double kUvMargin = 0.006;  // about 3 texels at 512 x 512 between charts

// Shelf packing at scale `scale`; returns the used height (> 1 = does not fit).
double shelf_pack(std::vector<Chart>& charts, const std::vector<int>& order, double scale) {
  double x = kUvMargin, y = kUvMargin, shelf = 0;
  for (int i : order) {
    Chart& c = charts[i];
    const double w = scale * (c.rotated ? c.h : c.w), h = scale * (c.rotated ? c.w : c.h);
    if (w + 2 * kUvMargin > 1) return 2;
    if (x + w + kUvMargin > 1) {
      y += shelf + kUvMargin;
      x = kUvMargin;
      shelf = 0;
    }
    c.x = x;
    c.y = y;
    x += w + kUvMargin;
    shelf = std::max(shelf, h);
  }
  return y + shelf + kUvMargin;
}

void pack_charts(std::vector<Chart>& charts) {
  for (Chart& c : charts) c.rotated = c.h > c.w;  // lay every chart on its long side
  std::vector<int> order(charts.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const double ha = charts[a].rotated ? charts[a].w : charts[a].h;
    const double hb = charts[b].rotated ? charts[b].w : charts[b].h;
    return ha > hb;
  });
  double lo = 0, hi = 10;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (shelf_pack(charts, order, mid) <= 1 ? lo : hi) = mid;
  }
  shelf_pack(charts, order, lo);
  for (Chart& c : charts)
    for (auto& p : c.uv) {
      // Rotation by +90 degrees keeps the triangles' orientation.
      const Vec2<double> q = c.rotated ? Vec2<double>(c.h - p.y, p.x) : p;
      p = {c.x + lo * q.x, c.y + lo * q.y};
    }
}

// ---- hand PCA: orthonormal rows; the first ones are meaningful (curl, spread, ...).
void hand_pca(const Body& base, bool left, std::vector<float>& comps, std::vector<float>& mean) {
  // Flexion axis of each finger (left hand): curls the finger toward the palm (-Y).
  std::array<V3, 5> flex;
  for (const TubeDef& t : base.tubes) {
    static const char* names[5] = {"index_l", "middle_l", "pinky_l", "ring_l", "thumb_l"};
    for (int f = 0; f < 5; ++f)
      if (t.name == names[f]) flex[f] = unit(cross(t.dir, V3(0, -1, 0)));
  }
  using Vec45 = std::array<double, 45>;
  auto set = [](Vec45& v, int f, int seg, V3 axis, double s) {
    for (int c = 0; c < 3; ++c) v[3 * (3 * f + seg) + c] += s * axis[c];
  };
  std::vector<Vec45> basis;
  Vec45 c{};
  for (int f = 0; f < 5; ++f)
    for (int s = 0; s < 3; ++s) set(c, f, s, flex[f], f == fThumb ? 0.7 : 1.0);  // curl all
  basis.push_back(c);
  c = {};
  const double spread[4] = {-1.0, -0.2, 1.0, 0.6};  // index, middle, pinky, ring about Y
  for (int f = 0; f < 4; ++f) set(c, f, 0, V3(0, 1, 0), spread[f]);
  basis.push_back(c);
  c = {};
  for (int s = 0; s < 3; ++s) set(c, fThumb, s, flex[fThumb], 1.0);  // thumb across the palm
  set(c, fThumb, 0, V3(1, 0, 0), 0.5);
  basis.push_back(c);
  c = {};
  for (int f = 0; f < 4; ++f) {  // knuckles bent, fingers straight ("flat hook")
    set(c, f, 0, flex[f], 1.0);
    set(c, f, 1, flex[f], -0.5);
    set(c, f, 2, flex[f], -0.5);
  }
  basis.push_back(c);
  c = {};
  for (int f = 0; f < 4; ++f)
    for (int s = 0; s < 3; ++s) set(c, f, s, flex[f], (f == fIndex || f == fMiddle) ? 1.0 : -1.0);
  basis.push_back(c);
  for (int i = 0; i < 45; ++i) {
    Vec45 e{};
    e[i] = 1;
    basis.push_back(e);
  }
  // Gram-Schmidt (twice, for accuracy); dependent vectors are dropped.
  std::vector<Vec45> ortho;
  for (Vec45 v : basis) {
    for (int pass = 0; pass < 2; ++pass)
      for (const Vec45& o : ortho) {
        double d = 0;
        for (int i = 0; i < 45; ++i) d += v[i] * o[i];
        for (int i = 0; i < 45; ++i) v[i] -= d * o[i];
      }
    double nn = 0;
    for (double x : v) nn += x * x;
    if (nn < 1e-10) continue;
    for (double& x : v) x /= std::sqrt(nn);
    ortho.push_back(v);
    if (ortho.size() == 45) break;
  }
  Vec45 mu{};
  for (int f = 0; f < 5; ++f) {
    const double a[3] = {f == fThumb ? 0.05 : 0.15, f == fThumb ? 0.1 : 0.2, 0.1};
    for (int s = 0; s < 3; ++s) set(mu, f, s, flex[f], a[s]);
  }
  // The right hand is the mirror image: axis-angle (x, y, z) -> (x, -y, -z).
  auto out = [&](const Vec45& v, float* dst) {
    for (int i = 0; i < 45; ++i) dst[i] = float((left || i % 3 == 0) ? v[i] : -v[i]);
  };
  comps.assign(45 * 45, 0.f);
  mean.assign(45, 0.f);
  for (int r = 0; r < 45; ++r) out(ortho[r], comps.data() + 45 * r);
  out(mu, mean.data());
}

// ---- facial landmarks (the 51 inner iBUG points: brows, nose, eyes, mouth), found by
// casting rays along -Z onto the head surface. Targets in head units relative to eye
// level; subject's right (-X) comes first as in the 68-point convention.
std::vector<Vec2<double>> landmark_targets(double ex) {
  std::vector<Vec2<double>> p;
  const double brow_x[5] = {-0.050, -0.042, -0.032, -0.022, -0.012};
  const double brow_y[5] = {0.015, 0.021, 0.023, 0.022, 0.019};
  for (int i = 0; i < 5; ++i) p.push_back({brow_x[i], brow_y[i]});
  for (int i = 4; i >= 0; --i) p.push_back({-brow_x[i], brow_y[i]});
  for (double y : {0.005, -0.008, -0.020, -0.032}) p.push_back({0.0, y});  // nose bridge
  const double nx[5] = {-0.013, -0.007, 0, 0.007, 0.013}, ny[5] = {-0.040, -0.042, -0.043, -0.042, -0.040};
  for (int i = 0; i < 5; ++i) p.push_back({nx[i], ny[i]});
  // Eyes: outer corner, two upper, inner corner, two lower (right eye), then left eye.
  auto eye = [&](double cx, double s) {
    const double dx[6] = {-0.013, -0.005, 0.005, 0.013, 0.005, -0.005};
    const double dy[6] = {0.0, 0.0045, 0.0045, 0.0, -0.0045, -0.0045};
    for (int i = 0; i < 6; ++i) p.push_back({cx + s * dx[i], dy[i]});
  };
  eye(-ex, 1);
  // left eye starts at the inner corner: mirror of the right eye order
  {
    const double dx[6] = {-0.013, -0.005, 0.005, 0.013, 0.005, -0.005};
    const double dy[6] = {0.0, 0.0045, 0.0045, 0.0, -0.0045, -0.0045};
    for (int i = 0; i < 6; ++i) p.push_back({ex + dx[i], dy[i]});
  }
  const double mo_x[12] = {-0.025, -0.016, -0.006, 0, 0.006, 0.016, 0.025, 0.016, 0.006, 0, -0.006, -0.016};
  const double mo_y[12] = {-0.064, -0.058, -0.055, -0.054, -0.055, -0.058, -0.064, -0.071, -0.074, -0.075, -0.074, -0.071};
  for (int i = 0; i < 12; ++i) p.push_back({mo_x[i], mo_y[i]});
  const double mi_x[8] = {-0.020, -0.008, 0, 0.008, 0.020, 0.008, 0, -0.008};
  const double mi_y[8] = {-0.064, -0.062, -0.062, -0.062, -0.064, -0.066, -0.066, -0.066};
  for (int i = 0; i < 8; ++i) p.push_back({mi_x[i], mi_y[i]});
  return p;
}


// Base proportions for a seed (bit-exact across platforms: raw mt19937_64 output).
Params base_params(uint64_t seed) {
  Params base;
  base.p.fill(0);
  for (int i = 0; i < kShapeParams; ++i) base.p[i] = i == pBelly ? 0.0 : 1.0;
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 0x5EEDB0D1ull);
  auto sym = [&] { return 2.0 * double(rng() >> 11) * 0x1.0p-53 - 1.0; };
  const double var[kShapeParams] = {0.02, 0.04, 0.015, 0.03, 0.015, 0.02, 0.005, 0.03, 0.03, 0.05};
  for (int i = 0; i < kShapeParams; ++i) base.p[i] += var[i] * sym();
  for (double& f : base.d.finger_len) f = 1 + 0.04 * sym();
  base.d.eye_spacing = 1 + 0.04 * sym();
  base.d.nose = 1 + 0.12 * sym();
  base.d.lips = 1 + 0.15 * sym();
  base.d.ears = 1 + 0.15 * sym();
  base.d.brows = 1 + 0.15 * sym();
  return base;
}

// Faces and UV faces of every tube, then the packed UV atlas.
void add_faces_and_uvs(BodyModel& m, const Body& body, const std::vector<PartLayout>& layout, const std::vector<V3>& v) {
  const int F = m.num_faces;
  std::vector<Chart> charts;
  m.faces.resize(3 * size_t(F));
  m.ft.resize(3 * size_t(F));
  for (size_t p = 0; p < body.tubes.size(); ++p) {
    const PartLayout& L = layout[p];
    const int n = L.columns, rings = int(L.ring_t.size());
    auto uv_ring = [&](int i, int k) { return L.uv0 + i * (n + 1) + k; };
    const int uv_pole0 = L.uv0 + rings * (n + 1), uv_pole1 = uv_pole0 + n;
    int f = L.f0;
    auto tri = [&](int a, int b, int c, int ta, int tb, int tc) {
      m.faces[3 * f] = a, m.faces[3 * f + 1] = b, m.faces[3 * f + 2] = c;
      m.ft[3 * f] = ta, m.ft[3 * f + 1] = tb, m.ft[3 * f + 2] = tc;
      ++f;
    };
    for (int k = 0; k < n; ++k) tri(L.pole0(), L.vert(0, k + 1), L.vert(0, k), uv_pole0 + k, uv_ring(0, k + 1), uv_ring(0, k));
    for (int i = 0; i + 1 < rings; ++i)
      for (int k = 0; k < n; ++k) {
        tri(L.vert(i, k), L.vert(i, k + 1), L.vert(i + 1, k + 1), uv_ring(i, k), uv_ring(i, k + 1), uv_ring(i + 1, k + 1));
        tri(L.vert(i, k), L.vert(i + 1, k + 1), L.vert(i + 1, k), uv_ring(i, k), uv_ring(i + 1, k + 1), uv_ring(i + 1, k));
      }
    for (int k = 0; k < n; ++k)
      tri(L.vert(rings - 1, k), L.vert(rings - 1, k + 1), L.pole1(), uv_ring(rings - 1, k), uv_ring(rings - 1, k + 1), uv_pole1 + k);
    charts.push_back(make_chart(body.tubes[p], L, v));
  }
  pack_charts(charts);
  for (const Chart& c : charts)
    for (const auto& p : c.uv) {
      m.vt.push_back(float(p.x));
      m.vt.push_back(float(p.y));
    }
}

// Skeleton, joint regressor and skinning weights; returns the weights per vertex (the pose
// correctives need them unrounded).
std::vector<Weights> add_skeleton(BodyModel& m, const Body& body, const std::vector<PartLayout>& layout,
                                  const std::vector<V3>& v) {
  const int V = m.num_verts;
  m.parents.assign(kParents, kParents + kNumJoints);
  m.j_regressor.assign(size_t(kNumJoints) * V, 0.f);
  std::vector<int> regressed(kNumJoints, 0);
  std::vector<Weights> w(V);
  for (size_t p = 0; p < body.tubes.size(); ++p) {
    const TubeDef& t = body.tubes[p];
    const PartLayout& L = layout[p];
    const int n = L.columns;
    for (size_t j = 0; j < t.joints.size(); ++j) {
      const int joint = t.joints[j].second;
      for (int k = 0; k < n; ++k) m.j_regressor[size_t(joint) * V + L.vert(L.joint_ring[j], k)] = 1.f / n;
      regressed[joint]++;
    }
    if (t.regress_all >= 0) {
      for (int i = 0; i < L.num_verts(); ++i) m.j_regressor[size_t(t.regress_all) * V + L.v0 + i] = 1.f / L.num_verts();
      regressed[t.regress_all]++;
    }
    w[L.pole0()] = vertex_weights(body, t, 0, v[L.pole0()]);
    w[L.pole1()] = vertex_weights(body, t, t.length, v[L.pole1()]);
    for (int i = 0; i < int(L.ring_t.size()); ++i)
      for (int k = 0; k < n; ++k) w[L.vert(i, k)] = vertex_weights(body, t, L.ring_t[i] * t.length, v[L.vert(i, k)]);
  }
  for (int j = 0; j < kNumJoints; ++j)
    if (regressed[j] != 1) throw std::logic_error("procedural body: joint " + std::to_string(j) + " regressed " + std::to_string(regressed[j]) + " times");
  m.weights.assign(size_t(V) * kNumJoints, 0.f);
  for (int i = 0; i < V; ++i)
    for (auto& e : w[i]) m.weights[size_t(i) * kNumJoints + e.first] = float(e.second);
  return w;
}

// Shape and expression directions: central differences of the generator.
void add_shape_directions(BodyModel& m, const Params& base, const std::vector<PartLayout>& layout) {
  const int V = m.num_verts;
  const int D = m.num_shape + m.num_expr;
  m.shapedirs.assign(size_t(V) * 3 * D, 0.f);
  for (int q = 0; q < kParams; ++q) {
    const bool shape = q < kShapeParams;
    const double step = shape ? 1e-4 : 1.0;  // expressions are linear: exact
    const double unit_change = shape ? kShapeUnit[q] : 1.0;
    Params hi = base, lo = base;
    hi.p[q] += step;
    lo.p[q] -= step;
    const std::vector<V3> vh = eval_vertices(build_body(hi), layout), vl = eval_vertices(build_body(lo), layout);
    const int col = shape ? q : m.num_shape + (q - kShapeParams);
    for (int i = 0; i < V; ++i)
      for (int c = 0; c < 3; ++c)
        m.shapedirs[(size_t(i) * 3 + c) * D + col] = float((vh[i][c] - vl[i][c]) / (2 * step) * unit_change);
  }
}

// Pose correctives: where a vertex blends between joints, bending joint j pushes it
// outward by k w (1 - w) (1 - cos angle) * 2 (volume kept at bends). Non-zero only for
// the vertex's own joints, so sparse LBS stays sparse.
void add_pose_correctives(BodyModel& m, const std::vector<V3>& v, const std::vector<Weights>& w) {
  const int V = m.num_verts, F = m.num_faces;
  m.posedirs.assign(size_t(V) * 3 * kNumPoseFeatures, 0.f);
  std::vector<V3> normal(V, V3(0, 0, 0));
  for (int f = 0; f < F; ++f) {
    const int a = m.faces[3 * f], b = m.faces[3 * f + 1], c = m.faces[3 * f + 2];
    const V3 n = cross(v[b] - v[a], v[c] - v[a]);
    normal[a] += n, normal[b] += n, normal[c] += n;
  }
  constexpr double kBulge = 0.012;
  for (int i = 0; i < V; ++i) {
    const V3 n = unit(normal[i]);
    for (auto& e : w[i]) {
      if (e.first == 0 || e.second >= 1) continue;
      const double coef = -kBulge * e.second * (1 - e.second);
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d)
          m.posedirs[(size_t(i) * 3 + c) * kNumPoseFeatures + 9 * (e.first - 1) + 4 * d] = float(coef * n[c]);
    }
  }
}

// Landmarks on the head part.
void add_landmarks(BodyModel& m, const Body& body, const std::vector<PartLayout>& layout, const std::vector<V3>& v) {
  int head = -1;
  for (size_t p = 0; p < body.tubes.size(); ++p)
    if (body.tubes[p].name == "head") head = int(p);
  const PartLayout& L = layout[head];
  const Face& fc = body.face;
  for (const auto& t : landmark_targets(fc.eye_x / fc.hs)) {
    const double px = t.x * fc.hs, py = fc.y_eye + t.y * fc.hs;
    int best = -1;
    double best_z = -1e9, bary[3] = {0, 0, 0};
    for (int f = L.f0; f < L.f0 + L.num_faces(); ++f) {
      const V3 a = v[m.faces[3 * f]], b = v[m.faces[3 * f + 1]], c = v[m.faces[3 * f + 2]];
      if (cross(b - a, c - a).z <= 0) continue;  // back-facing
      const double det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
      if (std::abs(det) < 1e-14) continue;
      const double l1 = ((px - a.x) * (c.y - a.y) - (c.x - a.x) * (py - a.y)) / det;
      const double l2 = ((b.x - a.x) * (py - a.y) - (px - a.x) * (b.y - a.y)) / det;
      const double l0 = 1 - l1 - l2;
      if (l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9) continue;
      const double z = l0 * a.z + l1 * b.z + l2 * c.z;
      if (z > best_z) {
        best_z = z;
        best = f;
        bary[0] = l0, bary[1] = l1, bary[2] = l2;
      }
    }
    if (best < 0) throw std::logic_error("procedural body: landmark missed the face");
    m.lmk_faces_idx.push_back(best);
    for (double b : bary) m.lmk_bary_coords.push_back(float(std::max(0.0, b)));
  }
}

}  // namespace

BodyResolution parse_body_resolution(const std::string& s) {
  if (s == "low") return BodyResolution::low;
  if (s == "full") return BodyResolution::full;
  fail("--resolution", "unknown value '" + s + "' (expected low or full)");
}
const char* body_resolution_name(BodyResolution r) { return r == BodyResolution::low ? "low" : "full"; }

BodyModel make_procedural_body(const ProceduralBodyOptions& opt, ProceduralBodyInfo* info) {
  const Params base = base_params(opt.seed);
  const Body body = build_body(base);
  const std::vector<PartLayout> layout = make_layout(body, opt.resolution);
  const std::vector<V3> v = eval_vertices(body, layout);
  const int V = int(v.size());
  const int F = layout.back().f0 + layout.back().num_faces();

  BodyModel m;
  m.source = std::string("procedural body (") + body_resolution_name(opt.resolution) + ", seed " +
             std::to_string(opt.seed) + ")";
  m.num_verts = V;
  m.num_faces = F;
  m.num_shape = 300;
  m.num_expr = 100;
  m.v_template.resize(3 * size_t(V));
  for (int i = 0; i < V; ++i)
    for (int c = 0; c < 3; ++c) m.v_template[3 * i + c] = float(v[i][c]);

  add_faces_and_uvs(m, body, layout, v);
  const std::vector<Weights> w = add_skeleton(m, body, layout, v);
  add_shape_directions(m, base, layout);
  add_pose_correctives(m, v, w);
  hand_pca(body, true, m.hands_components_l, m.hands_mean_l);
  hand_pca(body, false, m.hands_components_r, m.hands_mean_r);
  add_landmarks(m, body, layout, v);

  if (info) {
    info->parts.clear();
    for (size_t p = 0; p < body.tubes.size(); ++p) {
      const PartLayout& L = layout[p];
      info->parts.push_back({body.tubes[p].name, L.v0, L.num_verts(), L.f0, L.num_faces(), L.uv0, L.num_uv()});
    }
    info->num_meaningful_shape = kShapeParams;
    info->num_meaningful_expr = kExprParams;
  }
  return m;
}

}  // namespace haha
