// Motions of the synthetic subject: a turning-in-place training sequence and a test
// sequence of novel poses, grounded on the rest floor; the unseen views' poses; pose
// distance; fit noise.
//
// Rotations are written in the rest (T-pose) frame, as SMPL-X local rotations are: the
// arms lie along +-X palms down, legs along -Y, the body faces +Z. Handy facts:
//   R_z(-a) lowers the left arm (+X) by a; R_z(+a) lowers the right arm (-X).
//   R_x(-b) swings a hanging arm or a thigh forward (+Z); R_x(+k) bends a knee (shin back).
//   R_y(-c) bends the left elbow (forearm toward +Z); R_y(+c) the right one.
//   R_y(-v) brings the left arm forward from the T-pose; R_y(+v) the right arm.
// Training lowers the arms by 53 to 78 degrees from the T-pose and keeps the knees within
// 0.1 rad of straight; test frames hold the arms forward at most 10 degrees below
// horizontal and bend both knees by at least 0.7 rad, so every test pose is at least
// 0.6 rad from every training pose at the knees alone (the margin behind
// kSynthMinPoseGap, which the tests check on generated sequences).
#include <algorithm>
#include <cmath>
#include <random>

#include "body/rotation.h"
#include "core/error.h"
#include "core/parallel.h"
#include "synth/synth_internal.h"
#include "synth/synth_subject.h"

