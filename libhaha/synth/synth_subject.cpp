// The clothed synthetic subject: anatomy landmarks from the rest joints, garment geometry
// (hair shell, ponytail, skirt) and the two painted textures. See synth_subject.h.
#include "synth/synth_subject.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <random>

#include "core/bitmap_font.h"
#include "core/error.h"
#include "core/parallel.h"
#include "synth/synth_internal.h"

namespace haha {
namespace synth {

// ---------------------------------------------------------------------------------------
// Small helpers

double smoothstep(double e0, double e1, double x) {
  const double t = clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

V3 unit(V3 v) {
  const double n = norm(v);
  return n > 0 ? v / n : v;
}

V3 mix(V3 a, V3 b, double t) { return a + t * (b - a); }

// Deterministic lattice hash -> [0, 1).
static double hash01(int64_t x, int64_t y, int64_t z, uint64_t seed) {
  uint64_t h = seed * 0x9E3779B97F4A7C15ull;
  h ^= uint64_t(x) * 0xBF58476D1CE4E5B9ull;
  h = (h ^ (h >> 31)) * 0x94D049BB133111EBull;
  h ^= uint64_t(y) * 0xD6E8FEB86659FD93ull;
  h = (h ^ (h >> 29)) * 0xBF58476D1CE4E5B9ull;
  h ^= uint64_t(z) * 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 32)) * 0x94D049BB133111EBull;
  h ^= h >> 29;
  return double(h >> 11) * 0x1.0p-53;
}

double value_noise(V3 p, double cell, uint64_t seed) {
  const V3 q = p / cell;
  const double fx = std::floor(q.x), fy = std::floor(q.y), fz = std::floor(q.z);
  const int64_t ix = int64_t(fx), iy = int64_t(fy), iz = int64_t(fz);
  auto s = [](double t) { return t * t * (3 - 2 * t); };
  const double tx = s(q.x - fx), ty = s(q.y - fy), tz = s(q.z - fz);
  double acc = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? tx : 1 - tx) * (dy ? ty : 1 - ty) * (dz ? tz : 1 - tz);
    acc += w * hash01(ix + dx, iy + dy, iz + dz, seed);
  }
  return acc;
}

// ---------------------------------------------------------------------------------------
// Anatomy

int joint_group(int j) {
  switch (j) {
    case 0: case 3: case 6: case 9: case 13: case 14: return gTorso;
    case 1: case 2: case 4: case 5: return gLeg;
    case 7: case 8: case 10: case 11: return gFoot;
    case 12: return gNeck;
    case 15: case 22: return gHead;
    case 23: case 24: return gEye;
    case 16: case 17: case 18: case 19: return gArm;
    default: return gHand;  // wrists 20, 21 and fingers 25..54
  }
}

Anatomy make_anatomy(const std::vector<float>& rest_joints, const std::vector<float>& rest_verts) {
  Anatomy a;
  for (int j = 0; j < kNumJoints; ++j) a.J[j] = V3(rest_joints[3 * j], rest_joints[3 * j + 1], rest_joints[3 * j + 2]);
  a.eye_mid = 0.5 * (a.J[kLeftEye] + a.J[kRightEye]);
  a.d = norm(a.J[kLeftEye] - a.J[kRightEye]);
  if (!(a.d > 0.02 && a.d < 0.2)) a.d = 0.064;  // models without eye joints: a typical value
  a.floor_y = 1e30;
  for (size_t i = 1; i < rest_verts.size(); i += 3) a.floor_y = std::min(a.floor_y, double(rest_verts[i]));
  a.waist_y = a.J[0].y + 0.07;
  return a;
}

// Height of the hairline at azimuth phi about the head (0 = face): forehead 0.9 eye
// distances above the eyes, just above the ears at the sides, the nape at the back.
static double hairline_y(const Anatomy& a, double phi) {
  return a.eye_mid.y + a.d * (1.25 * std::cos(phi) - 0.35 * std::cos(2 * phi));
}

double head_azimuth(const Anatomy& a, V3 p) { return std::atan2(p.x - a.J[kHeadJoint].x, p.z - a.J[kHeadJoint].z); }

double hair_depth(const Anatomy& a, V3 p) { return p.y - hairline_y(a, head_azimuth(a, p)); }

double hair_thickness(const Anatomy& a, V3 p) {
  const double hd = hair_depth(a, p);
  if (hd <= 0) return 0;
  const double phi = head_azimuth(a, p);
  const double base = 0.016 + 0.014 * (0.5 - 0.5 * std::cos(phi)) +
                      0.006 * smoothstep(a.eye_mid.y + 1.0 * a.d, a.eye_mid.y + 1.8 * a.d, p.y);
  const double lumps = 1 + 0.12 * std::sin(14 * phi + 25 * (p.y - a.eye_mid.y));
  return base * lumps * smoothstep(0, 0.3 * a.d, hd);
}

// ---------------------------------------------------------------------------------------
// Palette

Palette make_palette(uint64_t seed) {
  std::mt19937_64 rng(seed * 0xD1B54A32D192ED03ull + 0xC0FFEEull);
  auto pick = [&](int n) { return int(rng() % uint64_t(n)); };
  static const V3 skins[] = {{0.87, 0.67, 0.55}, {0.76, 0.55, 0.42}, {0.56, 0.39, 0.28}, {0.93, 0.77, 0.67}};
  static const V3 shirts[] = {{0.13, 0.22, 0.52}, {0.66, 0.11, 0.13}, {0.10, 0.44, 0.26}, {0.42, 0.20, 0.56}};
  static const V3 trousers[] = {{0.16, 0.25, 0.45}, {0.23, 0.23, 0.26}, {0.30, 0.33, 0.18}, {0.11, 0.11, 0.13}};
  static const V3 hairs[] = {{0.24, 0.14, 0.07}, {0.09, 0.08, 0.08}, {0.52, 0.23, 0.09}, {0.80, 0.64, 0.34}};
  static const V3 irises[] = {{0.20, 0.42, 0.72}, {0.36, 0.22, 0.10}, {0.26, 0.52, 0.30}};
  struct Tartan {
    V3 base, dark, line;
  };
  static const Tartan tartans[] = {{{0.64, 0.08, 0.10}, {0.06, 0.16, 0.10}, {0.92, 0.82, 0.25}},
                                   {{0.12, 0.22, 0.58}, {0.05, 0.07, 0.20}, {0.92, 0.92, 0.92}},
                                   {{0.10, 0.40, 0.22}, {0.05, 0.08, 0.20}, {0.85, 0.15, 0.15}}};
  static const V3 shoes[] = {{0.92, 0.92, 0.90}, {0.55, 0.12, 0.10}, {0.14, 0.14, 0.16}};
  Palette p;
  p.skin = skins[pick(4)];
  p.shirt = shirts[pick(4)];
  p.trousers = trousers[pick(4)];
  p.hair = hairs[pick(4)];
  p.iris = irises[pick(3)];
  const Tartan& t = tartans[pick(3)];
  p.skirt = t.base;
  p.skirt_dark = t.dark;
  p.skirt_line = t.line;
  p.shoe = shoes[pick(3)];
  p.accent = V3(0.95, 0.78, 0.15);
  p.lips = mix(p.skin, V3(0.72, 0.22, 0.25), 0.6);
  p.hair_tie = V3(0.95, 0.35, 0.55);
  p.noise_seed = rng();
  return p;
}

