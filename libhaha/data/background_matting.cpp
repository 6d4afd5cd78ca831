#include "data/background_matting.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"
#include "core/parallel.h"

namespace haha {

namespace {

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

uint8_t to_8bit(float v) { return uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }

// Index of the nearest seed pixel for every pixel, -1 where there is no seed: two raster
// passes that take a neighbour's nearest seed when it is closer (8SSEDT; within a pixel of
// the exact Euclidean answer, linear in the pixels).
std::vector<int32_t> nearest_seed(const std::vector<uint8_t>& seed, int W, int H) {
  std::vector<int32_t> near(size_t(W) * H, -1);
  for (size_t p = 0; p < near.size(); ++p)
    if (seed[p]) near[p] = int32_t(p);
  auto d2 = [W](int x, int y, int32_t s) {
    const int64_t dx = x - s % W, dy = y - s / W;
    return dx * dx + dy * dy;
  };
  auto relax = [&](int x, int y, int nx, int ny) {
    if (nx < 0 || ny < 0 || nx >= W || ny >= H) return;
    const int32_t s = near[size_t(ny) * W + nx];
    if (s < 0) return;
    int32_t& cur = near[size_t(y) * W + x];
    if (cur < 0 || d2(x, y, s) < d2(x, y, cur)) cur = s;
  };
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      relax(x, y, x - 1, y);
      relax(x, y, x - 1, y - 1);
      relax(x, y, x, y - 1);
      relax(x, y, x + 1, y - 1);
    }
    for (int x = W - 1; x >= 0; --x) relax(x, y, x + 1, y);
  }
  for (int y = H - 1; y >= 0; --y) {
    for (int x = W - 1; x >= 0; --x) {
      relax(x, y, x + 1, y);
      relax(x, y, x + 1, y + 1);
      relax(x, y, x, y + 1);
      relax(x, y, x - 1, y + 1);
    }
    for (int x = 0; x < W; ++x) relax(x, y, x - 1, y);
  }
  return near;
}

// Squared distance from pixel p to its nearest seed (max when none).
int64_t seed_d2(const std::vector<int32_t>& near, size_t p, int W) {
  const int32_t s = near[p];
  if (s < 0) return std::numeric_limits<int64_t>::max();
  const int64_t dx = int64_t(p % size_t(W)) - s % W, dy = int64_t(p / size_t(W)) - s / W;
  return dx * dx + dy * dy;
}

// Median of a histogram (the lower one for an even count); -1 for an empty one.
int histogram_median(const std::vector<int64_t>& h) {
  int64_t n = 0;
  for (int64_t c : h) n += c;
  if (n == 0) return -1;
  int64_t seen = 0;
  for (size_t v = 0; v < h.size(); ++v)
    if ((seen += h[v]) * 2 >= n) return int(v);
  return int(h.size()) - 1;
}

}  // namespace

int matting_band_px(int width, int height) {
  return std::max(3, int(std::lround(std::max(width, height) / 200.0)));
}

// ---------------------------------------------------------------------------------------
// The plate

BackgroundPlateBuilder::BackgroundPlateBuilder(int width, int height, const MattingOptions& opt)
    : w_(width), h_(height), opt_(opt) {
  if (width < 1 || height < 1) fail("background plate", "frame size " + size_text(width, height) + " out of range");
  const int band = opt.band_px > 0 ? opt.band_px : matting_band_px(width, height);
  dilate_ = opt.plate_dilate_px > 0 ? opt.plate_dilate_px : 2 * band;
}

void BackgroundPlateBuilder::reserve(int frames) {
  const size_t P = size_t(w_) * h_;
  rgb_.reserve(size_t(std::max(0, frames)) * P * 3);
  cover_.reserve(size_t(std::max(0, frames)) * P);
}

