// Subject 2 of `haha synth` (long loose hair, loose coat, another body shape) on the
// low-resolution procedural body: well-formed skinned meshes, garments standing off the
// body, no tearing under strong poses, hair that follows the head at the top and the
// back at the tips, renders in frame, view-dependent shading (zero at strength 0,
// changing with the view), bad options.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "body/procedural_body.h"
#include "body/rotation.h"
#include "core/error.h"
#include "support/expect_error.h"
#include "support/low_body.h"
#include "support/synth_mesh_checks.h"
#include "synth/synth_internal.h"
#include "synth/synth_subject.h"

namespace haha {
namespace {

using synth::V3;

using test::low_body;

// Built on first use only (ctest runs every test in its own process).
const SynthSubject& subject(int which) {
  auto make = [](int n) {
    SynthSubjectOptions o;
    o.texture_size = 128;
    o.subject = n;
    return make_synth_subject(low_body(), o);
  };
  if (which == 1) {
    static const SynthSubject s = make(1);
    return s;
  }
  static const SynthSubject s = make(2);
  return s;
}

const SynthMesh& mesh(const std::string& name) {
  for (const SynthMesh& m : subject(2).meshes)
    if (m.name == name) return m;
  throw std::runtime_error("no mesh " + name);
}

V3 at(const std::vector<float>& v, int i) { return V3(v[3 * i], v[3 * i + 1], v[3 * i + 2]); }

// Distance from p to triangle (a, b, c) (closest point by regions, Ericson 5.1.5).
double point_triangle(V3 p, V3 a, V3 b, V3 c) {
  const V3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return norm(p - a);
  const V3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return norm(p - b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return norm(p - (a + d1 / (d1 - d3) * ab));
  const V3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return norm(p - c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return norm(p - (a + d2 / (d2 - d6) * ac));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return norm(p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b)));
  const double den = 1 / (va + vb + vc);
  return norm(p - (a + vb * den * ab + vc * den * ac));
}

// Fraction of the mesh's rest vertices farther than `gap` from the shaped rest body surface.
double fraction_beyond(const SynthMesh& m, double gap) {
  const SynthSubject& s = subject(2);
  const BodyModel& b = low_body();
  int far = 0;
  for (int v = 0; v < m.num_verts(); ++v) {
    const V3 p = at(m.rest, v);
    double d = 1e9;
    for (int f = 0; f < b.num_faces && d > gap; ++f)
      d = std::min(d, point_triangle(p, at(s.rest_verts, b.faces[3 * f]), at(s.rest_verts, b.faces[3 * f + 1]),
                                     at(s.rest_verts, b.faces[3 * f + 2])));
    far += d > gap;
  }
  return double(far) / m.num_verts();
}

TEST(SynthCoat, MeshesAreWellFormedAndSkinned) {
  const SynthSubject& s = subject(2);
  std::map<std::string, unsigned> parts;
  for (const SynthMesh& m : s.meshes) parts[m.name] = m.part;
  EXPECT_EQ(parts, (std::map<std::string, unsigned>{
                       {"hair", kSynthHair}, {"long_hair", kSynthLongHair}, {"coat", kSynthCoat}, {"coat_tails", kSynthCoat}}));
  for (const SynthMesh& m : s.meshes) {
    SCOPED_TRACE(m.name);
    ASSERT_GT(m.num_faces(), 100);
    EXPECT_GT(m.gloss, 0.0f);
    test::expect_synth_mesh_well_formed(m);
    if (HasFatalFailure()) return;
    for (int f = 0; f < m.num_faces(); ++f) {
      const V3 a = at(m.rest, m.faces[3 * f]), b = at(m.rest, m.faces[3 * f + 1]), c = at(m.rest, m.faces[3 * f + 2]);
      ASSERT_GT(norm(cross(b - a, c - a)), 1e-10) << "face " << f;  // every face has an area
    }
  }
  for (const Image* t : {&s.body_texture, &s.garment_texture}) {
    ASSERT_FALSE(t->empty());
    for (float x : t->data) ASSERT_TRUE(x >= 0 && x <= 1);
  }
}

TEST(SynthCoat, AnotherBodyShapeAndPalette) {
  const SynthSubject &a = subject(1), &b = subject(2);
  auto extent = [](const std::vector<float>& v, int axis) {
    double lo = 1e9, hi = -1e9;
    for (size_t i = size_t(axis); i < v.size(); i += 3) lo = std::min(lo, double(v[i])), hi = std::max(hi, double(v[i]));
    return hi - lo;
  };
  EXPECT_GT(extent(b.rest_verts, 1), extent(a.rest_verts, 1) + 0.06);  // taller
  // Heavier: wider at the hips (x extent of the vertices within 3 cm of the hip joints'
  // height; the low body measures 0.347 m for subject 1, 0.401 m for subject 2; heights 1.709 and
  // 1.803 m).
  auto hips = [](const SynthSubject& s) {
    const double y = 0.5 * (s.rest_joints[3 * 1 + 1] + s.rest_joints[3 * 2 + 1]);
    double lo = 1e9, hi = -1e9;
    for (size_t i = 0; i < s.rest_verts.size(); i += 3)
      if (std::abs(s.rest_verts[i + 1] - y) < 0.03) lo = std::min(lo, double(s.rest_verts[i])), hi = std::max(hi, double(s.rest_verts[i]));
    return hi - lo;
  };
  EXPECT_GT(hips(b), hips(a) + 0.03);
  double sa = 0, sb = 0;
  for (size_t i = 0; i < a.rest_verts.size(); i += 3) {
    sa += std::hypot(a.rest_verts[i] - a.rest_joints[0], a.rest_verts[i + 2] - a.rest_joints[2]);
    sb += std::hypot(b.rest_verts[i] - b.rest_joints[0], b.rest_verts[i + 2] - b.rest_joints[2]);
  }
  EXPECT_GT(sb, 1.05 * sa);
  double diff = 0;
  for (size_t i = 0; i < a.body_texture.data.size(); ++i) diff += std::abs(a.body_texture.data[i] - b.body_texture.data[i]);
  EXPECT_GT(diff / a.body_texture.data.size(), 0.05);
}

TEST(SynthCoat, HairAndCoatStandOffTheBody) {
  // Measured on this body: long hair 100 %, jacket shell 86 %, tails 98.5 % beyond 2 cm.
  EXPECT_GT(fraction_beyond(mesh("long_hair"), 0.02), 0.6);
  EXPECT_GT(fraction_beyond(mesh("coat"), 0.02), 0.5);
  EXPECT_GT(fraction_beyond(mesh("coat_tails"), 0.02), 0.5);
  // The tails reach below the knees; the hair from above the ears to the shoulder blades.
  const SynthSubject& s = subject(2);
  auto lowest = [](const SynthMesh& m) {
    double y = 1e9;
    for (int v = 0; v < m.num_verts(); ++v) y = std::min(y, double(m.rest[3 * v + 1]));
    return y;
  };
  EXPECT_LT(lowest(mesh("coat_tails")), std::min(s.rest_joints[3 * 4 + 1], s.rest_joints[3 * 5 + 1]) - 0.05);
  EXPECT_LT(lowest(mesh("long_hair")), s.rest_joints[3 * 9 + 1]);  // below spine3: long
}

SmplxParams strong_pose(const SynthSubject& s) {
  SmplxParams p;
  p.betas = s.betas;
  auto set = [&](int j, double x, double y, double z) {
    p.pose[3 * j] = float(x), p.pose[3 * j + 1] = float(y), p.pose[3 * j + 2] = float(z);
  };
  set(15, 0.2, 0.8, 0.0);    // head turned hard
  set(12, 0.1, 0.3, 0.1);    // neck
  set(3, 0.3, 0.2, 0.0);     // lean and twist
  set(1, -1.0, 0.0, 0.2);    // left thigh forward
  set(2, 0.4, 0.0, -0.2);    // right thigh back
  set(4, 1.3, 0.0, 0.0);     // knees bent
  set(5, 0.6, 0.0, 0.0);
  set(16, 0.0, 0.0, -1.2);   // arms down / up
  set(17, 0.0, 0.6, -0.8);
  set(18, 0.0, -1.5, 0.0);   // elbow bent hard
  return p;
}

// Largest ratio of posed to rest edge length over the mesh (and the smallest).
std::pair<double, double> edge_ratio(const SynthMesh& m, const std::vector<float>& posed) {
  double hi = 0, lo = 1e9;
  for (int f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.faces[3 * f + k], b = m.faces[3 * f + (k + 1) % 3];
      const double r = norm(at(posed, a) - at(posed, b)) / norm(at(m.rest, a) - at(m.rest, b));
      hi = std::max(hi, r), lo = std::min(lo, r);
    }
  return {lo, hi};
}

// Edge-length ratios posed / rest of every garment mesh, (smallest, largest) over `poses`.
std::map<std::string, std::pair<double, double>> garment_stretch(const std::vector<SmplxParams>& poses) {
  const SynthSubject& s = subject(2);
  SynthRenderer r(low_body(), s);
  std::map<std::string, std::pair<double, double>> out;
  for (const SmplxParams& p : poses)
    for (const SynthMesh& m : s.meshes) {
      // Pose this mesh's part; the coat bit holds two meshes: take this one's share.
      std::vector<float> v;
      r.pose(p, m.part, v);
      size_t off = 0;
      for (const SynthMesh& o : s.meshes) {
        if (&o == &m) break;
        if (o.part == m.part) off += size_t(o.num_verts()) * 3;
      }
      const std::vector<float> mine(v.begin() + long(off), v.begin() + long(off) + long(m.rest.size()));
      const auto [lo, hi] = edge_ratio(m, mine);
      auto& e = out.emplace(m.name, std::pair{1e9, 0.0}).first->second;
      e.first = std::min(e.first, lo), e.second = std::max(e.second, hi);
    }
  return out;
}

TEST(SynthCoat, GarmentsDoNotTearUnderStrongPoses) {
  // A lunge (thighs 1.4 rad apart) with a hard head turn, bent elbow and knees. Measured
  // largest ratios: coat 1.96, tails 3.14 (their middle spans both thighs: a real coat
  // stretches or pulls there too), long hair 2.31, hair shell 1.0.
  for (const auto& [name, e] : garment_stretch({strong_pose(subject(2))})) {
    EXPECT_LT(e.second, 4.0) << name;
    EXPECT_GT(e.first, 0.2) << name;
  }
  // The dataset's own test poses (knees bent 0.7 to 1.3 rad, arms raised): tighter.
  // Measured: coat 0.39 .. 2.03 (raised arms pull the jacket's sleeve), tails 0.63 .. 1.33,
  // long hair 0.90 .. 1.31.
  const SynthMotion m = make_synth_motion(low_body(), subject(2), 1, 8, 0);
  for (const auto& [name, e] : garment_stretch(m.test)) {
    EXPECT_LT(e.second, 2.5) << name;
    EXPECT_GT(e.first, 0.3) << name;
  }
}

TEST(SynthCoat, LongHairTurnsWithTheHeadAtTheTopAndStaysAtTheTips) {
  const SynthSubject& s = subject(2);
  SynthRenderer r(low_body(), s);
  SmplxParams p0, p1;
  p0.betas = p1.betas = s.betas;
  p1.pose[3 * 15 + 1] = 0.6f;  // head turns 0.6 rad
  std::vector<float> a, b;
  r.pose(p0, kSynthLongHair, a);
  r.pose(p1, kSynthLongHair, b);
  const SynthMesh& m = mesh("long_hair");
  const int cols = synth::kLongHairColumns + 1;
  ASSERT_EQ(m.num_verts(), synth::kLongHairRows * cols);
  double top = 0, tips = 0;
  for (int k = 0; k < cols; ++k) {
    top = std::max(top, norm(at(b, k) - at(a, k)));
    const int t = m.num_verts() - cols + k;
    tips = std::max(tips, norm(at(b, t) - at(a, t)));
  }
  EXPECT_GT(top, 0.04);   // the top follows the head
  EXPECT_LT(tips, 0.005);  // the tips stay on the back: the sheet shears, not the body
}

struct Scene {
  SynthMotion motion = make_synth_motion(low_body(), subject(2), 4, 2, 0);
  SynthRenderer renderer{low_body(), subject(2)};
  Camera cam;
  Scene() {
    std::vector<const SmplxParams*> all;
    for (const auto& p : motion.train) all.push_back(&p);
    for (const auto& p : motion.test) all.push_back(&p);
    cam = synth_camera(renderer, all, 64);
  }
};

TEST(SynthCoat, RendersInFrameWithSoftMasks) {
  Scene sc;
  sc.renderer.set_view_shading(default_view_shading(2));
  Image rgb, mask;
  std::vector<SmplxParams> all = sc.motion.train;
  all.insert(all.end(), sc.motion.test.begin(), sc.motion.test.end());
  for (const SmplxParams& p : all) {
    sc.renderer.render(sc.cam, p, 2, kSynthAll, rgb, mask);
    int on = 0;
    for (int i = 0; i < 64 * 64; ++i) {
      const float m = mask.data[i];
      ASSERT_TRUE(m >= 0 && m <= 1);
      on += m > 0;
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(rgb.data[3 * i + c] >= 0 && rgb.data[3 * i + c] <= m + 1e-6f);
    }
    EXPECT_GT(on, 64 * 64 / 20);
    for (int k = 0; k < 64; ++k) {  // the whole person inside the frame
      EXPECT_EQ(mask.at(k, 0, 0), 0.0f);
      EXPECT_EQ(mask.at(k, 63, 0), 0.0f);
      EXPECT_EQ(mask.at(0, k, 0), 0.0f);
      EXPECT_EQ(mask.at(63, k, 0), 0.0f);
    }
  }
}

TEST(SynthCoat, ViewShadingDependsOnTheViewAndIsZeroAtStrengthZero) {
  // The shading function: identity at strength 0; for one normal, another view direction
  // gives another colour (a texture holds one colour per surface point).
  const V3 c(0.5, 0.4, 0.3), n(0, 0, 1);
  const V3 v1 = synth::unit(V3(0, 0, 1)), v2 = synth::unit(V3(0.8, 0, 0.3));
  for (int k = 0; k < 3; ++k) EXPECT_EQ(synth::view_shade(c, n, v2, 0)[k], c[k]);
  EXPECT_GT(norm(synth::view_shade(c, n, v1, 0.5) - synth::view_shade(c, n, v2, 0.5)), 0.02);
  EXPECT_LT(norm(synth::view_shade(c, n, v1, 0.5) - c), 0.2);  // mild
  // Renders: strength 0 is exactly the unshaded render; a strength changes garment pixels
  // only (the body has no gloss), by amounts that differ between views of the turn.
  Scene sc;
  Image base, base_mask, shaded, mask, body0, body1;
  std::vector<double> change;
  for (const SmplxParams& p : {sc.motion.train[0], sc.motion.train[1]}) {
    sc.renderer.set_view_shading(0);
    sc.renderer.render(sc.cam, p, 2, kSynthAll, base, base_mask);
    sc.renderer.render(sc.cam, p, 2, kSynthBody, body0, mask);
    sc.renderer.set_view_shading(0.5);
    sc.renderer.render(sc.cam, p, 2, kSynthBody, body1, mask);
    EXPECT_EQ(body0.data, body1.data);
    sc.renderer.render(sc.cam, p, 2, kSynthAll, shaded, mask);
    EXPECT_EQ(mask.data, base_mask.data);
    double d = 0;
    for (size_t i = 0; i < base.data.size(); ++i) d += std::abs(shaded.data[i] - base.data[i]);
    change.push_back(d / base.data.size());
  }
  SynthRenderer fresh(low_body(), subject(2));
  Image again;
  fresh.render(sc.cam, sc.motion.train[1], 2, kSynthAll, again, mask);
  EXPECT_EQ(again.data, base.data);  // the default strength is 0: the textures alone
  EXPECT_GT(change[0], 0.002);
  EXPECT_GT(change[1], 0.002);
  EXPECT_GT(std::abs(change[0] - change[1]), 0.05 * std::max(change[0], change[1]));
  haha::test::expect_error([&] { sc.renderer.set_view_shading(-0.1); }, "--view-shading");
  haha::test::expect_error([&] { sc.renderer.set_view_shading(NAN); }, "--view-shading");
}

TEST(SynthCoat, BadSubjectOrShadingIsAClearError) {
  SynthSubjectOptions o;
  o.subject = 3;
  haha::test::expect_error([&] { make_synth_subject(low_body(), o); }, "--subject: 3 is not a subject");
  SynthOptions so;
  so.subject = 0;
  haha::test::expect_error([&] { validate_synth_options(so); }, "--subject");
  so.subject = 2;
  EXPECT_NO_THROW(validate_synth_options(so));
  so.view_shading = 2.5;
  haha::test::expect_error([&] { validate_synth_options(so); }, "--view-shading");
  so.view_shading = -0.5;
  haha::test::expect_error([&] { validate_synth_options(so); }, "--view-shading");
  EXPECT_EQ(default_view_shading(1), 0.0);
  EXPECT_GT(default_view_shading(2), 0.0);
}

}  // namespace
}  // namespace haha
