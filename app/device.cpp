#include "app/device.h"

#include "core/error.h"

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
#include "cuda/runtime.h"
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
  if (s != "cuda") fail(where, "unknown device '" + s + "' (expected cpu or cuda)");
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
  if (!cuda::cuda_available()) fail(where, "no CUDA device found (" + cuda::device_description() + ")");
  return Device::cuda;
#else
  fail(where, "cuda requested but this build has no CUDA backend (configure with nvcc on PATH and HAHA_WITH_CUDA=ON)");
#endif
}

}  // namespace haha
