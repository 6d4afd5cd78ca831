// SMPL-X LBS on the GPU: the per-vertex kernels of body/lbs_kernels.h, one thread per
// vertex; the 55-joint chain (forward and backward) runs on the host with the CPU path's
// functions, as the CPU launcher does. The backward sums the per-vertex contributions
// (dA, dfeature, dcoefficient, dtransl) in shared memory and then globally with atomics,
// reads the ~1.2k sums back and finishes the chain on the host.
#pragma once

#include <string>

#include "body/body_model.h"
#include "body/lbs.h"
#include "body/lbs_kernels.h"
#include "cuda/cuda_base.h"

namespace haha::cuda {

// What a forward leaves for its backward.
struct LbsCudaCache {
  LbsCache<float> chain;        // host: rest joints, rotations, chained transforms, features
  DeviceBuffer<float> v_posed;  // device (V, 3): shaped vertices + pose correctives
};

class LbsCuda {
 public:
  // Validates and precomputes exactly as Lbs<float> (same errors), then uploads.
  explicit LbsCuda(const BodyModel& model);

  // One frame. p: host values (as for Lbs). verts: device (V, 3) output. joints: host
  // (55, 3) output or null. cache: kept for backward when non-null. Queues the kernel
  // and returns (the parameter upload waits for earlier work on the stream).
  void forward(const SmplxView<float>& p, float* verts, float* joints, LbsCudaCache* cache);

  // d_verts: device (V, 3) dL/dverts or null; d_joints: host (55, 3) or null. ADDS
  // dL/d(pose, betas, expression, transl) into grad (host, sized by make_grad). Reads the
  // per-vertex sums back (synchronises).
  void backward(const SmplxView<float>& p, const LbsCudaCache& cache, const float* d_verts, const float* d_joints,
                SmplxGrad<float>& grad);

  int num_verts() const { return host_.V; }

 private:
  void upload_frame(const SmplxView<float>& p, const LbsCache<float>& chain, LbsFrameView<float>& f);
  LbsModelView<float> device_view() const;

  LbsModelData<float> host_;
  std::string where_;
  DeviceBuffer<float> v_template_, shapedirs_, w_val_, p_data_;
  DeviceBuffer<int32_t> w_off_, w_joint_, p_off_, p_feat_;
  DeviceBuffer<float> frame_;     // betas | expression | features (486) | A (660)
  DeviceBuffer<float> v_shaped_;  // (V, 3) scratch
  DeviceBuffer<float> acc_;       // per-vertex sums of the backward
};

}  // namespace haha::cuda
