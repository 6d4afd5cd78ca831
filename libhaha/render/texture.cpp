#include "render/texture.h"

#include <string>

#include "core/error.h"
#include "core/parallel.h"
#include "render/scatter.h"

namespace haha {

namespace {

template <class T>
void check_texture(const TextureViewT<T>& tex, int num_pixels, const T* uv, const char* fn) {
  if (tex.width <= 0 || tex.height <= 0 || tex.channels <= 0 || !tex.data)
    fail(fn, "texture is empty (" + std::to_string(tex.width) + "x" + std::to_string(tex.height) + "x" +
                 std::to_string(tex.channels) + ")");
  if (num_pixels < 0 || (num_pixels > 0 && !uv)) fail(fn, "null uv buffer");
}

}  // namespace

template <class T>
void sample_texture(const TextureViewT<T>& tex, int num_pixels, const int32_t* tri, const T* uv, T* out) {
  check_texture(tex, num_pixels, uv, "sample_texture");
  const int C = tex.channels;
  detail::parallel_items(num_pixels, [&](int64_t p) {
    T* o = out + p * C;
    if (tri && tri[p] < 0) {
      for (int c = 0; c < C; ++c) o[c] = T(0);
      return;
    }
    bilinear_sample(tex, uv[2 * p], uv[2 * p + 1], o);
  });
}

template <class T>
void sample_texture_backward(const TextureViewT<T>& tex, int num_pixels, const int32_t* tri, const T* uv,
                             const NoDeduce<T>* grad_out, NoDeduce<T>* grad_texture, NoDeduce<T>* grad_uv) {
  check_texture(tex, num_pixels, uv, "sample_texture_backward");
  const int C = tex.channels;
  auto one = [&](int64_t p, T* gtex) {
    T gu = 0, gv = 0;
    if (!tri || tri[p] >= 0) bilinear_sample_backward(tex, uv[2 * p], uv[2 * p + 1], grad_out + p * C, gtex, &gu, &gv);
    if (grad_uv) {
      grad_uv[2 * p] = gu;
      grad_uv[2 * p + 1] = gv;
    }
  };
  if (grad_texture)
    detail::scatter_add(num_pixels, int64_t(tex.width) * tex.height * C, grad_texture, one);
  else
    detail::parallel_items(num_pixels, [&](int64_t p) { one(p, nullptr); });
}

template void sample_texture<float>(const TextureViewT<float>&, int, const int32_t*, const float*, float*);
template void sample_texture<double>(const TextureViewT<double>&, int, const int32_t*, const double*, double*);
template void sample_texture_backward<float>(const TextureViewT<float>&, int, const int32_t*, const float*,
                                             const float*, float*, float*);
template void sample_texture_backward<double>(const TextureViewT<double>&, int, const int32_t*, const double*,
                                              const double*, double*, double*);

}  // namespace haha