namespace haha {
namespace {

using synth::kPi;
using synth::V3;
using M3 = Mat3<double>;

M3 rot(V3 axis_angle) { return rodrigues(axis_angle); }
M3 Rx(double a) { return rot({a, 0, 0}); }
M3 Ry(double a) { return rot({0, a, 0}); }
M3 Rz(double a) { return rot({0, 0, a}); }

void set_joint(SmplxParams& p, int j, const M3& R) {
  const V3 w = matrix_to_axis_angle(R);
  for (int c = 0; c < 3; ++c) p.pose[3 * j + c] = float(w[c]);
}

// Uniform [0, 1) from raw generator bits (identical on every platform).
double uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

// Finger flexion axes from the rest joints (toward the palm, -Y in the rest pose).
struct HandAxes {
  V3 flex[2][5][3];  // [hand: 0 left, 1 right][finger][segment]
};
HandAxes hand_axes(const std::vector<float>& J) {
  HandAxes h;
  auto at = [&](int j) { return V3(J[3 * j], J[3 * j + 1], J[3 * j + 2]); };
  for (int hand = 0; hand < 2; ++hand)
    for (int f = 0; f < 5; ++f)
      for (int s = 0; s < 3; ++s) {
        const int j = (hand == 0 ? kLeftHandFirst : kRightHandFirst) + 3 * f + s;
        V3 dir = s < 2 ? at(j + 1) - at(j) : at(j) - at(j - 1);
        if (norm(dir) < 1e-6) dir = V3(hand == 0 ? 1 : -1, 0, 0);
        V3 ax = synth::unit(cross(synth::unit(dir), V3(0, -1, 0)));
        if (norm(ax) < 0.5) ax = V3(0, 0, hand == 0 ? -1 : 1);
        h.flex[hand][f][s] = ax;
      }
  return h;
}

// A hand shape: curl fraction per finger (index, middle, pinky, ring, thumb; SMPL-X order)
// and spread (1 = fingers fanned out, negative = pressed together).
struct HandShape {
  double curl[5];
  double spread;
};

void set_hand(SmplxParams& p, const HandAxes& ax, int hand, const HandShape& s) {
  static const double max_curl[5][3] = {{1.0, 1.1, 0.8}, {1.0, 1.1, 0.8}, {1.0, 1.1, 0.8}, {1.0, 1.1, 0.8}, {0.5, 0.6, 0.7}};
  static const double spread_angle[4] = {-0.22, -0.04, 0.30, 0.14};  // about +Y, left hand
  const int first = hand == 0 ? kLeftHandFirst : kRightHandFirst;
  const double mirror = hand == 0 ? 1 : -1;  // the right hand is the mirror image
  for (int f = 0; f < 5; ++f)
    for (int seg = 0; seg < 3; ++seg) {
      M3 R = rot(s.curl[f] * max_curl[f][seg] * ax.flex[hand][f][seg]);
      if (seg == 0 && f < 4) R = R * Ry(mirror * s.spread * spread_angle[f]);
      set_joint(p, first + 3 * f + seg, R);
    }
}

SmplxParams blank(const SynthSubject& subject, const BodyModel& body) {
  SmplxParams p;
  p.betas = subject.betas;
  p.expression.assign(size_t(std::min(10, body.num_expr)), 0.0f);
  return p;
}

// Puts the lowest body vertex on the rest floor (y of the rest pose's lowest vertex).
void ground(const Lbs<float>& lbs, std::vector<float>& scratch, double floor_y, SmplxParams& p) {
  const float keep_x = p.transl[0], keep_z = p.transl[2];
  p.transl = {0, 0, 0};
  lbs.forward(p, scratch.data(), nullptr, nullptr);
  double lo = 1e30;
  for (size_t i = 1; i < scratch.size(); i += 3) lo = std::min(lo, double(scratch[i]));
  p.transl = {keep_x, float(floor_y - lo), keep_z};
}

}  // namespace

SynthMotion make_synth_motion(const BodyModel& body, const SynthSubject& subject, int train_frames, int test_frames,
                              uint64_t seed, bool still_arms) {
  if (train_frames < 1 || test_frames < 0) fail("synth motion", "need at least one training frame");
  if (subject.rest_joints.size() != size_t(kNumJoints) * 3) fail("synth motion", "subject has no rest joints");
  std::mt19937_64 rng(seed * 0xA24BAED4963EE407ull + 0x5EED5EEDull);
  double ph[12];
  for (double& x : ph) x = 2 * kPi * uniform(rng);
  const HandAxes axes = hand_axes(subject.rest_joints);
  double floor_y = 1e30;
  for (size_t i = 1; i < subject.rest_verts.size(); i += 3) floor_y = std::min(floor_y, double(subject.rest_verts[i]));
  const Lbs<float> lbs(body);

  SynthMotion out;
  const double tau = 2 * kPi;
  for (int i = 0; i < train_frames; ++i) {
    const double s = double(i) / train_frames;
    auto wave = [&](double cycles, int k) { return std::sin(tau * cycles * s + ph[k]); };
    SmplxParams p = blank(subject, body);
    set_joint(p, kGlobalOrient, Ry(tau * s));  // one full turn: every side seen once
    for (int j : {3, 6, 9}) set_joint(p, j, Ry(0.06 * wave(2, 0)) * Rz(0.04 * wave(3, 1)));
    set_joint(p, 12, Rx(0.06 * wave(2, 2)));
    set_joint(p, 15, Ry(0.2 * wave(3, 3)) * Rx(0.05 * wave(2, 4)));
    // Still arms: the mean of each moving value below.
    const double arm = still_arms ? 0.0 : 1.0;
    const double down_l = 1.15 + arm * 0.22 * wave(4, 5), down_r = 1.15 + arm * 0.22 * std::sin(tau * 4 * s + ph[5] + 1.3);
    const double swing = arm * 0.45 * wave(3, 6);
    set_joint(p, 16, Rx(-swing) * Rz(-down_l));
    set_joint(p, 17, Rx(swing) * Rz(down_r));
    const double el = 0.2 + 0.45 * (0.5 + arm * 0.5 * wave(3, 7)),
                 er = 0.2 + 0.45 * (0.5 + arm * 0.5 * std::sin(tau * 3 * s + ph[7] + 2));
    set_joint(p, 18, Ry(-el));
    set_joint(p, 19, Ry(er));
    set_joint(p, 20, Rz(-0.2 * wave(4, 8)));
    set_joint(p, 21, Rz(0.2 * std::sin(tau * 4 * s + ph[8] + 1)));
    const double hip = 0.06 * wave(4, 9);
    set_joint(p, 1, Rx(-hip));
    set_joint(p, 2, Rx(hip));
    set_joint(p, 4, Rx(0.05 + 0.05 * (0.5 + 0.5 * wave(4, 9))));
    set_joint(p, 5, Rx(0.05 + 0.05 * (0.5 - 0.5 * wave(4, 9))));
    set_joint(p, kJaw, Rx(0.06 * (0.5 + 0.5 * wave(5, 10))));
    for (int hand = 0; hand < 2; ++hand) {
      const double k = 0.5 + 0.5 * std::sin(tau * 5 * s + ph[11] + 2.0 * hand);
      HandShape h{{0, 0, 0, 0, 0}, 0.0};
      for (int f = 0; f < 4; ++f) h.curl[f] = clamp(k + 0.1 * std::sin(tau * 5 * s + f), 0.0, 1.0);
      h.curl[4] = 0.6 * k;
      set_hand(p, axes, hand, h);
    }
    p.transl = {float(0.02 * wave(2, 1)), 0, 0};
    out.train.push_back(p);
  }

  static const HandShape test_hands[4] = {
      {{0.0, 0.0, 0.0, 0.0, 0.0}, 1.0},    // spread
      {{0.0, 1.0, 1.0, 1.0, 0.8}, 0.0},    // pointing index
      {{1.0, 1.0, 1.0, 1.0, 1.0}, -0.4},   // fist
      {{0.0, 0.0, 1.0, 1.0, 0.9}, 1.0},    // V sign
  };
  for (int j = 0; j < test_frames; ++j) {
    auto u = [&] { return uniform(rng); };
    SmplxParams p = blank(subject, body);
    set_joint(p, kGlobalOrient, Ry(-1.0 + 2.0 * (0.618034 * j + 0.3 - std::floor(0.618034 * j + 0.3))));
    const double lean = 0.15 + 0.1 * u(), twist = 0.2 * (2 * u() - 1);
    set_joint(p, 3, Rx(lean) * Ry(twist));
    set_joint(p, 6, Rx(0.5 * lean));
    set_joint(p, 15, Rx(0.1 * u()) * Rz(0.15 * (2 * u() - 1)));
    // Each arm reaches forward (v from the T-pose toward +Z) and up (e), at most 10
    // degrees below horizontal; alternately it is raised high with the forearm bent up
    // (R_z(+-c) lifts the forearm of a T-pose arm) or reaches with a slight elbow bend.
    for (int side = 0; side < 2; ++side) {
      const double sgn = side == 0 ? 1 : -1;  // left arm +X, right arm -X
      const bool high = ((j + side) % 3) == 0;
      const double v = high ? 0.2 + 0.5 * u() : 0.7 + 0.7 * u();
      const double e = high ? 0.8 + 0.5 * u() : -0.15 + 0.6 * u();
      set_joint(p, 16 + side, Rz(sgn * e) * Ry(-sgn * v));
      const double bend = high ? 0.6 + 0.8 * u() : 0.3 * u();
      set_joint(p, 18 + side, Rz(sgn * bend) * Ry(-sgn * 0.3 * u()));
    }
    // Knees bent (squat-like, asymmetric); ankles keep the feet flat.
    for (int side = 0; side < 2; ++side) {
      const double h = 0.35 + 0.4 * u(), k = 0.7 + 0.6 * u();
      set_joint(p, 1 + side, Rx(-h));
      set_joint(p, 4 + side, Rx(k));
      set_joint(p, 7 + side, Rx(h - k));
    }
    set_joint(p, kJaw, Rx(0.15 * u()));
    set_hand(p, axes, 0, test_hands[j % 4]);
    set_hand(p, axes, 1, test_hands[(j + 2) % 4]);
    out.test.push_back(p);
  }
  // Grounding: one frame per thread (LBS's own loop then runs single-threaded).
  std::vector<SmplxParams*> all;
  for (SmplxParams& p : out.train) all.push_back(&p);
  for (SmplxParams& p : out.test) all.push_back(&p);
  std::vector<std::vector<float>> scratch(size_t(std::max(1, num_threads())), std::vector<float>(size_t(body.num_verts) * 3));
  parallel_for_dynamic(int64_t(all.size()), [&](int64_t i) { ground(lbs, scratch[size_t(thread_index())], floor_y, *all[i]); });
  return out;
}

const char* synth_unseen_view_name(int view) {
  switch (view) {
    case kUnseenBelow: return "below chin";
    case kUnseenAbove: return "above head";
    case kUnseenArmsUp: return "arms raised";
    default: return "?";
  }
}

std::vector<SmplxParams> make_synth_unseen_poses(const BodyModel& body, const SynthSubject& subject) {
  if (subject.rest_joints.size() != size_t(kNumJoints) * 3) fail("synth unseen views", "subject has no rest joints");
  const HandAxes axes = hand_axes(subject.rest_joints);
  double floor_y = 1e30;
  for (size_t i = 1; i < subject.rest_verts.size(); i += 3) floor_y = std::min(floor_y, double(subject.rest_verts[i]));
  const Lbs<float> lbs(body);
  std::vector<float> scratch(size_t(body.num_verts) * 3);
  std::vector<SmplxParams> out;
  for (int view = 0; view < kSynthUnseenViews; ++view) {
    SmplxParams p = blank(subject, body);  // facing the camera (+Z)
    const bool up = view == kUnseenArmsUp;
    // Below / above: the turn's mean arms (53 to 78 degrees below the T-pose), so only the
    // view is new. Arms up: 69 degrees above the T-pose, a pose the turn never holds, which
    // shows the armpits and the arms' undersides.
    const double lift = up ? 1.2 : -1.15, elbow = up ? 0.25 : 0.42;
    set_joint(p, 16, Rz(lift));
    set_joint(p, 17, Rz(-lift));
    set_joint(p, 18, Ry(-elbow));
    set_joint(p, 19, Ry(elbow));
    set_joint(p, 4, Rx(0.05));
    set_joint(p, 5, Rx(0.05));
    const HandShape open{{0.1, 0.1, 0.1, 0.1, 0.1}, 0.6}, relaxed{{0.5, 0.5, 0.5, 0.5, 0.3}, 0.0};
    set_hand(p, axes, 0, up ? open : relaxed);
    set_hand(p, axes, 1, up ? open : relaxed);
    ground(lbs, scratch, floor_y, p);
    out.push_back(p);
  }
  return out;
}

double pose_distance(const SmplxParams& a, const SmplxParams& b) {
  double worst = 0;
  for (int j = 1; j < kNumJoints; ++j) {
    const M3 Ra = rot(V3(a.pose[3 * j], a.pose[3 * j + 1], a.pose[3 * j + 2]));
    const M3 Rb = rot(V3(b.pose[3 * j], b.pose[3 * j + 1], b.pose[3 * j + 2]));
    worst = std::max(worst, norm(matrix_to_axis_angle(transpose(Ra) * Rb)));
  }
  return worst;
}

std::vector<SmplxParams> perturb_fits(const std::vector<SmplxParams>& truth, FitNoise sigma, uint64_t seed) {
  if (!(sigma.pose >= 0) || !std::isfinite(sigma.pose)) fail("--fit-noise-pose", "must be a finite value >= 0");
  if (!(sigma.transl >= 0) || !std::isfinite(sigma.transl)) fail("--fit-noise-transl", "must be a finite value >= 0");
  std::vector<SmplxParams> out = truth;
  if (sigma.pose == 0 && sigma.transl == 0) return out;
  std::mt19937_64 rng(seed * 0x9FB21C651E98DF25ull + 0xF17u);
  // Box-Muller on raw generator bits (std::normal_distribution differs between libraries).
  auto gauss = [&] {
    const double u1 = (double(rng() >> 11) + 0.5) * 0x1.0p-53, u2 = double(rng() >> 11) * 0x1.0p-53;
    return std::sqrt(-2 * std::log(u1)) * std::cos(2 * kPi * u2);
  };
  for (SmplxParams& p : out) {
    for (int j = 0; j < kNumJoints; ++j) {
      if (j == kLeftEye || j == kRightEye) continue;
      for (int c = 0; c < 3; ++c) p.pose[3 * j + c] += float(sigma.pose * gauss());
    }
    for (float& t : p.transl) t += float(sigma.transl * gauss());
  }
  return out;
}

}  // namespace haha
