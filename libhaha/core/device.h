// Where a command runs its kernels: `--device cpu|cuda` on train, eval, render, render-ply
// and bench. parse_device() turns the option into a Device and refuses `cuda` with one
// clear line when this build has no CUDA backend or the machine has no usable GPU.
//
// Header-only on purpose: haha_core cannot link the CUDA layer, so whether a backend
// exists is decided in the translation unit that includes this, by HAHA_HAS_CUDA (a
// public definition of the haha_cuda target: code linking haha_cuda sees 1). The two
// variants live in different inline namespaces, so a program mixing both kinds of
// translation unit has no ODR clash.
#pragma once

#include <string>

#include "core/error.h"

#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
namespace haha::cuda {
bool cuda_available();             // cuda/runtime.h
std::string device_description();  // cuda/runtime.h
}  // namespace haha::cuda
#define HAHA_DEVICE_NS device_with_cuda
#else
#define HAHA_DEVICE_NS device_without_cuda
#endif

namespace haha {

enum class Device { cpu, cuda };

inline const char* device_name(Device d) { return d == Device::cuda ? "cuda" : "cpu"; }

inline namespace HAHA_DEVICE_NS {

// True when this translation unit was built with the CUDA backend linked in.
inline bool cuda_backend_built() {
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
  return true;
#else
  return false;
#endif
}

// "cpu" or "cuda" (case-sensitive). `where` names the option in the error ("--device").
// Throws haha::Error for an unknown name, for "cuda" without a CUDA backend in this build,
// and for "cuda" on a machine where no CUDA device can be used (no driver, no GPU).
inline Device parse_device(const std::string& s, const std::string& where = "--device") {
  if (s == "cpu") return Device::cpu;
  if (s != "cuda") fail(where, "unknown device '" + s + "' (expected cpu or cuda)");
#if defined(HAHA_HAS_CUDA) && HAHA_HAS_CUDA
  if (!cuda::cuda_available()) fail(where, "no CUDA device found (" + cuda::device_description() + ")");
  return Device::cuda;
#else
  fail(where, "cuda requested but this build has no CUDA backend (configure with nvcc on PATH and HAHA_WITH_CUDA=ON)");
#endif
}

}  // namespace HAHA_DEVICE_NS
}  // namespace haha

#undef HAHA_DEVICE_NS