// ---------------------------------------------------------------------------------------
// Body texture shader

static V3 gingham(const Palette& P, double a, double b, double period) {
  const double fa = a / period - std::floor(a / period), fb = b / period - std::floor(b / period);
  const int k = (fa < 0.5) + (fb < 0.5);
  const V3 white(0.93, 0.93, 0.90);
  return k == 0 ? white : (k == 1 ? mix(white, P.shirt, 0.5) : P.shirt);
}

namespace {

// Shade of each skinning group at a rest-surface point p with unit normal n; `left`: the
// subject's left (+X), `skin`: the skin colour with its noise.

V3 trousers_colour(const Palette& P, V3 p) { return (0.92 + 0.16 * value_noise(p, 0.015, P.noise_seed + 1)) * P.trousers; }

V3 eye_colour(const Anatomy& A, const Palette& P, V3 p, bool left) {
  const V3 q = unit(p - (left ? A.J[kLeftEye] : A.J[kRightEye]));
  return q.z > std::cos(0.20) ? V3(0.04, 0.04, 0.05) : (q.z > std::cos(0.45) ? P.iris : V3(0.95, 0.95, 0.92));
}

V3 hair_colour(const Anatomy& A, const Palette& P, V3 p) {
  const double phi = head_azimuth(A, p);
  const double streak = 0.5 + 0.5 * std::sin(55 * phi + 6 * std::sin(23 * p.y));
  return (0.72 + 0.4 * streak) * P.hair;
}

// Face features in units of the eye distance, relative to the eyes' midpoint.
V3 face_colour(const Anatomy& A, const Palette& P, V3 p, V3 skin) {
  const double d = A.d;
  V3 c = skin;
  const double xs = (p.x - A.eye_mid.x) / d, ys = (p.y - A.eye_mid.y) / d;
  const double ax = std::abs(xs);
  const double blush = 0.22 * std::exp(-((ax - 0.72) * (ax - 0.72) + (ys + 0.5) * (ys + 0.5)) / (2 * 0.18 * 0.18));
  c = mix(c, V3(0.90, 0.45, 0.45), blush);
  const double ex = ax - 0.5;
  const double ell = (ex / 0.27) * (ex / 0.27) + (ys / 0.125) * (ys / 0.125);
  if (ell <= 1) {
    const double r = std::hypot(ex, ys);
    c = r < 0.05 ? V3(0.04, 0.04, 0.05) : (r < 0.11 ? (r > 0.09 ? 0.6 * P.iris : P.iris) : V3(0.95, 0.95, 0.92));
  } else if (ell < 1.45 && ys > -0.03) {
    c = V3(0.08, 0.06, 0.06);  // lash line
  }
  if (ax > 0.15 && ax < 0.85) {
    const double u = (ax - 0.48) / 0.37;
    const double yb = 0.34 + 0.07 * (1 - u * u);
    if (std::abs(ys - yb) < 0.045 * (1.2 - 0.5 * smoothstep(0.3, 0.85, ax))) c = 0.8 * P.hair + V3(0.02, 0.02, 0.02);
  }
  const double nx = ax - 0.11;
  if ((nx / 0.055) * (nx / 0.055) + ((ys + 0.64) / 0.03) * ((ys + 0.64) / 0.03) < 1) c = 0.45 * skin;
  const double ly = ys + 1.0, lh = ly > 0 ? 0.10 : 0.13;
  if ((xs / 0.36) * (xs / 0.36) + (ly / lh) * (ly / lh) < 1) c = P.lips;
  if (std::abs(ly) < 0.018 && ax < 0.33) c = V3(0.30, 0.08, 0.08);
  return c;
}

V3 head_colour(const Anatomy& A, const Palette& P, V3 p, V3 n, bool neck, V3 skin) {
  if (hair_depth(A, p) > 0) return hair_colour(A, P, p);
  if (neck || p.z < A.eye_mid.z - 0.03 || n.z < 0.1) return skin;
  return face_colour(A, P, p, skin);
}

// Gingham shirt with a chest emblem (front, subject's left) and "HAHA" on the back:
// front/back and left/right become distinguishable while turning.
V3 shirt_colour(const Anatomy& A, const Palette& P, V3 p, V3 n) {
  const V3* J = A.J;
  const V3 ctr = J[6];
  const double arc = 0.16 * std::atan2(p.x - ctr.x, p.z - ctr.z);
  V3 c = gingham(P, arc, p.y, 0.032);
  const V3 em(J[9].x + 0.075, J[9].y + 0.02, 0);
  if (n.z > 0.45 && std::hypot(p.x - em.x, p.y - em.y) < 0.032)
    c = std::hypot(p.x - em.x, p.y - em.y) < 0.014 ? P.shirt : P.accent;
  if (n.z < -0.45) {
    const std::string text = "HAHA";
    const double px = 0.0105, cols = double(text.size()) * kFontAdvance - 1;
    const double x0 = J[6].x + 0.5 * cols * px, y0 = J[9].y + 0.03;
    const int col = int(std::floor((x0 - p.x) / px)), row = int(std::floor((y0 - p.y) / px));
    if (col >= 0 && col < int(cols) && row >= 0 && row < kFontHeight &&
        font_pixel(text[size_t(col / kFontAdvance)], col % kFontAdvance, row))
      c = P.accent;
  }
  return c;
}

V3 torso_colour(const Anatomy& A, const Palette& P, V3 p, V3 n, V3 skin) {
  // Crew neck: above a plane tilted down toward the front, near the neck axis (the
  // shoulder tops, further out, stay shirt).
  const V3 nk = A.J[kNeckJoint];
  const double front = smoothstep(-0.02, 0.05, p.z - nk.z);
  const double y_collar = nk.y - 0.025 - 0.04 * front;
  const double r_neck = std::hypot(p.x - nk.x, p.z - nk.z);
  if (p.y > y_collar && r_neck < 0.11) return skin;
  if (p.y > y_collar - 0.012 && r_neck < 0.12) return P.shirt;  // collar band
  if (p.y > A.waist_y) return shirt_colour(A, P, p, n);
  if (p.y > A.waist_y - 0.025) {
    const bool buckle = n.z > 0.6 && std::abs(p.x - A.J[0].x) < 0.022;
    return buckle ? V3(0.85, 0.70, 0.30) : V3(0.25, 0.15, 0.08);  // belt
  }
  return trousers_colour(P, p);
}

V3 leg_colour(const Anatomy& A, const Palette& P, V3 p, bool left) {
  const V3* J = A.J;
  const int hip = left ? 1 : 2, knee = left ? 4 : 5, ankle = left ? 7 : 8;
  if (p.y < J[ankle].y + 0.012) return P.shoe;
  V3 c = trousers_colour(P, p);
  // Stripe down the outer side: axis point at this height between hip, knee, ankle.
  const V3 a0 = p.y > J[knee].y ? J[hip] : J[knee], a1 = p.y > J[knee].y ? J[knee] : J[ankle];
  const double t = clamp((p.y - a0.y) / (a1.y - a0.y), 0.0, 1.0);
  const V3 ax = mix(a0, a1, t);
  const double ang = std::atan2(p.z - ax.z, (p.x - ax.x) * (left ? 1 : -1));
  if (std::abs(ang) < 0.16) c = std::abs(ang) < 0.05 ? P.accent : V3(0.92, 0.92, 0.92);
  return c;
}

V3 foot_colour(const Anatomy& A, const Palette& P, V3 p, V3 n, bool left) {
  const V3 ankle = A.J[left ? 7 : 8];
  if (p.y < A.floor_y + 0.018) return V3(0.35, 0.33, 0.32);  // sole
  if (std::abs(n.x) > 0.6 && p.y > A.floor_y + 0.028 && p.y < A.floor_y + 0.042) return P.accent;
  if (n.y > 0.5) {
    const double fz = p.z - ankle.z;
    if (fz > 0.03 && fz < 0.11 && std::abs(p.x - ankle.x) < 0.018) {
      const double f = fz / 0.012 - std::floor(fz / 0.012);
      if (f < 0.45) return V3(0.97, 0.97, 0.97);  // laces
    }
  }
  return P.shoe;
}

V3 arm_colour(const Anatomy& A, const Palette& P, V3 p, bool left, V3 skin) {
  const V3* J = A.J;
  const int sh = left ? 16 : 17, el = left ? 18 : 19;
  const V3 axis = unit(J[el] - J[sh]);
  const double len = norm(J[el] - J[sh]);
  const V3 q = p - J[sh];
  const double along = dot(q, axis);
  if (along < 0.45 * len) {
    if (along > 0.38 * len) return P.shirt;  // cuff
    const V3 up(0, 1, 0);
    const V3 e1 = unit(up - dot(up, axis) * axis), e2 = cross(axis, e1);
    return gingham(P, along, 0.045 * std::atan2(dot(q, e2), dot(q, e1)), 0.032);
  }
  return skin;
}

// Nails on the back (palm-down rest pose: +Y) of the four finger tips.
V3 hand_colour(const Anatomy& A, V3 p, V3 n, bool left, V3 skin) {
  const V3* J = A.J;
  V3 c = skin;
  const int base = left ? 25 : 40;
  for (int f = 0; f < 4; ++f) {
    const V3 j2 = J[base + 3 * f + 1], j3 = J[base + 3 * f + 2];
    const V3 dir = unit(j3 - j2);
    const double len = 0.85 * norm(j3 - j2);
    const V3 q = p - j3;
    const double along = dot(q, dir);
    if (along > 0.25 * len && along < 0.95 * len && norm(q - along * dir) < 0.016 && n.y > 0.55)
      c = mix(skin, V3(0.96, 0.86, 0.86), 0.7);
  }
  return c;
}

// Watch on the left wrist (forearm side of the wrist joint), over colour c.
V3 with_watch(const Anatomy& A, V3 p, V3 n, V3 c) {
  const V3 axis = unit(A.J[20] - A.J[18]);
  const V3 q = p - A.J[20];
  const double along = dot(q, axis);
  if (along > -0.035 && along < -0.012) {
    c = V3(0.12, 0.08, 0.06);
    const double r = std::hypot(along + 0.0235, q.z);
    if (n.y > 0.5 && r < 0.015) c = r < 0.012 ? V3(0.85, 0.88, 0.92) : V3(0.55, 0.55, 0.58);
  }
  return c;
}

}  // namespace