void BackgroundPlateBuilder::add(const Image& rgb, const Image& mask) {
  if (rgb.width != w_ || rgb.height != h_ || rgb.channels != 3)
    fail("background plate", "frame " + std::to_string(n_) + " is " + size_text(rgb.width, rgb.height) + "x" +
                                 std::to_string(rgb.channels) + ", expected " + size_text(w_, h_) + " RGB");
  if (!mask.empty() && (mask.width != w_ || mask.height != h_ || mask.channels != 1))
    fail("background plate", "mask " + std::to_string(n_) + " is " + size_text(mask.width, mask.height) + "x" +
                                 std::to_string(mask.channels) + ", expected " + size_text(w_, h_) +
                                 " with one channel");
  const size_t P = size_t(w_) * h_;
  rgb_.resize((size_t(n_) + 1) * P * 3);
  cover_.resize((size_t(n_) + 1) * P, 0);
  uint8_t* px = &rgb_[size_t(n_) * P * 3];
  for (size_t k = 0; k < P * 3; ++k) px[k] = to_8bit(rgb.data[k]);
  uint8_t* cov = &cover_[size_t(n_) * P];
  if (!mask.empty()) {
    std::vector<uint8_t> person(P);
    for (size_t p = 0; p < P; ++p) person[p] = mask.data[p] > opt_.cover_threshold;
    const std::vector<int32_t> near = nearest_seed(person, w_, h_);
    const int64_t r2 = int64_t(dilate_) * dilate_;
    for (size_t p = 0; p < P; ++p) cov[p] = seed_d2(near, p, w_) <= r2;
  }
  ++n_;
}

