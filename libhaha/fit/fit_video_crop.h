// The crop of `haha fit-video`'s dataset: the box around the person over the kept frames,
// so that training (which scales the frame's longer side to the preset's resolution) spends
// its pixels on the person, not on the room. The box is the union of two opinions per
// frame: the keypoint tool's mask (mask > 0.5: it covers hair and loose clothes the body
// model has not) and the fitted body's projected vertices (they cover a limb or a hand the
// mask misses); a spurious blob of either only costs resolution, while a part cut off is
// lost to training. Then a margin, clipped to the frame, even sizes (H.264 / yuv420p).
#pragma once

#include "core/image.h"
#include "core/camera.h"

namespace haha {

// [x0, x0 + w) x [y0, y0 + h) in frame pixels; w or h <= 0: empty.
struct CropBox {
  int x0 = 0, y0 = 0, w = 0, h = 0;
  bool empty() const { return w <= 0 || h <= 0; }
  bool operator==(const CropBox& o) const { return x0 == o.x0 && y0 == o.y0 && w == o.w && h == o.h; }
};

// The pixels of a one-channel mask above `threshold` (empty: none).
CropBox mask_box(const Image& mask, float threshold = 0.5f);

// The pixels the projected points (`n` xyz vertices in world space through `cam`) fall in,
// clipped to the frame; points behind the near plane are skipped (empty: none in frame).
CropBox projected_box(const Camera& cam, const float* verts, int n);

// The smallest box holding both (an empty one adds nothing).
CropBox box_union(const CropBox& a, const CropBox& b);

struct CropOptions {
  double margin = 0.1;   // of the box's larger side, on every side
  int min_margin = 4;    // px
};

// The person's box with the margin, clipped to the frame (width x height), with even width
// and height where the frame allows it (odd frame sides stay odd only when the box spans
// them). An empty person box gives the whole frame.
CropBox dataset_crop(const CropBox& person, int width, int height, const CropOptions& opt = {});

// The camera of the cropped frames: same rays, intrinsics shifted (cx -= x0, cy -= y0) and
// the size of the box, so a 3D point lands on the same content pixel.
Camera crop_camera(const Camera& cam, const CropBox& box);

}  // namespace haha
