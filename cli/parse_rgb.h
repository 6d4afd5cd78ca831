// "--background r,g,b" for the render commands: exactly three finite numbers.
#pragma once

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/math.h"

namespace haha::cli {

inline Vec3f parse_rgb(const std::string& s) {
  Vec3f c;
  std::istringstream in(s);
  std::string part;
  int k = 0;
  while (std::getline(in, part, ',')) {
    char* end = nullptr;
    const float v = std::strtof(part.c_str(), &end);
    if (k >= 3 || part.empty() || *end != '\0' || !std::isfinite(v))
      fail("--background", "expected three numbers r,g,b (e.g. 1,1,1), got '" + s + "'");
    c[k++] = v;
  }
  if (k != 3) fail("--background", "expected three numbers r,g,b (e.g. 1,1,1), got '" + s + "'");
  return c;
}

}  // namespace haha::cli