// Body colour at a rest-surface point: position p, unit normal n, skinning-group weights g.
V3 shade_body(const Anatomy& A, const Palette& P, V3 p, V3 n, const double* g) {
  int grp = 0;
  for (int k = 1; k < kGroups; ++k)
    if (g[k] > g[grp]) grp = k;
  const bool left = p.x > A.J[0].x;  // the subject's left is +X
  const double skin_var = 0.95 + 0.1 * value_noise(p, 0.03, P.noise_seed);
  const V3 skin = skin_var * P.skin;
  V3 c;
  switch (grp) {
    case gEye: c = eye_colour(A, P, p, left); break;
    case gHead:
    case gNeck: c = head_colour(A, P, p, n, grp == gNeck, skin); break;
    case gTorso: c = torso_colour(A, P, p, n, skin); break;
    case gLeg: c = leg_colour(A, P, p, left); break;
    case gFoot: c = foot_colour(A, P, p, n, left); break;
    case gArm: c = arm_colour(A, P, p, left, skin); break;
    case gHand:
    default: c = hand_colour(A, p, n, left, skin); break;
  }
  if (left && (grp == gArm || grp == gHand)) c = with_watch(A, p, n, c);
  // Baked ambient light (static: a texture can hold it).
  return (0.86 + 0.14 * n.y) * c;
}

// ---------------------------------------------------------------------------------------
// Garment texture: skirt chart in the upper part, ponytail chart in the lower part.

static V3 tartan_thread(const Palette& P, double c) {
  const double period = 0.09, f = c / period - std::floor(c / period);
  if (f < 0.28) return P.skirt_dark;
  if (f >= 0.55 && f < 0.59) return P.skirt_line;
  return P.skirt;
}