BackgroundPlate BackgroundPlateBuilder::build() const {
  BackgroundPlate b;
  b.width = w_;
  b.height = h_;
  b.frames = n_;
  b.rgb = Image(w_, h_, 3);
  const size_t P = size_t(w_) * h_;
  b.known.assign(P, 0);
  // Row by row: the row of every frame copied together (the frames lie P * 3 bytes apart).
  parallel_for_dynamic(h_, [&](int64_t y) {
    std::vector<uint8_t> samples[3];
    for (auto& s : samples) s.reserve(size_t(n_));
    for (int x = 0; x < w_; ++x) {
      const size_t p = size_t(y) * w_ + x;
      for (auto& s : samples) s.clear();
      for (int f = 0; f < n_; ++f) {
        if (cover_[size_t(f) * P + p]) continue;
        const uint8_t* v = &rgb_[(size_t(f) * P + p) * 3];
        for (int c = 0; c < 3; ++c) samples[c].push_back(v[c]);
      }
      if (samples[0].empty()) continue;
      b.known[p] = 1;
      for (int c = 0; c < 3; ++c) {
        auto& s = samples[c];
        const size_t mid = (s.size() - 1) / 2;
        std::nth_element(s.begin(), s.begin() + std::ptrdiff_t(mid), s.end());
        b.rgb.at(x, int(y), c) = float(s[mid]) / 255.0f;
      }
    }
  });
  size_t holes = 0;
  for (uint8_t k : b.known) holes += !k;
  b.hole_share = P ? double(holes) / double(P) : 0.0;

  // Per frame: the median over its uncovered pixels of the mean |I - B| (in 1/255 steps).
  std::vector<uint8_t> plate8(P * 3);  // the residual: seen pixels only (the fill comes below)
  for (size_t k = 0; k < P * 3; ++k) plate8[k] = to_8bit(b.rgb.data[k]);
  b.frame_residual.assign(size_t(n_), NAN);
  parallel_for_dynamic(n_, [&](int64_t f) {
    std::vector<int64_t> hist(3 * 255 + 1);  // of the summed |I - B| over RGB, in 1/255 steps
    const uint8_t* px = &rgb_[size_t(f) * P * 3];
    const uint8_t* cov = &cover_[size_t(f) * P];
    for (size_t p = 0; p < P; ++p) {
      if (cov[p] || !b.known[p]) continue;
      int d = 0;
      for (int c = 0; c < 3; ++c) d += std::abs(int(px[p * 3 + c]) - int(plate8[p * 3 + c]));
      ++hist[size_t(d)];
    }
    const int m = histogram_median(hist);
    if (m >= 0) b.frame_residual[size_t(f)] = m / (3 * 255.0);
  });
  std::vector<double> r;
  for (double v : b.frame_residual)
    if (std::isfinite(v)) r.push_back(v);
  if (!r.empty()) {
    std::sort(r.begin(), r.end());
    b.residual = r[(r.size() - 1) / 2];
  }

  // Holes near seen pixels take the nearest seen pixel's colour where the seen background
  // around that pixel is smooth (a plain wall: the fill is right); next to texture or an
  // edge (a tiled floor, a door frame) they stay holes.
  const int band = opt_.band_px > 0 ? opt_.band_px : matting_band_px(w_, h_);
  const int fill = opt_.fill_px > 0 ? opt_.fill_px : 10 * band, around = 2 * band;
  std::vector<uint8_t> seen(P);
  for (size_t p = 0; p < P; ++p) seen[p] = b.known[p] == 1;
  const std::vector<int32_t> near = nearest_seed(seen, w_, h_);
  std::vector<int8_t> smooth(P, -1);  // per seen pixel: -1 not yet asked, 0 / 1
  auto is_smooth = [&](int32_t s) {
    if (smooth[size_t(s)] < 0) {
      const int sx = s % w_, sy = s / w_;
      bool ok = true;
      for (int y = std::max(0, sy - around); ok && y <= std::min(h_ - 1, sy + around); ++y)
        for (int x = std::max(0, sx - around); ok && x <= std::min(w_ - 1, sx + around); ++x)
          if (seen[size_t(y) * w_ + x])
            for (int c = 0; c < 3; ++c)
              ok = ok && std::abs(b.rgb.at(x, y, c) - b.rgb.at(sx, sy, c)) <= opt_.fill_smooth;
      smooth[size_t(s)] = ok;
    }
    return smooth[size_t(s)] == 1;
  };
  size_t filled = 0;
  const int64_t fill2 = int64_t(fill) * fill;
  for (size_t p = 0; p < P; ++p) {
    if (b.known[p] || seed_d2(near, p, w_) > fill2 || !is_smooth(near[p])) continue;
    b.known[p] = 2;
    for (int c = 0; c < 3; ++c) b.rgb.data[p * 3 + c] = b.rgb.data[size_t(near[p]) * 3 + c];
    ++filled;
  }
  b.filled_share = P ? double(filled) / double(P) : 0.0;
  return b;
}

// ---------------------------------------------------------------------------------------
// The matte

