// Miniature LPIPS networks with random weights in the documented layout (train/lpips.h):
// channels are small, kernel sizes, strides and taps are the real ones.
#pragma once

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "train/lpips.h"

namespace haha::test {

struct ConvSpec {
  int index, out, k;
};

inline LpipsWeights make_weights(LpipsBackbone b, unsigned seed, const std::string& source = "mini.npz") {
  std::vector<ConvSpec> convs;
  std::vector<int> tap_after;  // tap channel counts follow the last conv before each tap
  if (b == LpipsBackbone::Alex) {
    convs = {{0, 4, 11}, {3, 5, 5}, {6, 6, 3}, {8, 5, 3}, {10, 4, 3}};
  } else {
    convs = {{0, 3, 3},  {2, 3, 3},  {5, 4, 3},  {7, 4, 3},  {10, 5, 3}, {12, 5, 3}, {14, 5, 3},
             {17, 4, 3}, {19, 4, 3}, {21, 4, 3}, {24, 3, 3}, {26, 3, 3}, {28, 3, 3}};
  }
  const std::vector<int> taps = b == LpipsBackbone::Alex ? std::vector<int>{0, 3, 6, 8, 10}
                                                         : std::vector<int>{2, 7, 14, 21, 28};
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.f, 1.f);
  std::uniform_real_distribution<float> u(0.1f, 1.f);
  LpipsWeights w;
  w.source = source;
  const std::string p = lpips_prefix(b);
  int in = 3, tap = 0;
  for (const ConvSpec& c : convs) {
    LpipsTensor wt{{c.out, in, c.k, c.k}, {}}, bt{{c.out}, {}};
    const float s = std::sqrt(2.f / float(in * c.k * c.k));
    for (int i = 0; i < c.out * in * c.k * c.k; ++i) wt.data.push_back(s * g(rng));
    for (int i = 0; i < c.out; ++i) bt.data.push_back(0.05f * g(rng));
    w.tensors[p + ".features." + std::to_string(c.index) + ".weight"] = wt;
    w.tensors[p + ".features." + std::to_string(c.index) + ".bias"] = bt;
    in = c.out;
    if (c.index == taps[size_t(tap)]) {
      LpipsTensor l{{1, c.out, 1, 1}, {}};
      for (int i = 0; i < c.out; ++i) l.data.push_back(u(rng));  // LPIPS heads are >= 0
      w.tensors[p + ".lin." + std::to_string(tap) + ".weight"] = l;
      ++tap;
    }
  }
  return w;
}

}  // namespace haha::test