V3 shade_skirt(const Palette& P, double t, double phi, double ref_radius, double length) {
  V3 c = 0.5 * (tartan_thread(P, phi * ref_radius) + tartan_thread(P, t * length));
  if (t < 0.06) c = 0.6 * P.skirt_dark + V3(0.03, 0.03, 0.03);  // waistband
  if (t > 0.965) c = 0.75 * c;                                   // hem
  const double valley = t * (0.5 - 0.5 * std::cos(kSkirtPleats * phi));
  return (1 - 0.16 * valley) * c;
}

V3 shade_ponytail(const Palette& P, double s, double theta) {
  if (s > 0.05 && s < 0.11) return P.hair_tie;
  const double streak = 0.5 + 0.5 * std::sin(9 * theta + 3 * s);
  return (0.72 + 0.4 * streak) * (0.95 - 0.15 * s) * P.hair;
}

// ---------------------------------------------------------------------------------------
// Painting an atlas by rasterizing the UV triangles: each texel averages ss x ss samples
// of shade(face, barycentrics); texels outside every chart are filled from their
// neighbours (a gutter, so bilinear sampling at chart borders stays clean).

void paint_atlas(Image& tex, const float* vt, const int32_t* ft, const std::vector<int32_t>& faces_to_paint, int ss,
                 const std::function<V3(int, double, double, double)>& shade) {
  const int W = tex.width, H = tex.height, GW = W * ss, GH = H * ss;
  std::vector<int32_t> face_of(size_t(GW) * GH, -1);
  std::vector<float> bary(size_t(GW) * GH * 2, 0.f);
  for (int32_t f : faces_to_paint) {
    double X[3], Y[3];
    for (int i = 0; i < 3; ++i) {
      const int t = ft[3 * f + i];
      X[i] = double(vt[2 * t]) * GW - 0.5;
      Y[i] = (1.0 - double(vt[2 * t + 1])) * GH - 0.5;
    }
    const double area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
    if (!(std::abs(area) > 1e-12)) continue;
    const int x0 = std::max(0, int(std::ceil(std::min({X[0], X[1], X[2]}))));
    const int x1 = std::min(GW - 1, int(std::floor(std::max({X[0], X[1], X[2]}))));
    const int y0 = std::max(0, int(std::ceil(std::min({Y[0], Y[1], Y[2]}))));
    const int y1 = std::min(GH - 1, int(std::floor(std::max({Y[0], Y[1], Y[2]}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const size_t s = size_t(y) * GW + x;
        if (face_of[s] >= 0) continue;  // first face wins on shared edges
        const double b1 = ((x - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (y - Y[0])) / area;
        const double b2 = ((X[1] - X[0]) * (y - Y[0]) - (x - X[0]) * (Y[1] - Y[0])) / area;
        const double b0 = 1 - b1 - b2;
        const double eps = -1e-9;
        if (b0 < eps || b1 < eps || b2 < eps) continue;
        face_of[s] = f;
        bary[2 * s] = float(b1);
        bary[2 * s + 1] = float(b2);
      }
  }
  std::vector<uint8_t> valid(size_t(W) * H, 0);
  parallel_for_dynamic(H, [&](int64_t ty) {
    for (int tx = 0; tx < W; ++tx) {
      V3 acc(0, 0, 0);
      int n = 0;
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          const size_t s = size_t(ty * ss + sy) * GW + size_t(tx) * ss + sx;
          if (face_of[s] < 0) continue;
          const double b1 = bary[2 * s], b2 = bary[2 * s + 1];
          acc += shade(face_of[s], 1 - b1 - b2, b1, b2);
          ++n;
        }
      const size_t t = size_t(ty) * W + tx;
      if (n > 0) {
        for (int c = 0; c < 3; ++c) tex.data[3 * t + c] = float(clamp(acc[c] / n, 0.0, 1.0));
        valid[t] = 1;
      }
    }
  });
  // Gutter: a few passes of neighbour averaging outward from the charts.
  for (int pass = 0; pass < 6; ++pass) {
    std::vector<uint8_t> next = valid;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t t = size_t(y) * W + x;
        if (valid[t]) continue;
        float acc[3] = {0, 0, 0};
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= W || yy >= H || !valid[size_t(yy) * W + xx]) continue;
            for (int c = 0; c < 3; ++c) acc[c] += tex.data[3 * (size_t(yy) * W + xx) + c];
            ++n;
          }
        if (n > 0) {
          for (int c = 0; c < 3; ++c) tex.data[3 * t + c] = acc[c] / n;
          next[t] = 1;
        }
      }
    valid.swap(next);
  }
  for (size_t t = 0; t < valid.size(); ++t)
    if (!valid[t])
      for (int c = 0; c < 3; ++c) tex.data[3 * t + c] = 0.5f;
}

// ---------------------------------------------------------------------------------------
// Geometry

std::vector<V3> vertex_normals(const std::vector<float>& verts, const std::vector<int32_t>& faces) {
  const size_t V = verts.size() / 3;
  std::vector<V3> n(V, V3(0, 0, 0));
  auto at = [&](int i) { return V3(verts[3 * i], verts[3 * i + 1], verts[3 * i + 2]); };
  for (size_t f = 0; f + 2 < faces.size(); f += 3) {
    const int a = faces[f], b = faces[f + 1], c = faces[f + 2];
    const V3 fn = cross(at(b) - at(a), at(c) - at(a));
    n[a] += fn, n[b] += fn, n[c] += fn;
  }
  for (V3& v : n) v = unit(v);
  return n;
}

// Per-vertex skinning-group sums.
std::vector<std::array<double, kGroups>> vertex_groups(const BodyModel& body) {
  std::vector<std::array<double, kGroups>> g(size_t(body.num_verts));
  for (int v = 0; v < body.num_verts; ++v) {
    g[v].fill(0);
    for (int j = 0; j < kNumJoints; ++j) g[v][joint_group(j)] += body.weights[size_t(v) * kNumJoints + j];
  }
  return g;
}

void add_weight(SynthMesh& m, int joint, double w) {
  if (w <= 1e-6) return;
  m.w_joint.push_back(joint);
  m.w_value.push_back(float(w));
}
void add_grid_faces(SynthMesh& m, int R, int C) {
  auto vid = [&](int i, int k) { return i * (C + 1) + k; };
  for (int i = 0; i + 1 < R; ++i)
    for (int k = 0; k < C; ++k) {
      const int a = vid(i, k), b = vid(i + 1, k), c = vid(i, k + 1), d = vid(i + 1, k + 1);
      m.faces.insert(m.faces.end(), {a, b, c, c, b, d});
    }
}

