#include "app/lpips_weights.h"

#include <cmath>

#include "core/error.h"
#include "io/npy.h"

namespace haha {

LpipsWeights read_lpips_weights(const std::string& path) {
  const Npz npz = Npz::read(path);
  LpipsWeights w;
  w.source = path;
  for (const std::string& key : npz.keys()) {
    if (key.rfind("alex.", 0) != 0 && key.rfind("vgg.", 0) != 0) continue;
    const NpyArray& a = npz.get(key);  // throws for an undecodable dtype
    if (a.dtype != DType::f32 && a.dtype != DType::f64)
      fail(path, key + ": expected float32 weights, got dtype '" + a.descr + "'");
    LpipsTensor t;
    t.shape = a.shape;
    t.data = a.as_float();
    for (size_t i = 0; i < t.data.size(); ++i)
      if (!std::isfinite(t.data[i])) fail(path, key + ": non-finite value at flat index " + std::to_string(i));
    w.tensors.emplace(key, std::move(t));
  }
  if (w.tensors.empty())
    fail(path, "no LPIPS arrays (expected keys alex.* or vgg.*; layout in train/lpips.h)");
  return w;
}

}  // namespace haha
