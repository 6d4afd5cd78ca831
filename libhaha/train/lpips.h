// LPIPS (Zhang et al. 2018, the `lpips` package v0.1) on the CPU: AlexNet features for
// the metric, VGG16 features for the optional training loss. Forward and the gradient
// with respect to the first image; plain C++ (direct convolution, register-blocked at
// stride 1, ReLU, max-pool, channel normalisation, 1x1 linear heads, spatial mean).
//
// The network weights are never shipped nor downloaded: the user supplies them (haha
// `--lpips-weights FILE`). Without them LPIPS is OFF and reported as unavailable
// (kLpipsUnavailable), never approximated.
//
// ---- Weight file layout (an .npz; read by app/lpips_weights.h) --------------------------
// One or both backbones, float32 (float64 is converted), torch's layouts:
//   alex.features.{0,3,6,8,10}.weight   (O, I, kh, kw)  conv weights, OIHW
//   alex.features.{0,3,6,8,10}.bias     (O)
//   alex.lin.{0..4}.weight              (1, C, 1, 1)    LPIPS linear heads, C = taps' O
//   vgg.features.{0,2,5,7,10,12,14,17,19,21,24,26,28}.weight / .bias
//   vgg.lin.{0..4}.weight
// Feature indices are torchvision's `features` indices. Strides, paddings and pooling are
// the architecture's (AlexNet: conv0 stride 4 pad 2, conv3 pad 2, others pad 1, max-pool
// 3/2 after taps 0 and 1; VGG16: 3x3 pad 1, max-pool 2/2 between blocks); channel counts
// and kernel sizes come from the file, so a test can use a miniature net.
//
// ---- Recipe to export it (on the user's machine: Python with torch, torchvision, lpips) ---
//   import numpy as np, torch, lpips
//   out = {}
//   for tag in ("alex", "vgg"):
//       m = lpips.LPIPS(net=tag, version="0.1").eval()  # torchvision backbone + LPIPS heads
//       for s in (m.net.slice1, m.net.slice2, m.net.slice3, m.net.slice4, m.net.slice5):
//           for idx, layer in s._modules.items():      # names are torchvision indices
//               if isinstance(layer, torch.nn.Conv2d):
//                   out[f"{tag}.features.{idx}.weight"] = layer.weight.detach().numpy().astype(np.float32)
//                   out[f"{tag}.features.{idx}.bias"] = layer.bias.detach().numpy().astype(np.float32)
//       for i, lin in enumerate(m.lins):
//           out[f"{tag}.lin.{i}.weight"] = lin.model[-1].weight.detach().numpy().astype(np.float32)
//   np.savez("lpips_weights.npz", **out)
// Either backbone may be left out.
//
// ---- What is computed -----------------------------------------------------------------
// Images (H, W, 3) in [0, 1] are mapped to [-1, 1] (lpips normalize=True) and through the
// scaling layer (z - shift) / scale, shift = (-.030, -.088, -.188), scale = (.458, .448,
// .450). For each of the 5 taps l: f = ReLU features, n = f / (|f|_channels + 1e-10),
//   d = sum_l mean_{h,w} sum_c lin_l[c] (n_x - n_y)^2.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace haha {

enum class LpipsBackbone { Alex, Vgg16 };
inline const char* lpips_prefix(LpipsBackbone b) { return b == LpipsBackbone::Alex ? "alex" : "vgg"; }
inline constexpr const char* kLpipsUnavailable =
    "unavailable (no LPIPS weights supplied; see --lpips-weights)";

struct LpipsTensor {
  std::vector<int64_t> shape;
  std::vector<float> data;  // C order, product(shape) values
};

// The weight file's arrays by name; what app/lpips_weights.h returns.
struct LpipsWeights {
  std::string source;  // the file, named in errors
  std::map<std::string, LpipsTensor> tensors;
  bool has_backbone(LpipsBackbone b) const {  // any "<prefix>." key
    const std::string p = std::string(lpips_prefix(b)) + ".";
    auto it = tensors.lower_bound(p);
    return it != tensors.end() && it->first.compare(0, p.size(), p) == 0;
  }
};

// T = float for use, double for finite-difference tests. Not thread-safe (it keeps its
// activation buffers between calls); its loops run in parallel inside.
template <class T>
class LpipsNet {
 public:
  // Throws haha::Error "<source>: <key>: <problem>" for a missing array or a wrong shape
  // (dimension count, channel chain, bias or head length, value count).
  LpipsNet(const LpipsWeights& weights, LpipsBackbone backbone);

  LpipsBackbone backbone() const { return backbone_; }
  // Smallest H = W the architecture accepts with this file's kernel sizes.
  int min_size() const;

  // LPIPS distance between x and y ((H, W, 3), values in [0, 1]); d(x, x) = 0, symmetric.
  // If grad is given, grad += grad_scale * dd/dx (x only). Throws haha::Error if the image
  // is smaller than the network can process.
  T distance(const T* x, const T* y, int H, int W, T* grad = nullptr, T grad_scale = T(1));

 private:
  struct Op {             // a conv (with its ReLU) or a max-pool
    int conv = -1;        // index into convs_, -1 for a pool
    int k = 0, s = 1;     // pool kernel / stride
  };
  struct Conv {
    int out = 0, in = 0, kh = 0, kw = 0, stride = 1, pad = 0;
    std::vector<T> w, b;
    std::vector<T> wt;  // stride 1: flipped (in, out, kh, kw) kernels for the input gradient
  };
  struct Act {  // one activation, planar (C, H, W)
    int c = 0, h = 0, w = 0;
    std::vector<T> v;
    std::vector<int32_t> arg;  // max-pool: flat input index of each output
  };
  bool shapes_ok(int H, int W) const;
  void forward(const T* img, int H, int W, std::vector<Act>& acts);

  LpipsBackbone backbone_;
  std::string source_;
  std::vector<Op> ops_;              // act[i + 1] = ops_[i](act[i]); act[0] = scaled input
  std::vector<Conv> convs_;
  std::vector<int> taps_;            // act index of each tap
  std::vector<std::vector<T>> lin_;  // per tap
  std::vector<Act> ax_, ay_;         // activations of x and y, by op output
  std::vector<T> pad_;               // zero-padded conv input
};

}  // namespace haha