void end_vertex(SynthMesh& m) {
  // Normalise this vertex's weights (the entries since the previous w_start).
  const int b = m.w_start.back(), e = int(m.w_joint.size());
  double s = 0;
  for (int i = b; i < e; ++i) s += m.w_value[i];
  for (int i = b; i < e; ++i) m.w_value[i] = float(m.w_value[i] / s);
  m.w_start.push_back(e);
}

// Ray (o, d) crosses triangle (a, b, c) at t > 0 (Moller-Trumbore).
static bool ray_crosses(V3 o, V3 d, V3 a, V3 b, V3 c) {
  const V3 e1 = b - a, e2 = c - a, p = cross(d, e2);
  const double det = dot(e1, p);
  if (std::abs(det) < 1e-18) return false;
  const V3 s = o - a;
  const double u = dot(s, p) / det;
  if (u < 0 || u > 1) return false;
  const V3 q = cross(s, e1);
  const double v = dot(d, q) / det;
  if (v < 0 || u + v > 1) return false;
  return dot(e2, q) / det > 0;
}

// Marks the candidate vertices that lie inside another connected component of the mesh
// (the procedural body is a union of overlapping closed parts: e.g. the top of the
// torso is tucked inside the head). Parity of ray crossings, per component.
std::vector<uint8_t> inside_other_part(const std::vector<float>& verts, const std::vector<int32_t>& faces,
                                       const std::vector<int>& candidates) {
  const int V = int(verts.size() / 3), F = int(faces.size() / 3);
  std::vector<int> parent(V);
  for (int i = 0; i < V; ++i) parent[i] = i;
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int f = 0; f < F; ++f)
    for (int k = 1; k < 3; ++k) parent[find(faces[3 * f + k])] = find(faces[3 * f]);
  auto P = [&](int i) { return V3(verts[3 * i], verts[3 * i + 1], verts[3 * i + 2]); };
  struct Comp {
    std::vector<int> faces;
    V3 lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
  };
  std::vector<int> comp_of(V, -1);
  std::vector<Comp> comps;
  for (int f = 0; f < F; ++f) {
    const int r = find(faces[3 * f]);
    if (comp_of[r] < 0) comp_of[r] = int(comps.size()), comps.emplace_back();
    Comp& c = comps[comp_of[r]];
    c.faces.push_back(f);
    for (int k = 0; k < 3; ++k) {
      const V3 p = P(faces[3 * f + k]);
      for (int a = 0; a < 3; ++a) c.lo[a] = std::min(c.lo[a], p[a]), c.hi[a] = std::max(c.hi[a], p[a]);
    }
  }
  const V3 dir = unit(V3(0.8112, 0.3309, 0.4821));  // generic: avoids edge-on hits
  std::vector<uint8_t> inside(candidates.size(), 0);
  parallel_for_dynamic(int64_t(candidates.size()), [&](int64_t i) {
    const int v = candidates[size_t(i)];
    const V3 p = P(v);
    const int own = comp_of[find(v)];
    for (size_t c = 0; c < comps.size() && !inside[size_t(i)]; ++c) {
      const Comp& C = comps[c];
      if (int(c) == own || p.x < C.lo.x || p.y < C.lo.y || p.z < C.lo.z || p.x > C.hi.x || p.y > C.hi.y || p.z > C.hi.z)
        continue;
      int n = 0;
      for (int f : C.faces) n += ray_crosses(p, dir, P(faces[3 * f]), P(faces[3 * f + 1]), P(faces[3 * f + 2]));
      inside[size_t(i)] = n % 2;
    }
  });
  return inside;
}

// A shell over part of the body: the vertices with offset(v, p) > 1e-4 m (and not hidden
// inside another body part), pushed out along the rest normal by that offset; the faces
// whose three corners are all kept. Body UVs and texture, the body's skinning weights.
// `source` (optional) receives the body vertex of every shell vertex.
SynthMesh make_shell(const BodyModel& body, const std::vector<float>& rest, const std::vector<V3>& normals,
                     const std::function<double(int, V3)>& offset, std::vector<int>* source) {
  const int V = body.num_verts;
  std::vector<int32_t> remap(V, -1);
  SynthMesh m;
  m.texture = 0;
  m.w_start.push_back(0);
  std::vector<int> cand;
  std::vector<double> off;
  for (int v = 0; v < V; ++v) {
    const V3 p(rest[3 * v], rest[3 * v + 1], rest[3 * v + 2]);
    const double o = offset(v, p);
    if (o > 1e-4) cand.push_back(v), off.push_back(o);
  }
  const std::vector<uint8_t> hidden = inside_other_part(rest, body.faces, cand);
  for (size_t i = 0; i < cand.size(); ++i) {
    if (hidden[i]) continue;
    const int v = cand[i];
    const V3 p(rest[3 * v], rest[3 * v + 1], rest[3 * v + 2]);
    remap[v] = m.num_verts();
    if (source) source->push_back(v);
    const V3 q = p + off[i] * normals[v];
    m.rest.insert(m.rest.end(), {float(q.x), float(q.y), float(q.z)});
    for (int j = 0; j < kNumJoints; ++j) add_weight(m, j, body.weights[size_t(v) * kNumJoints + j]);
    end_vertex(m);
  }
  m.vt = body.vt;
  for (int f = 0; f < body.num_faces; ++f) {
    const int a = remap[body.faces[3 * f]], b = remap[body.faces[3 * f + 1]], c = remap[body.faces[3 * f + 2]];
    if (a < 0 || b < 0 || c < 0) continue;
    m.faces.insert(m.faces.end(), {a, b, c});
    m.ft.insert(m.ft.end(), {body.ft[3 * f], body.ft[3 * f + 1], body.ft[3 * f + 2]});
  }
  return m;
}

// Hair shell: scalp vertices inside the hairline, offset by hair_thickness.
SynthMesh make_hair(const BodyModel& body, const Anatomy& A, const std::vector<float>& rest,
                    const std::vector<V3>& normals, const std::vector<std::array<double, kGroups>>& groups) {
  SynthMesh m = make_shell(body, rest, normals, [&](int v, V3 p) {
    if (!(groups[v][gHead] >= 0.5 && norm(p - A.J[kHeadJoint]) < 0.3)) return 0.0;
    return hair_thickness(A, p);
  });
  m.name = "hair";
  m.part = kSynthHair;
  m.gloss = kHairGloss;
  return m;
}

