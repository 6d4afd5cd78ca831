#include "render/merge.h"

#include "core/error.h"
#include "core/parallel.h"
#include "render/scatter.h"

namespace haha {

namespace {

template <class T>
void check_merge(const MergeInputsT<T>& in, const char* fn) {
  if (in.num_pixels < 0) fail(fn, "negative pixel count");
  if (in.mesh_mask && !in.mesh_color) fail(fn, "mesh mask given without mesh colour");
}

}  // namespace

template <class T>
void merge(const MergeInputsT<T>& in, T* out) {
  check_merge(in, "merge");
  detail::parallel_items(in.num_pixels, [&](int64_t p) { merge_pixel(in, p, out); });
}

template <class T>
void merge_backward(const MergeInputsT<T>& in, const T* grad_out, const MergeGradsT<T>& grads) {
  check_merge(in, "merge_backward");
  const bool bg_colour = !in.background && grads.background_color;
  T scratch[3] = {T(0), T(0), T(0)};
  T* bg_dst = bg_colour ? grads.background_color : scratch;
  detail::scatter_add(in.num_pixels, 3, bg_dst,
                      [&](int64_t p, T* gbg) { merge_backward_pixel(in, p, grad_out, grads, bg_colour, gbg); });
}

template void merge<float>(const MergeInputsT<float>&, float*);
template void merge<double>(const MergeInputsT<double>&, double*);
template void merge_backward<float>(const MergeInputsT<float>&, const float*, const MergeGradsT<float>&);
template void merge_backward<double>(const MergeInputsT<double>&, const double*, const MergeGradsT<double>&);

}  // namespace haha
