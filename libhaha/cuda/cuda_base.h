// The CUDA layer's base: device detection, error checking that turns CUDA errors
// into haha::Error, and an owning device buffer (cudaMalloc, never managed memory).
//
// Conventions of every launcher in libhaha/cuda:
//   - pointers named in a launcher's contract as "device" point to device memory the caller
//     owns (usually a DeviceBuffer); host structs of the CPU API (GaussianInputs, MeshView,
//     MergeInputs, ...) are reused with device pointers inside;
//   - work runs on the default stream, in issue order; a launcher returns once its kernels
//     are queued unless it must read a size or a value back (said where it does);
//   - the maths is the CPU path's HAHA_HD functions; only the launch and the reduction
//     order differ (atomics make sums order-dependent, hence the parity tolerances).
// This header is plain C++ (the CUDA runtime API is a C API): tests and the CLI include it.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/error.h"

namespace haha::cuda {

// True when a CUDA device can be used (a driver, at least one GPU, and a context can be
// made on it). Never throws; the answer is computed once.
bool cuda_available();
// "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs, 79.2 GiB)", or why no device can be used.
std::string device_description();

// Throws haha::Error "cuda: <what>: <CUDA error name>: <description>" unless err is
// cudaSuccess.
void check(cudaError_t err, const char* what);
// After a kernel launch: reports launch errors (bad configuration, no device) at once;
// faults inside the kernel surface at the next synchronising call.
void check_launch(const char* kernel);
// Waits for all queued work; reports asynchronous faults.
void synchronize(const char* what = "synchronize");

#define HAHA_CUDA_STR2(x) #x
#define HAHA_CUDA_STR(x) HAHA_CUDA_STR2(x)
#define HAHA_CUDA_CHECK(expr) ::haha::cuda::check((expr), #expr " (" __FILE__ ":" HAHA_CUDA_STR(__LINE__) ")")

// Owning, typed device allocation. Not copyable; movable. resize() keeps the allocation
// when it is large enough (contents are then unspecified); it never shrinks. T must be
// trivially copyable (the bytes are moved with cudaMemcpy).
template <class T>
class DeviceBuffer {
  static_assert(std::is_trivially_copyable_v<T>, "DeviceBuffer holds trivially copyable values");

 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(size_t n) { resize(n); }
  explicit DeviceBuffer(const std::vector<T>& host) { upload(host); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept { swap(o); }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    if (this != &o) {
      release();
      swap(o);
    }
    return *this;
  }
  ~DeviceBuffer() { release(); }

  void resize(size_t n) {
    if (n > capacity_) {
      release();
      void* p = nullptr;
      check(cudaMalloc(&p, n * sizeof(T)), "cudaMalloc");
      ptr_ = static_cast<T*>(p);
      capacity_ = n;
    }
    size_ = n;
  }
  // resize(n) and set every byte to zero (all-zero bits is 0 for float/int).
  void assign_zero(size_t n) {
    resize(n);
    zero();
  }
  void zero() {
    if (size_) check(cudaMemsetAsync(ptr_, 0, size_ * sizeof(T)), "cudaMemsetAsync");
  }
  void upload(const T* host, size_t n) {
    resize(n);
    if (n) check(cudaMemcpy(ptr_, host, n * sizeof(T), cudaMemcpyHostToDevice), "cudaMemcpy H2D");
  }
  void upload(const std::vector<T>& host) { upload(host.data(), host.size()); }
  // Copies size() values (or n <= size()) to host memory; waits for queued work first.
  void download(T* host, size_t n) const {
    if (n > size_) fail("cuda", "download of " + std::to_string(n) + " values from a buffer of " + std::to_string(size_));
    if (n) check(cudaMemcpy(host, ptr_, n * sizeof(T), cudaMemcpyDeviceToHost), "cudaMemcpy D2H");
  }
  void download(T* host) const { download(host, size_); }
  std::vector<T> to_host() const {
    std::vector<T> v(size_);
    download(v.data(), size_);
    return v;
  }

  T* data() { return ptr_; }
  const T* data() const { return ptr_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

 private:
  void release() noexcept {
    if (ptr_) cudaFree(ptr_);  // errors here (a dead context) cannot be reported usefully
    ptr_ = nullptr;
    size_ = capacity_ = 0;
  }
  void swap(DeviceBuffer& o) noexcept {
    std::swap(ptr_, o.ptr_);
    std::swap(size_, o.size_);
    std::swap(capacity_, o.capacity_);
  }
  T* ptr_ = nullptr;
  size_t size_ = 0, capacity_ = 0;
};

// Device copy of a host vector, for tests and one-off uploads.
template <class T>
DeviceBuffer<T> to_device(const std::vector<T>& host) {
  return DeviceBuffer<T>(host);
}

}  // namespace haha::cuda