// A closed tube along centreline(s), s in [0, 1], radius(s); rings x columns plus two
// poles; UV chart u in [0, 1] around, v from v_top (s = 0) to v_bot (s = 1).
template <class Centre, class Radius>
static void tube(SynthMesh& m, int rings, int cols, Centre&& centre, Radius&& radius, double v_top, double v_bot) {
  const int v0 = m.num_verts(), t0 = int(m.vt.size() / 2);
  auto push = [&](V3 p) { m.rest.insert(m.rest.end(), {float(p.x), float(p.y), float(p.z)}); };
  // Poles, then rings (seam column duplicated: cols + 1 per ring).
  push(centre(0.0));
  push(centre(1.0));
  for (int i = 0; i < rings; ++i) {
    const double s = (i + 0.5) / rings;
    const double h = 1e-4;
    const V3 T = unit(centre(std::min(1.0, s + h)) - centre(std::max(0.0, s - h)));
    const V3 X(1, 0, 0);
    V3 N = unit(X - dot(X, T) * T);
    if (norm(N) < 0.5) N = unit(V3(0, 1, 0) - dot(V3(0, 1, 0), T) * T);
    const V3 B = cross(T, N);
    const double r = radius(s);
    for (int k = 0; k <= cols; ++k) {
      const double th = 2 * kPi * k / cols;
      push(centre(s) + r * (std::cos(th) * N + std::sin(th) * B));
    }
  }
  auto vid = [&](int i, int k) { return v0 + 2 + i * (cols + 1) + k; };
  // UVs: one per vertex (poles get u = 0.5).
  m.vt.insert(m.vt.end(), {0.5f, float(v_top), 0.5f, float(v_bot)});
  for (int i = 0; i < rings; ++i)
    for (int k = 0; k <= cols; ++k) {
      const double s = (i + 0.5) / rings;
      m.vt.insert(m.vt.end(), {float(double(k) / cols), float(v_top + (v_bot - v_top) * s)});
    }
  auto tri = [&](int a, int b, int c) {
    m.faces.insert(m.faces.end(), {a, b, c});
    m.ft.insert(m.ft.end(), {a - v0 + t0, b - v0 + t0, c - v0 + t0});
  };
  // Winding: (T, N, B) is right-handed and k grows from N toward B, so (k, k+1, next ring)
  // turns counter-clockwise seen from outside? Checked below and flipped if not.
  const size_t f_begin = m.faces.size();
  for (int k = 0; k < cols; ++k) tri(v0, vid(0, k + 1), vid(0, k));
  for (int i = 0; i + 1 < rings; ++i)
    for (int k = 0; k < cols; ++k) {
      tri(vid(i, k), vid(i, k + 1), vid(i + 1, k + 1));
      tri(vid(i, k), vid(i + 1, k + 1), vid(i + 1, k));
    }
  for (int k = 0; k < cols; ++k) tri(vid(rings - 1, k), vid(rings - 1, k + 1), v0 + 1);
  // Orientation check on a mid-ring face: its normal must point away from the centreline.
  {
    const int i = rings / 2;
    const size_t f = f_begin + 3 * (cols + 2 * (i * cols));
    auto P = [&](int idx) { return V3(m.rest[3 * idx], m.rest[3 * idx + 1], m.rest[3 * idx + 2]); };
    const V3 a = P(m.faces[f]), b = P(m.faces[f + 1]), c = P(m.faces[f + 2]);
    const V3 out = (a + b + c) / 3.0 - centre((i + 0.5) / rings);
    if (dot(cross(b - a, c - a), out) < 0)
      for (size_t g = f_begin; g < m.faces.size(); g += 3) {
        std::swap(m.faces[g + 1], m.faces[g + 2]);
        std::swap(m.ft[g + 1], m.ft[g + 2]);
      }
  }
}

static SynthMesh make_ponytail(const Anatomy& A, const std::vector<float>& rest,
                               const std::vector<std::array<double, kGroups>>& groups) {
  // Anchor: back of the skull, half an eye distance above the eyes, inside the hair.
  const V3 head = A.J[kHeadJoint];
  const double ya = A.eye_mid.y + 0.55 * A.d;
  double zmin = head.z - 0.08;
  bool found = false;
  for (size_t v = 0; v < groups.size(); ++v) {
    if (groups[v][gHead] < 0.5) continue;
    const V3 p(rest[3 * v], rest[3 * v + 1], rest[3 * v + 2]);
    if (std::abs(p.x - head.x) < 0.02 && std::abs(p.y - ya) < 0.015 && p.z < head.z) {
      zmin = found ? std::min(zmin, p.z) : p.z;
      found = true;
    }
  }
  const V3 anchor(head.x, ya, zmin - 0.012);
  SynthMesh m;
  m.name = "ponytail";
  m.part = kSynthPonytail;
  m.gloss = kHairGloss;
  m.texture = 1;
  auto centre = [&](double s) { return anchor + V3(0, 0.02 * s - 0.19 * s * s, -0.08 * (1 - (1 - s) * (1 - s))); };
  auto radius = [&](double s) {
    double r = 0.021 * (1 - 0.45 * s);
    if (s > 0.05 && s < 0.11) r *= 0.82;  // hair tie
    if (s > 0.8) r *= std::sqrt(std::max(0.0, 1 - std::pow((s - 0.8) / 0.2, 2)));
    if (s < 0.04) r *= std::sqrt(std::max(0.0, 1 - std::pow((0.04 - s) / 0.04, 2)));
    return std::max(r, 0.0015);
  };
  tube(m, 28, 16, centre, radius, kPonytailV0, kPonytailV1);
  m.w_start.push_back(0);
  for (int v = 0; v < m.num_verts(); ++v) {
    add_weight(m, kHeadJoint, 1.0);
    end_vertex(m);
  }
  return m;
}

