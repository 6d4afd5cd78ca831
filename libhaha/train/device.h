// Choosing a Device (core/device.h) for `--device cpu|cuda|auto`. The trainer layer (and so
// everything above it) links the CUDA backend whenever the build has one, so this is the one
// place that asks whether it exists.
#pragma once

#include <string>

#include "core/device.h"

namespace haha {

// True when this build has the CUDA backend.
bool cuda_backend_built();

// "cpu", "cuda" or "auto" (cuda where a backend is built and a GPU answers, else cpu;
// case-sensitive). `where` names the option in the error ("--device"). Throws haha::Error
// for an unknown name, for "cuda" without a CUDA backend in this build, and for "cuda" on
// a machine where no CUDA device can be used ("cuda: no usable GPU: <why>").
Device parse_device(const std::string& s, const std::string& where = "--device");

// The GPU in use ("NVIDIA H100 ... (sm_90, ...)"), or why none can be used; empty
// without a CUDA backend.
std::string gpu_description();

}  // namespace haha
