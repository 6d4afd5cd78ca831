#include "train/device.h"

#include "core/error.h"

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
#include "cuda/cuda_base.h"
#endif

namespace haha {

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
bool cuda_backend_built() { return true; }
std::string gpu_description() { return cuda::device_description(); }
#else
bool cuda_backend_built() { return false; }
std::string gpu_description() { return ""; }
#endif

Device parse_device(const std::string& s, const std::string& where) {
  if (s == "cpu") return Device::cpu;
  if (s != "cuda" && s != "auto") fail(where, "unknown device '" + s + "' (expected cpu, cuda or auto)");
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
  const bool usable = cuda::cuda_available();
  if (s == "auto") return usable ? Device::cuda : Device::cpu;
  if (!usable) fail("cuda", "no usable GPU: " + cuda::device_description());
  return Device::cuda;
#else
  if (s == "auto") return Device::cpu;
  fail(where, "cuda requested but this build has no CUDA backend (configure with nvcc on PATH and HAHA_WITH_CUDA=ON)");
#endif
}

}  // namespace haha
