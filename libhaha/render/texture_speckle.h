// Salt-and-pepper in a texture where the video barely looked: the share of chart texels
// whose luminance differs by more than kSpeckleStep from the median of their 5 x 5
// neighbourhood, over the charts of the faces skinned mostly to the neck, the hands and the
// feet (the places a turning video sees rarely or at a grazing angle).
//
// Selection, decided once here:
//   - a face's part is the argmax over joints of its three vertices' summed skin weight:
//     neck = joint 12 (the head, 15, is mostly front-facing and not this measure's concern);
//     hands = wrists 20, 21 and every finger joint 25..54; feet = ankles 7, 8 and feet 10, 11;
//     garment faces (appended after the body) belong to no part;
//   - a texel belongs to a part when its centre lies inside a UV triangle of one of its faces
//     (render/texture_charts.h);
//   - the 5 x 5 neighbourhood counts only chart texels (of any face): gutter texels are not
//     content. Its median is the upper median (element n / 2 of the n sorted values,
//     the texel itself included).
// Luminance: Rec. 709 weights on the stored values (0..1).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "body/body_model.h"
#include "render/texture_charts.h"

namespace haha {

inline constexpr double kSpeckleStep = 0.15;  // luminance, of 1
inline constexpr int kSpeckleRadius = 2;      // 5 x 5

enum SpecklePart { kSpeckleNeck = 0, kSpeckleHands = 1, kSpeckleFeet = 2, kSpeckleParts = 3 };
inline const char* speckle_part_name(int p) { return p == 0 ? "neck" : p == 1 ? "hands" : "feet"; }

struct TextureSpeckle {
  std::array<double, kSpeckleParts> per_mille{};  // speckled texels per 1000 texels of the part
  std::array<int64_t, kSpeckleParts> texels{};    // chart texels of the part
  double all_per_mille = 0;                       // the same over every chart texel (garment included)
  int64_t all_texels = 0;
};

// Per face: its part (SpecklePart) or -1.
std::vector<int8_t> speckle_face_parts(const BodyModel& body);

// The measure on `rgb` (height, width, 3) over `charts` (of the same size). A part without
// texels scores 0 with texels = 0.
TextureSpeckle texture_speckle(const float* rgb, const TextureCharts& charts, const std::vector<int8_t>& face_part);

// The same from the body model and a texture (charts rasterized here). Throws haha::Error
// "texture_speckle: ..." for a texture of the wrong size or a body without a UV map.
TextureSpeckle texture_speckle(const BodyModel& body, const std::vector<float>& rgb, int width, int height);

}  // namespace haha
