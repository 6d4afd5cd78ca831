// Subject 2 of `haha synth` (--subject 2): the harder benchmark subject. Another body
// shape, long loose hair over a hair shell, a loose coat (jacket shell with flaring
// sleeves + long tails to below the knees), its own palette and fabric patterns. Built
// from subject 1's blocks (synth_internal.h): shells, flared skirt, atlas painters.
#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.h"
#include "synth/synth_internal.h"
#include "synth/synth_subject.h"

namespace haha {
namespace synth {
namespace {

// Betas on the procedural body's shape columns (0 height, 1 girth, 3 shoulders,
// 6 belly, 7 hips, 8 chest): ~10 cm taller, heavier, wider hips and shoulders. On a
// real SMPL-X file the same values are simply another plausible shape.
constexpr float kBetas[10] = {1.4f, 1.3f, 0.0f, 0.7f, 0.0f, 0.0f, 0.9f, 1.1f, 0.5f, 0.0f};

struct CoatPalette {
  Palette base;  // skin, shirt, trousers, shoes, face, hair colour (shade_body)
  V3 coat, coat_dark, coat_line, button;
};

CoatPalette make_coat_palette(uint64_t seed) {
  CoatPalette c;
  c.base = make_palette(seed + 0x5EC0D5ull);
  std::mt19937_64 rng(seed * 0x8CB92BA72F3D8DD7ull + 0xC0A7ull);
  auto pick = [&](int n) { return int(rng() % uint64_t(n)); };
  // Kept apart from subject 1's lists so the two subjects never look alike.
  static const V3 skins[] = {{0.45, 0.30, 0.21}, {0.68, 0.48, 0.36}, {0.82, 0.62, 0.50}};
  static const V3 hairs[] = {{0.05, 0.04, 0.04}, {0.40, 0.13, 0.06}, {0.70, 0.55, 0.30}, {0.30, 0.20, 0.12}};
  struct Coat {
    V3 base, dark, line, button;
  };
  static const Coat coats[] = {{{0.70, 0.52, 0.32}, {0.45, 0.31, 0.17}, {0.90, 0.82, 0.66}, {0.20, 0.12, 0.08}},
                               {{0.24, 0.25, 0.28}, {0.12, 0.12, 0.14}, {0.62, 0.62, 0.66}, {0.75, 0.66, 0.40}},
                               {{0.48, 0.10, 0.14}, {0.26, 0.05, 0.08}, {0.85, 0.62, 0.55}, {0.80, 0.70, 0.45}},
                               {{0.18, 0.32, 0.22}, {0.08, 0.16, 0.10}, {0.78, 0.72, 0.45}, {0.55, 0.40, 0.22}}};
  c.base.skin = skins[pick(3)];
  c.base.lips = mix(c.base.skin, V3(0.62, 0.18, 0.22), 0.6);
  c.base.hair = hairs[pick(4)];
  const Coat& k = coats[pick(4)];
  c.coat = k.base, c.coat_dark = k.dark, c.coat_line = k.line, c.button = k.button;
  return c;
}

// Wool twill: low-contrast diagonal ribs (1.6 cm) and a windowpane check of thin light
// lines every 7 cm; (a, b) = (arc length around, height) in metres.
V3 coat_fabric(const CoatPalette& C, double a, double b) {
  const double rib = 0.5 + 0.5 * std::sin(2 * kPi * (a + b) / 0.016);
  V3 c = (0.94 + 0.12 * rib) * C.coat;
  const double fa = a / 0.07 - std::floor(a / 0.07), fb = b / 0.07 - std::floor(b / 0.07);
  if (fa < 0.07 || fb < 0.07) c = mix(c, C.coat_line, 0.55);
  return c;
}

// Button of radius 1.1 cm at distance r from its centre (0 outside), with a darker rim.
bool button(const CoatPalette& C, double r, V3* c) {
  if (r >= 0.011) return false;
  *c = r > 0.008 ? 0.6 * C.button : C.button;
  return true;
}

// Jacket region of the torso: from 7.5 cm below the waist up to the neck.
bool in_jacket(const Anatomy& A, V3 p) { return p.y > A.waist_y - 0.075; }

// Sleeve coordinate: distance along the upper arm from the shoulder joint, and its length.
double along_arm(const Anatomy& A, V3 p, bool left, double* len) {
  const int sh = left ? 16 : 17, el = left ? 18 : 19;
  *len = norm(A.J[el] - A.J[sh]);
  return dot(p - A.J[sh], unit(A.J[el] - A.J[sh]));
}
constexpr double kSleeveEnd = 0.92;  // sleeves end at this fraction of the upper arm

// Body atlas of subject 2: where the jacket shell lies (it shares the body's UVs) the coat
// is painted: fabric, a V neckline showing the shirt, lapel edges, buttons, pocket flaps,
// a back seam, sleeves with cuffs. Elsewhere subject 1's painter with this palette.
V3 shade_coat_body(const Anatomy& A, const CoatPalette& C, V3 p, V3 n, const double* g) {
  int grp = 0;
  for (int k = 1; k < kGroups; ++k)
    if (g[k] > g[grp]) grp = k;
  const V3* J = A.J;
  const bool left = p.x > J[0].x;
  V3 c;
  if (grp == gTorso && in_jacket(A, p)) {
    const double x = p.x - J[0].x, yv = J[9].y - 0.03;  // bottom of the V neckline
    c = coat_fabric(C, 0.16 * std::atan2(p.x - J[6].x, p.z - J[6].z), p.y);
    const double v_edge = 0.55 * (p.y - yv) - std::abs(x);  // > 0 inside the V
    if (n.z > 0.2 && p.y > yv && v_edge > 0) {
      c = v_edge < 0.012 ? C.coat_dark : C.base.shirt;  // lapel edge, then the shirt
    } else if (n.z > 0.3) {
      if (std::abs(x) < 0.003 && p.y < yv) c = C.coat_dark;  // front opening
      for (int k = 0; k < 3; ++k) button(C, std::hypot(x - 0.012, p.y - (yv - 0.03 - 0.085 * k)), &c);
      if (std::abs(std::abs(x) - 0.10) < 0.045 && std::abs(p.y - (A.waist_y - 0.01)) < 0.005) c = C.coat_dark;
    } else if (n.z < -0.3 && std::abs(x) < 0.003) {
      c = C.coat_dark;  // back seam
    }
    if (p.y < A.waist_y - 0.065) c = 0.8 * c;  // hem band
  } else if (grp == gArm) {
    double len = 0;
    const double along = along_arm(A, p, left, &len);
    if (along > kSleeveEnd * len) return shade_body(A, C.base, p, n, g);
    const int sh = left ? 16 : 17, el = left ? 18 : 19;
    const V3 axis = unit(J[el] - J[sh]), q = p - J[sh], up(0, 1, 0);
    const V3 e1 = unit(up - dot(up, axis) * axis), e2 = cross(axis, e1);
    c = coat_fabric(C, 0.05 * std::atan2(dot(q, e2), dot(q, e1)), along);
    if (along > (kSleeveEnd - 0.12) * len) c = C.coat_dark;  // cuff
  } else {
    return shade_body(A, C.base, p, n, g);
  }
  return (0.86 + 0.14 * n.y) * c;  // the same baked ambient as shade_body
}

// Coat tails chart: t from the waist (0) to the hem (1), phi around (pi: back seam).
V3 shade_coat_tails(const CoatPalette& C, double t, double phi, double ref_radius, double length) {
  V3 c = coat_fabric(C, phi * ref_radius, t * length);
  const double front = std::abs(phi - 2 * kPi) * ref_radius;  // arc distance from the front line
  if (front < 0.003) c = C.coat_dark;
  for (double tb : {0.08, 0.24}) button(C, std::hypot(front - 0.012, (t - tb) * length), &c);
  if (t < 0.03 || t > 0.955) c = 0.8 * c;  // waist seam, hem band
  const double fold = t * (0.5 - 0.5 * std::cos(10 * phi));
  return (1 - 0.12 * fold) * c;
}

// Long hair chart: s from the top (0) to the tips (1), u across (0..1).
V3 shade_long_hair(const CoatPalette& C, double s, double u) {
  const double streak = 0.5 + 0.5 * std::sin(2 * kPi * 34 * u + 4 * std::sin(9 * u + 3 * s));
  V3 c = (0.72 + 0.4 * streak) * (1 - 0.12 * s) * C.base.hair;
  return mix(c, 1.5 * C.base.hair + V3(0.05, 0.04, 0.03), 0.5 * smoothstep(0.7, 1.0, s));  // lighter tips
}

constexpr double kHairHalfWidth = 0.34 * kPi;  // azimuths covered either side of the back

// Long loose hair: a sheet around the neck axis over the back of the head, from above the
// ears down to the shoulder blades (tips longer in the middle), everywhere outside the
// obstacles (tris of verts/faces: body, hair shell, jacket) by 1.2 cm except the top rows,
// which tuck just inside the hair shell. It falls straight or outward, never inward.
SynthMesh make_long_hair(const Anatomy& A, const std::vector<float>& verts, const std::vector<int32_t>& faces,
                         const std::vector<int>& tris) {
  const double ax = A.J[kNeckJoint].x, az = A.J[kNeckJoint].z;
  const double y_top = A.eye_mid.y + 1.2 * A.d, y_end = A.J[6].y;
  const int R = kLongHairRows, C = kLongHairColumns;
  auto across = [&](int k) { return 2.0 * k / C - 1; };  // -1 (left, +X) .. 1 (right)
  auto col_phi = [&](int k) { return kPi + across(k) * kHairHalfWidth; };
  auto tip_y = [&](int k) { return y_end - 0.06 * (1 - across(k) * across(k)); };
  auto row_y = [&](int i, int k) { return y_top + (tip_y(k) - y_top) * double(i) / (R - 1); };

  // Obstacle extents on planes every 5 mm, directions at the columns and half-columns.
  const double step = 0.005, y_hi = y_top + 0.03, y_lo = tip_y(C / 2) - 0.03;
  std::vector<double> planes, phis;
  for (double y = y_hi; y > y_lo; y -= step) planes.push_back(y);
  for (int j = -2; j <= 2 * C + 2; ++j) phis.push_back(kPi + (double(j) / C - 1) * kHairHalfWidth);
  const std::vector<double> ext = radial_extent(verts, faces, tris, ax, az, planes, phis);
  const int D = int(phis.size());
  const double band = (y_top - y_end) / (R - 1);  // a row's height: the sheet between rows clears too
  std::vector<double> req(size_t(R) * (C + 1)), rad(req.size());
  for (int i = 0; i < R; ++i)
    for (int k = 0; k <= C; ++k) {
      const double y = row_y(i, k), s = double(i) / (R - 1);
      double m = 0;
      for (size_t q = 0; q < planes.size(); ++q) {
        if (std::abs(planes[q] - y) > band) continue;
        for (int j = 2 * k; j <= 2 * k + 4; ++j) m = std::max(m, ext[q * D + size_t(j)]);
      }
      req[size_t(i) * (C + 1) + k] = m - 0.006 + 0.018 * smoothstep(0.0, 0.12, s);
    }
  for (int k = 0; k <= C; ++k) {
    double run = 0;
    for (int i = 0; i < R; ++i) run = std::max(run, req[size_t(i) * (C + 1) + k]), rad[size_t(i) * (C + 1) + k] = run;
  }
  for (int i = 0; i < R; ++i) {
    std::vector<double> sm(size_t(C) + 1);
    for (int k = 0; k <= C; ++k) {
      const double* r = &rad[size_t(i) * (C + 1)];
      sm[size_t(k)] = (r[std::max(0, k - 1)] + 2 * r[k] + r[std::min(C, k + 1)]) / 4;
    }
    const double s = double(i) / (R - 1);
    for (int k = 0; k <= C; ++k) {
      const double clump = 0.005 * s * (0.5 + 0.5 * std::cos(2 * kPi * 7 * k / C + 3 * s));  // strands, outward only
      rad[size_t(i) * (C + 1) + k] = std::max(sm[size_t(k)], req[size_t(i) * (C + 1) + k]) + clump;
    }
  }

  SynthMesh m;
  m.name = "long_hair";
  m.part = kSynthLongHair;
  m.gloss = kHairGloss;
  m.texture = 1;
  m.w_start.push_back(0);
  // Skinning by height: the head above the skull base, then neck, spine3 (with the
  // collars at the sides) and spine2 toward the tips; smooth blends in between.
  const double yh = A.J[kHeadJoint].y - 0.03, yn = A.J[kNeckJoint].y - 0.02, y9 = A.J[9].y, y6 = A.J[6].y - 0.05;
  for (int i = 0; i < R; ++i)
    for (int k = 0; k <= C; ++k) {
      const double phi = col_phi(k), r = rad[size_t(i) * (C + 1) + k], y = row_y(i, k);
      m.rest.insert(m.rest.end(), {float(ax + r * std::sin(phi)), float(y), float(az + r * std::cos(phi))});
      const double s = double(i) / (R - 1);
      m.vt.insert(m.vt.end(), {float(double(k) / C), float(kPonytailV0 + (kPonytailV1 - kPonytailV0) * s)});
      const double head = smoothstep(yn - 0.04, yh, y), rest = 1 - head;
      const double neck = rest * smoothstep(y9 - 0.03, yn, y), low = rest - neck;
      const double sp3 = low * smoothstep(y6, y9, y), sp2 = low - sp3;
      const double collar = 0.4 * smoothstep(0.4, 1.0, std::abs(across(k))) * sp3;
      add_weight(m, kHeadJoint, head);
      add_weight(m, kNeckJoint, neck);
      add_weight(m, 9, sp3 - collar);
      add_weight(m, across(k) < 0 ? 13 : 14, collar);
      add_weight(m, 6, sp2);
      end_vertex(m);
    }
  // Columns go with phi like the skirt's: (i,k) -> (i+1,k) -> (i,k+1) faces outward.
  add_grid_faces(m, R, C);
  m.ft = m.faces;
  return m;
}

}  // namespace

SynthSubject make_coat_subject(const BodyModel& body, const SynthSubjectOptions& opt) {
  SynthSubject s;
  s.betas.assign(kBetas, kBetas + std::min(10, body.num_shape));
  shape_rest(body, s);
  const Anatomy A = make_anatomy(s.rest_joints, s.rest_verts);
  const CoatPalette P = make_coat_palette(opt.seed);
  const std::vector<V3> normals = vertex_normals(s.rest_verts, body.faces);
  const auto groups = vertex_groups(body);

  SynthMesh hair = make_hair(body, A, s.rest_verts, normals, groups);

  // Jacket shell: torso from the jacket's hem up (thinner toward the collar, 3.5 -> 1.5 cm)
  // and the upper arms to the cuff (3 -> 5.5 cm: the sleeves flare).
  std::vector<int> jacket_src;
  SynthMesh coat = make_shell(
      body, s.rest_verts, normals,
      [&](int v, V3 p) {
        const auto& g = groups[size_t(v)];
        if (g[gTorso] >= 0.5 && in_jacket(A, p))
          return 0.035 - 0.02 * smoothstep(A.J[kNeckJoint].y - 0.10, A.J[kNeckJoint].y - 0.02, p.y);
        if (g[gArm] >= 0.5) {
          double len = 0;
          const double along = along_arm(A, p, p.x > A.J[0].x, &len);
          if (along < kSleeveEnd * len) return 0.03 + 0.025 * smoothstep(0.2 * len, kSleeveEnd * len, along);
        }
        return 0.0;
      },
      &jacket_src);
  coat.name = "coat";
  coat.part = kSynthCoat;
  coat.gloss = kClothGloss;

  SkirtSpec spec;
  spec.name = "coat_tails";
  spec.part = kSynthCoat;
  spec.y_top = A.waist_y;
  const double knee_y = 0.5 * (A.J[4].y + A.J[5].y);
  spec.y_hem = knee_y - 0.10;  // below the knees
  spec.clearance = 0.015;
  spec.flare = 0.16;
  spec.pleat_depth = 0.012;
  spec.pleats = 10;
  spec.legs = 0.9;
  spec.legs_full_at = 0.6;  // by the knees: bent knees stay inside the tails
  spec.leg_blend = 0.2;  // long tails: spread the thighs' difference over the whole width
  spec.rings = 28;
  SkirtFrame sf{0.3, 0.8};
  SynthMesh tails = make_skirt(spec, A, s.rest_verts, body.faces, groups, &sf);

  // The hair's obstacles: body (arms, hands and eyes left out: the T-pose arms would push
  // it sideways), hair shell and jacket (its sleeves left out likewise).
  std::vector<float> ov = s.rest_verts;
  std::vector<int32_t> of = body.faces;
  std::vector<int> tris;
  auto skip = [&](int v) { return groups[size_t(v)][gArm] + groups[size_t(v)][gHand] + groups[size_t(v)][gEye] > 0.5; };
  for (int f = 0; f < body.num_faces; ++f)
    if (!skip(body.faces[3 * f]) && !skip(body.faces[3 * f + 1]) && !skip(body.faces[3 * f + 2])) tris.push_back(f);
  for (const SynthMesh* m : {&hair, &coat}) {
    const int v0 = int(ov.size() / 3), f0 = int(of.size() / 3);
    ov.insert(ov.end(), m->rest.begin(), m->rest.end());
    for (int32_t i : m->faces) of.push_back(i + v0);
    for (int f = 0; f < m->num_faces(); ++f) {
      if (m == &coat && (skip(jacket_src[size_t(m->faces[3 * f])]) || skip(jacket_src[size_t(m->faces[3 * f + 1])]) ||
                         skip(jacket_src[size_t(m->faces[3 * f + 2])])))
        continue;
      tris.push_back(f0 + f);
    }
  }
  SynthMesh long_hair = make_long_hair(A, ov, of, tris);

  s.meshes.push_back(std::move(hair));
  s.meshes.push_back(std::move(coat));
  s.meshes.push_back(std::move(tails));
  s.meshes.push_back(std::move(long_hair));

  paint_body_texture(body, s, normals, groups, opt.texture_size,
                     [&](V3 p, V3 n, const double* g) { return shade_coat_body(A, P, p, n, g); });
  // Garment atlas: coat tails in the upper part, long hair in the lower part.
  paint_garment_texture(
      s.garment_texture, opt.texture_size,
      [&](double t, double u) { return shade_coat_tails(P, t, kPi + 2 * kPi * u, sf.ref_radius, sf.length); },
      [&](double sp, double u) { return shade_long_hair(P, sp, u); });
  return s;
}

}  // namespace synth
}  // namespace haha