// Farthest crossing, per (plane, direction), of the ray from the vertical axis through
// (axis_x, axis_z) with the horizontal cross-section of triangles `tris` of (verts, faces)
// at plane_y[i]; direction k is the azimuth phis[k] (0 = +Z, pi/2 = +X). 0 where the ray
// meets nothing. Result (planes x directions), row-major.
std::vector<double> radial_extent(const std::vector<float>& rest, const std::vector<int32_t>& faces,
                                  const std::vector<int>& tris, double axis_x, double axis_z,
                                  const std::vector<double>& plane_y, const std::vector<double>& phis) {
  const int C = int(phis.size());
  std::vector<double> ext(plane_y.size() * phis.size(), 0.0);
  parallel_for(int64_t(plane_y.size()), [&](int64_t i) {
    const double y = plane_y[size_t(i)];
    double* row = &ext[size_t(i) * C];
    for (int f : tris) {
      // Segment where the triangle crosses the plane (x, z relative to the axis).
      double seg[2][2];
      int n = 0;
      for (int k = 0; k < 3 && n < 2; ++k) {
        const int ia = faces[3 * f + k], ib = faces[3 * f + (k + 1) % 3];
        const double ya = rest[3 * ia + 1], yb = rest[3 * ib + 1];
        if ((ya - y) * (yb - y) > 0 || ya == yb) continue;
        const double t = (y - ya) / (yb - ya);
        seg[n][0] = rest[3 * ia] + t * (rest[3 * ib] - rest[3 * ia]) - axis_x;
        seg[n][1] = rest[3 * ia + 2] + t * (rest[3 * ib + 2] - rest[3 * ia + 2]) - axis_z;
        ++n;
      }
      if (n < 2) continue;
      const double ex = seg[1][0] - seg[0][0], ez = seg[1][1] - seg[0][1];
      for (int k = 0; k < C; ++k) {
        const double dx = std::sin(phis[size_t(k)]), dz = std::cos(phis[size_t(k)]);
        const double den = dx * ez - dz * ex;  // cross(d, e)
        if (std::abs(den) < 1e-15) continue;
        const double t = (seg[0][0] * ez - seg[0][1] * ex) / den;   // cross(a, e) / cross(d, e)
        const double sp = (seg[0][0] * dz - seg[0][1] * dx) / den;  // cross(a, d) / cross(d, e)
        if (t > 0 && sp >= 0 && sp <= 1) row[k] = std::max(row[k], t);
      }
    }
  });
  return ext;
}

// A flared skirt around the pelvis axis from spec.y_top down to spec.y_hem, outside the
// body everywhere (per-azimuth body extent + clearance), skinned to pelvis and hips.
SynthMesh make_skirt(const SkirtSpec& spec, const Anatomy& A, const std::vector<float>& rest,
                     const std::vector<int32_t>& faces, const std::vector<std::array<double, kGroups>>& groups,
                     SkirtFrame* frame) {
  const V3 pel = A.J[0];
  const double y_top = spec.y_top, y_hem = spec.y_hem;
  const int R = spec.rings, C = spec.columns;
  auto ring_y = [&](int i) { return y_top + (y_hem - y_top) * double(i) / (R - 1); };
  auto col_phi = [&](int k) { return kPi + 2 * kPi * k / C; };  // seam at the back

  // Body extent per (ring, azimuth bin): the farthest crossing of the bin's ray from the
  // axis with the body's horizontal cross-sections (torso and legs; arms, hands and head
  // excluded), taken over 5 planes spanning the ring's band so that the skirt surface
  // between rings clears the body too.
  const double band = std::abs(y_hem - y_top) / (R - 1);
  std::vector<int> tris;
  for (size_t f = 0; f + 2 < faces.size(); f += 3) {
    bool skip = false;
    double ylo = 1e30, yhi = -1e30;
    for (int k = 0; k < 3; ++k) {
      const auto& g = groups[faces[f + k]];
      skip |= g[gArm] + g[gHand] + g[gHead] + g[gNeck] + g[gEye] > 0.5;
      ylo = std::min(ylo, double(rest[3 * faces[f + k] + 1])), yhi = std::max(yhi, double(rest[3 * faces[f + k] + 1]));
    }
    if (!skip && yhi >= y_hem - band && ylo <= y_top + band) tris.push_back(int(f / 3));
  }
  // Bin k covers the azimuths around col_phi(k) + half a column.
  std::vector<double> planes, phis;
  for (int i = 0; i < R; ++i)
    for (int q = -2; q <= 2; ++q) planes.push_back(ring_y(i) + 0.25 * q * band);
  for (int k = 0; k < C; ++k) phis.push_back(col_phi(k) + kPi / C);
  const std::vector<double> cut = radial_extent(rest, faces, tris, pel.x, pel.z, planes, phis);
  std::vector<double> ext(size_t(R) * C, 0.0);
  for (int i = 0; i < R; ++i)
    for (int q = 0; q < 5; ++q)
      for (int k = 0; k < C; ++k) ext[size_t(i) * C + k] = std::max(ext[size_t(i) * C + k], cut[(size_t(i) * 5 + q) * C + k]);
  // Angular dilation (+-2 bins), then the required radius (body + clearance).
  std::vector<double> req(size_t(R) * C);
  for (int i = 0; i < R; ++i)
    for (int k = 0; k < C; ++k) {
      double m = 0;
      for (int dk = -2; dk <= 2; ++dk) m = std::max(m, ext[size_t(i) * C + (k + dk + C) % C]);
      req[size_t(i) * C + k] = m + spec.clearance;
    }
  // Monotone flare down the skirt, circular smoothing, clearance re-imposed, pleats out.
  std::vector<double> rad(size_t(R) * C);
  for (int k = 0; k < C; ++k) {
    double run = 0;
    for (int i = 0; i < R; ++i) {
      const double t = double(i) / (R - 1);
      run = std::max(run, req[size_t(i) * C + k]);
      rad[size_t(i) * C + k] = run + spec.flare * std::pow(t, 1.5);
    }
  }
  for (int i = 0; i < R; ++i) {
    std::vector<double> sm(C);
    for (int k = 0; k < C; ++k) {
      double s = 0;
      for (int dk = -3; dk <= 3; ++dk) s += rad[size_t(i) * C + (k + dk + C) % C];
      sm[k] = s / 7;
    }
    for (int k = 0; k < C; ++k) {
      const double t = double(i) / (R - 1);
      const double pleat = spec.pleat_depth * t * (0.5 + 0.5 * std::cos(spec.pleats * col_phi(k)));
      rad[size_t(i) * C + k] = std::max(sm[k], req[size_t(i) * C + k]) + pleat;
    }
  }
  double ref = 0;
  for (int k = 0; k < C; ++k) ref += rad[k] / C;
  frame->ref_radius = ref + 0.04;
  frame->length = y_top - y_hem;

  SynthMesh m;
  m.name = spec.name;
  m.part = spec.part;
  m.gloss = spec.gloss;
  m.garment = true;  // one surface around both legs: what a leg-bound avatar cannot carry
  m.texture = 1;
  m.w_start.push_back(0);
  for (int i = 0; i < R; ++i) {
    const double t = double(i) / (R - 1);
    const double legs = spec.legs * smoothstep(0.0, spec.legs_full_at, t);
    for (int k = 0; k <= C; ++k) {
      const double phi = col_phi(k), r = rad[size_t(i) * C + (k % C)];
      const V3 p(pel.x + r * std::sin(phi), ring_y(i), pel.z + r * std::cos(phi));
      m.rest.insert(m.rest.end(), {float(p.x), float(p.y), float(p.z)});
      m.vt.insert(m.vt.end(), {float(double(k) / C), float(kSkirtV0 + (kSkirtV1 - kSkirtV0) * t)});
      const double sl = smoothstep(-spec.leg_blend, spec.leg_blend, p.x - pel.x);  // left thigh share
      add_weight(m, 0, 1 - legs);
      add_weight(m, 1, legs * sl);
      add_weight(m, 2, legs * (1 - sl));
      end_vertex(m);
    }
  }
  // Rings go down and phi grows: (i,k) -> (i+1,k) -> (i,k+1) has normal
  // (-Y) x d/dphi (sin phi, 0, cos phi) = (sin phi, 0, cos phi), i.e. outward.
  add_grid_faces(m, R, C);
  m.ft = m.faces;
  return m;
}