Matte refine_matte(const Image& rgb, const Image& mask, const BackgroundPlate& plate, const MattingOptions& opt) {
  const int W = rgb.width, H = rgb.height;
  if (rgb.channels != 3) fail("matting", "frame has " + std::to_string(rgb.channels) + " channels, expected RGB");
  if (mask.width != W || mask.height != H || mask.channels != 1)
    fail("matting", "mask is " + size_text(mask.width, mask.height) + "x" + std::to_string(mask.channels) +
                        ", the frame " + size_text(W, H) + " (one channel expected)");
  const bool have_plate = !plate.rgb.empty();
  if (have_plate && (plate.width != W || plate.height != H || plate.rgb.width != W || plate.rgb.height != H ||
                     plate.known.size() != size_t(W) * H))
    fail("matting", "background plate is " + size_text(plate.width, plate.height) + ", the frame " + size_text(W, H));
  const size_t P = size_t(W) * H;
  Matte m;
  m.alpha = Image(W, H, 1);
  m.premultiplied = Image(W, H, 3);
  if (!have_plate) {  // the tool's mask as it is
    m.alpha = mask;
    for (size_t p = 0; p < P; ++p)
      for (int c = 0; c < 3; ++c) m.premultiplied.data[p * 3 + c] = mask.data[p] * rgb.data[p * 3 + c];
    return m;
  }
  const int r = opt.band_px > 0 ? opt.band_px : matting_band_px(W, H);
  const int64_t r2 = int64_t(r) * r;
  std::vector<uint8_t> person(P), background(P);
  for (size_t p = 0; p < P; ++p) {
    person[p] = mask.data[p] > 0.5f;
    background[p] = !person[p];
  }
  const std::vector<int32_t> to_person = nearest_seed(person, W, H);
  const std::vector<int32_t> to_background = nearest_seed(background, W, H);
  // F comes from the nearest core pixel (the mask eroded by the whole band: clear of a
  // mask that is a few pixels too wide); where that is more than 3 bands away (a thin limb
  // has no core), from the nearest pixel of the mask eroded by half the band; else nothing
  // local is known and the tool's mask stays.
  std::vector<uint8_t> core(P), half(P);
  const int64_t half2 = int64_t((r + 1) / 2) * ((r + 1) / 2);
  for (size_t p = 0; p < P; ++p) {
    const int64_t d2 = person[p] ? seed_d2(to_background, p, W) : 0;
    core[p] = d2 > r2;
    half[p] = d2 > half2;
  }
  const std::vector<int32_t> to_core = nearest_seed(core, W, H), to_half = nearest_seed(half, W, H);
  const int64_t far2 = 9 * r2;
  auto foreground_of = [&](size_t p) -> int32_t {
    if (to_core[p] >= 0 && seed_d2(to_core, p, W) <= far2) return to_core[p];
    if (to_half[p] >= 0 && seed_d2(to_half, p, W) <= far2) return to_half[p];
    return -1;
  };

  size_t band = 0, band_known = 0, band_filled = 0;
  const float lo = 0.05f, hi = 0.95f;  // a dead zone at both ends: codec noise is not a veil of alpha
  for (size_t p = 0; p < P; ++p) {
    const float* I = &rgb.data[p * 3];
    float* out = &m.premultiplied.data[p * 3];
    float& a = m.alpha.data[p];
    if (core[p]) {
      a = 1.0f;
      for (int c = 0; c < 3; ++c) out[c] = I[c];
      continue;
    }
    if (seed_d2(to_person, p, W) > r2) {  // outside the dilated mask
      a = 0.0f;
      continue;
    }
    ++band;
    const float tool = mask.data[p];
    if (!plate.known[p]) {  // a hole of the plate: the tool's mask
      a = tool;
      for (int c = 0; c < 3; ++c) out[c] = tool * I[c];
      continue;
    }
    ++band_known;
    band_filled += plate.known[p] == 2;
    const float* B = &plate.rgb.data[p * 3];
    float est = tool, w = 0.0f;
    if (const int32_t q = foreground_of(p); q >= 0) {
      const float* F = &rgb.data[size_t(q) * 3];
      float num = 0, den = 0;
      for (int c = 0; c < 3; ++c) {
        num += (I[c] - B[c]) * (F[c] - B[c]);
        den += (F[c] - B[c]) * (F[c] - B[c]);
      }
      const float contrast = std::sqrt(den);
      w = std::clamp((contrast - 0.5f * opt.min_contrast) / (0.5f * opt.min_contrast), 0.0f, 1.0f);
      if (den > 0) est = std::clamp((std::clamp(num / den, 0.0f, 1.0f) - lo) / (hi - lo), 0.0f, 1.0f);
    }
    a = w * est + (1.0f - w) * tool;
    for (int c = 0; c < 3; ++c) out[c] = std::clamp(I[c] - (1.0f - a) * B[c], 0.0f, a);
  }
  m.band_share = P ? double(band) / double(P) : 0.0;
  m.band_known = band ? double(band_known) / double(band) : 0.0;
  m.band_filled = band ? double(band_filled) / double(band) : 0.0;
  return m;
}

}  // namespace haha
