// JSON numbers of float32 values: short, and exact when read back through a double.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "format/glb.h"

namespace haha {
namespace {

float bits_to_float(uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

// Digits between the first and the last non-zero digit of the mantissa.
int significant_digits(const std::string& s) {
  std::string d;
  for (char c : s) {
    if (c == 'e' || c == 'E') break;
    if (c >= '0' && c <= '9') d += c;
  }
  const size_t a = d.find_first_not_of('0'), b = d.find_last_not_of('0');
  return a == std::string::npos ? 0 : int(b - a + 1);
}

TEST(JsonFloat, ReadsBackExactlyAndPrintsShort) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<uint32_t> any;
  size_t long_prints = 0, n = 0;
  auto check = [&](float f) {
    if (!std::isfinite(f)) return;
    const glb::Json j = glb::json_float(f);
    const std::string s = j.dump();
    const double back = glb::Json::parse(s).get<double>();
    ASSERT_EQ(float(back), f) << s;
    if (significant_digits(s) > 9) ++long_prints;
    ++n;
  };
  for (int i = 0; i < 200000; ++i) check(bits_to_float(any(rng)));
  // Hard cases: subnormals, the extremes, values next to powers of two and ten.
  for (float f : {std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::min(),
                  std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(), 0.0f, -0.0f, 0.1f,
                  0.05f, 1.0f / 3.0f, 16777216.0f, 16777217.0f, 1e-38f, 3.4e38f})
    check(f);
  for (int e = -140; e < 128; ++e) {
    const float p = std::ldexp(1.0f, e);
    check(std::nextafter(p, 0.0f));
    check(p);
    check(std::nextafter(p, INFINITY));
  }
  // nlohmann prints doubles with Grisu2, which is not always shortest: measured 0.7 % of
  // random floats come out with 17 digits (still exact).
  EXPECT_LT(double(long_prints), 0.01 * double(n)) << long_prints << " of " << n;
  // The printed form is the short one (a double's 17 digits would be 0.05000000074505806).
  EXPECT_EQ(glb::Json(glb::json_float(0.05f)).dump(), "0.05");
}

}  // namespace
}  // namespace haha