void shape_rest(const BodyModel& body, SynthSubject& s) {
  Lbs<float> lbs(body);
  SmplxParams rest_pose;
  rest_pose.betas = s.betas;
  s.rest_verts.resize(size_t(body.num_verts) * 3);
  s.rest_joints.resize(size_t(kNumJoints) * 3);
  lbs.forward(rest_pose, s.rest_verts.data(), s.rest_joints.data(), nullptr);
}

void paint_body_texture(const BodyModel& body, SynthSubject& s, const std::vector<V3>& normals,
                        const std::vector<std::array<double, kGroups>>& groups, int S,
                        const std::function<V3(V3, V3, const double*)>& shade) {
  // Every face, shaded from its interpolated rest point.
  const int ss = S <= 1024 ? 2 : 1;
  s.body_texture = Image(S, S, 3);
  std::vector<int32_t> all(size_t(body.num_faces));
  for (int f = 0; f < body.num_faces; ++f) all[f] = f;
  paint_atlas(s.body_texture, body.vt.data(), body.ft.data(), all, ss, [&](int f, double b0, double b1, double b2) {
    const int i0 = body.faces[3 * f], i1 = body.faces[3 * f + 1], i2 = body.faces[3 * f + 2];
    auto P3 = [&](int i) { return V3(s.rest_verts[3 * i], s.rest_verts[3 * i + 1], s.rest_verts[3 * i + 2]); };
    const V3 p = b0 * P3(i0) + b1 * P3(i1) + b2 * P3(i2);
    const V3 n = unit(b0 * normals[i0] + b1 * normals[i1] + b2 * normals[i2]);
    double g[kGroups];
    for (int k = 0; k < kGroups; ++k) g[k] = b0 * groups[i0][k] + b1 * groups[i1][k] + b2 * groups[i2][k];
    return shade(p, n, g);
  });
}

void paint_garment_texture(Image& tex, int S, const std::function<V3(double, double)>& upper,
                           const std::function<V3(double, double)>& lower) {
  auto shade = [&](double u, double v) {
    if (v > 0.5 * (kSkirtV1 + kPonytailV0)) return upper(clamp((v - kSkirtV0) / (kSkirtV1 - kSkirtV0), 0.0, 1.0), u);
    return lower(clamp((v - kPonytailV0) / (kPonytailV1 - kPonytailV0), 0.0, 1.0), u);
  };
  // Charts are analytic rectangles, so every texel is shaded directly (2 x 2 samples).
  const int GW = S, GH = std::max(8, S / 2);
  tex = Image(GW, GH, 3);
  parallel_for(GH, [&](int64_t y) {
    for (int x = 0; x < GW; ++x) {
      V3 acc(0, 0, 0);
      for (int sy = 0; sy < 2; ++sy)
        for (int sx = 0; sx < 2; ++sx) {
          const double u = (x + 0.25 + 0.5 * sx) / GW, v = 1 - (double(y) + 0.25 + 0.5 * sy) / GH;
          acc += shade(u, v);
        }
      for (int c = 0; c < 3; ++c) tex.data[3 * (size_t(y) * GW + x) + c] = float(clamp(acc[c] / 4, 0.0, 1.0));
    }
  });
}

}  // namespace synth

using namespace synth;

SynthSubject make_synth_subject(const BodyModel& body, const SynthSubjectOptions& opt) {
  const std::string where = body.source.empty() ? std::string("body model") : body.source;
  if (opt.subject != 1 && opt.subject != 2)
    fail("--subject", std::to_string(opt.subject) + " is not a subject (expected 1 or 2)");
  if (body.vt.empty() || body.ft.size() != body.faces.size())
    fail(where, "vt/ft: the synthetic subject needs a body model with a UV map");
  if (opt.texture_size < 16 || opt.texture_size > 8192)
    fail("texture size", std::to_string(opt.texture_size) + " is outside [16, 8192]");
  for (int32_t t : body.ft)
    if (t < 0 || t >= body.num_uv()) fail(where, "ft: UV index " + std::to_string(t) + " out of range");
  if (opt.subject == 2) return make_coat_subject(body, opt);

  SynthSubject s;
  s.betas.assign(size_t(std::min(10, body.num_shape)), 0.0f);
  shape_rest(body, s);
  const Anatomy A = make_anatomy(s.rest_joints, s.rest_verts);
  const Palette P = make_palette(opt.seed);
  const std::vector<V3> normals = vertex_normals(s.rest_verts, body.faces);
  const auto groups = vertex_groups(body);

  if (opt.hair) s.meshes.push_back(make_hair(body, A, s.rest_verts, normals, groups));
  if (opt.ponytail) s.meshes.push_back(make_ponytail(A, s.rest_verts, groups));
  SkirtFrame sf{0.25, 0.4};
  if (opt.skirt) {
    SkirtSpec spec;
    spec.y_top = A.waist_y;
    const double hip_y = 0.5 * (A.J[1].y + A.J[2].y), knee_y = 0.5 * (A.J[4].y + A.J[5].y);
    spec.y_hem = hip_y + 0.72 * (knee_y - hip_y);
    s.meshes.push_back(make_skirt(spec, A, s.rest_verts, body.faces, groups, &sf));
  }

  paint_body_texture(body, s, normals, groups, opt.texture_size,
                     [&](V3 p, V3 n, const double* g) { return shade_body(A, P, p, n, g); });
  // Garment atlas: skirt chart in the upper part, ponytail chart in the lower part.
  paint_garment_texture(
      s.garment_texture, opt.texture_size,
      [&](double t, double u) { return shade_skirt(P, t, kPi + 2 * kPi * u, sf.ref_radius, sf.length); },
      [&](double sp, double u) { return shade_ponytail(P, sp, 2 * kPi * u); });
  return s;
}

}  // namespace haha
