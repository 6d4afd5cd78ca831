// The one device type: where a command runs its kernels (`--device cpu|cuda` on train,
// eval, render, render-ply, bench and train_bench; the Trainer's backend). Choosing one
// (parsing, asking whether a GPU answers) is train/device.h, the lowest layer that links
// the CUDA backend.
#pragma once

namespace haha {

enum class Device { cpu, cuda };

inline const char* device_name(Device d) { return d == Device::cuda ? "cuda" : "cpu"; }

}  // namespace haha
