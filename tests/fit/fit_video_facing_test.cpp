// Face points seen from behind (fit/fit_video_facing.h): the facing factor of the nose and
// eyes against the head's heading, every other point untouched.
#include "fit/fit_video_facing.h"

#include <gtest/gtest.h>

#include <cmath>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "body/rotation.h"
#include "io/keypoints_json.h"

namespace haha {
namespace {

namespace bp = blazepose;
constexpr double kPi = 3.14159265358979323846;

const BodyModel& procedural() {
  static const BodyModel b = make_procedural_body({BodyResolution::low, 3});
  return b;
}

// The correspondence's points of the rest body turned by `yaw` about its vertical axis,
// upright in camera axes (y down) 3 m in front of the camera; yaw 0 faces the camera.
std::vector<Vec3d> posed(const std::vector<FitVideoPoint>& pts, double yaw) {
  const BodyModel& b = procedural();
  std::vector<float> v(size_t(b.num_verts) * 3), j(size_t(kNumJoints) * 3);
  Lbs<float>(b).forward(SmplxParams{}, v.data(), j.data(), nullptr);
  const Mat3<double> R = rodrigues(Vec3d(kPi, 0, 0)) * rodrigues(Vec3d(0, yaw, 0));
  std::vector<Vec3d> out;
  for (const FitVideoPoint& p : pts) {
    const float* x = p.joint >= 0 ? &j[size_t(3 * p.joint)] : &v[size_t(3 * p.vertex)];
    out.push_back(R * Vec3d(x[0], x[1] - 1.0, x[2]) + Vec3d(0, 0, 3));
  }
  return out;
}

double factor_of(const std::vector<FitVideoPoint>& pts, const std::vector<double>& f, int blaze) {
  for (size_t k = 0; k < pts.size(); ++k)
    if (pts[k].blazepose == blaze) return f[k];
  ADD_FAILURE() << "no point " << blaze;
  return NAN;
}

TEST(FitVideoFacing, FaceFadesAsTheHeadTurnsAwayAndOtherPointsKeepTheirWeight) {
  const std::vector<FitVideoPoint> pts = fit_video_points(procedural());
  double last = 2;
  for (double deg : {0.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0}) {
    const std::vector<double> f = face_point_factors(pts, posed(pts, deg * kPi / 180));
    ASSERT_EQ(f.size(), pts.size());
    const double nose = factor_of(pts, f, bp::nose);
    EXPECT_EQ(factor_of(pts, f, bp::left_eye), nose) << deg;
    EXPECT_EQ(factor_of(pts, f, bp::right_eye), nose) << deg;
    EXPECT_LE(nose, last) << "the factor must not grow as the head turns away (" << deg << " deg)";
    last = nose;
    if (deg <= 60) {
      EXPECT_EQ(nose, 1.0) << deg;  // facing the camera: as BlazePose says
    }
    if (deg >= 120) {
      EXPECT_EQ(nose, 0.0) << deg;  // turned away: not used
    }
    if (deg == 90) {  // a profile keeps part (the nose sits below the ears and to the side)
      EXPECT_GT(nose, 0.2);
      EXPECT_LT(nose, 0.8);
    }
    for (size_t k = 0; k < pts.size(); ++k) {
      const int b = pts[k].blazepose;
      if (b != bp::nose && b != bp::left_eye && b != bp::right_eye) {
        EXPECT_EQ(f[k], 1.0) << pts[k].name << " " << deg;
      }
    }
  }
  // Turned to either side alike.
  const std::vector<double> l = face_point_factors(pts, posed(pts, 100 * kPi / 180));
  const std::vector<double> r = face_point_factors(pts, posed(pts, -100 * kPi / 180));
  EXPECT_NEAR(factor_of(pts, l, bp::nose), factor_of(pts, r, bp::nose), 0.05);
}

TEST(FitVideoFacing, WithoutNoseOrEarsEveryFactorIsOne) {
  std::vector<FitVideoPoint> pts = fit_video_points(procedural());
  std::vector<FitVideoPoint> no_ears;
  for (const FitVideoPoint& p : pts)
    if (p.blazepose != bp::left_ear) no_ears.push_back(p);
  for (double f : face_point_factors(no_ears, posed(no_ears, kPi))) EXPECT_EQ(f, 1.0);
  // Mismatched sizes or a degenerate head: no change either.
  for (double f : face_point_factors(pts, {})) EXPECT_EQ(f, 1.0);
  for (double f : face_point_factors(pts, std::vector<Vec3d>(pts.size(), Vec3d(0, 0, 0)))) EXPECT_EQ(f, 1.0);
}

}  // namespace
}  // namespace haha
