#include "cuda/cuda_base.h"

#include <cstdio>
#include <mutex>
#include <string>

namespace haha::cuda {

namespace {

struct Probe {
  bool ok = false;
  std::string text;
};

// Asks the runtime once. Without a driver cudaGetDeviceCount returns an error (e.g.
// cudaErrorInsufficientDriver / cudaErrorNoDevice) rather than crashing; cudaFree(0)
// then makes the context, which is where a broken driver or a busy exclusive GPU shows.
const Probe& probe() {
  static Probe p;
  static std::once_flag once;
  std::call_once(once, [] {
    int n = 0;
    cudaError_t e = cudaGetDeviceCount(&n);
    if (e != cudaSuccess) {
      p.text = std::string("no CUDA device: ") + cudaGetErrorName(e) + ": " + cudaGetErrorString(e);
      cudaGetLastError();  // clear the sticky-free error state
      return;
    }
    if (n == 0) {
      p.text = "no CUDA device: the driver reports 0 devices";
      return;
    }
    e = cudaFree(nullptr);
    if (e != cudaSuccess) {
      p.text = std::string("CUDA device unusable: ") + cudaGetErrorName(e) + ": " + cudaGetErrorString(e);
      cudaGetLastError();
      return;
    }
    int dev = 0;
    cudaDeviceProp prop{};
    if (cudaGetDevice(&dev) != cudaSuccess || cudaGetDeviceProperties(&prop, dev) != cudaSuccess) {
      p.text = "CUDA device unusable: cannot read its properties";
      cudaGetLastError();
      return;
    }
    char buf[512];
    std::snprintf(buf, sizeof buf, "%s (sm_%d%d, %d SMs, %.1f GiB)", prop.name, prop.major, prop.minor,
                  prop.multiProcessorCount, double(prop.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0));
    p.text = buf;
    p.ok = true;
  });
  return p;
}

}  // namespace

bool cuda_available() { return probe().ok; }

std::string device_description() { return probe().text; }

void check(cudaError_t err, const char* what) {
  if (err == cudaSuccess) return;
  fail("cuda", std::string(what) + ": " + cudaGetErrorName(err) + ": " + cudaGetErrorString(err));
}

void check_launch(const char* kernel) { check(cudaGetLastError(), kernel); }

void synchronize(const char* what) { check(cudaDeviceSynchronize(), what); }

}  // namespace haha::cuda
