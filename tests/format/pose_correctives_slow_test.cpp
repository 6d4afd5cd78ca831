// Bytes against reposing error of the compact pose correctives (format/pose_correctives_codec.h)
// over a grid of threshold / rank / bits, on the procedural body (sparse, rank-1 blocks per
// joint) and on the dense stand-in for SMPL-X (tests/support/format_dense_correctives.h).
// Error: posed vertices (LBS in double) with the decoded correctives against the exact
// ones, over generic poses (every joint's axis-angle ~ N(0, 0.35 rad) per component).
// Prints the table docs/results.md's storage section quotes.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "format/pose_correctives_codec.h"
#include "support/format_dense_correctives.h"

namespace haha {
namespace {

std::vector<SmplxParams> generic_poses(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.0f, 0.35f);
  std::vector<SmplxParams> out(static_cast<size_t>(n));
  for (SmplxParams& p : out)
    for (size_t i = 3; i < p.pose.size(); ++i) p.pose[i] = g(rng);  // global orientation: no effect on offsets
  return out;
}

struct PosedError {
  double rms_mm = 0, max_mm = 0;
};

std::vector<std::vector<double>> posed(const BodyModel& b, const std::vector<SmplxParams>& poses) {
  Lbs<double> lbs(b);
  std::vector<std::vector<double>> out;
  for (const SmplxParams& p : poses) {
    std::vector<double> v(size_t(b.num_verts) * 3), j(size_t(kNumJoints) * 3);
    lbs.forward(p, v.data(), j.data(), nullptr);
    out.push_back(std::move(v));
  }
  return out;
}

PosedError error_vs(const std::vector<std::vector<double>>& ref, const std::vector<std::vector<double>>& got) {
  PosedError e;
  double se = 0;
  size_t n = 0;
  for (size_t p = 0; p < ref.size(); ++p)
    for (size_t v = 0; v < ref[p].size() / 3; ++v) {
      double d2 = 0;
      for (int c = 0; c < 3; ++c) d2 += (ref[p][v * 3 + c] - got[p][v * 3 + c]) * (ref[p][v * 3 + c] - got[p][v * 3 + c]);
      se += d2;
      ++n;
      e.max_mm = std::max(e.max_mm, 1000.0 * std::sqrt(d2));
    }
  e.rms_mm = 1000.0 * std::sqrt(se / double(n));
  return e;
}

// One row per codec; returns the RMS errors in grid order.
std::vector<double> sweep(const char* name, const BodyModel& body, const std::vector<PoseCorrectiveCodec>& grid,
                          double* default_rms, double* uncorrected_rms, size_t* default_bytes) {
  std::vector<double> rms;
  const std::vector<SmplxParams> poses = generic_poses(12, 11);
  const auto ref = posed(body, poses);
  BodyModel plain = body;
  plain.posedirs.clear();
  const PosedError none = error_vs(ref, posed(plain, poses));
  *uncorrected_rms = none.rms_mm;
  std::printf("\n%s: %d vertices; dense int16 %zu B; without correctives: RMS %.3f mm, max %.3f mm (12 generic poses)\n", name,
              body.num_verts, body.posedirs.size() * 2 + 486 * 4, none.rms_mm, none.max_mm);
  std::printf("| threshold | rank (stored) | energy | bits | blocks kept | bytes | RMS mm | max mm |\n|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  const PoseCorrectiveCodec def;
  for (const PoseCorrectiveCodec& c : grid) {
    const EncodedPoseCorrectives e = encode_pose_correctives(body.posedirs, body.num_verts, c);
    BodyModel dec = body;
    dec.posedirs = decode_pose_correctives(e.draco.data(), e.draco.size(), e.count, e.rank, e.ids.data(), e.mixing.data(),
                                           body.num_verts, "test", "correctives");
    const PosedError err = error_vs(ref, posed(dec, poses));
    rms.push_back(err.rms_mm);
    const size_t bytes = e.draco.size() + e.mixing.size() * 4;
    const bool is_default = c.threshold == def.threshold && c.rank == def.rank && c.bits == def.bits && c.energy == def.energy;
    std::printf("| %g | %d (%d) | %g | %d | %d | %zu | %.4f | %.4f |%s\n", c.threshold, c.rank, e.rank, c.energy, c.bits, e.count, bytes, err.rms_mm,
                err.max_mm, is_default ? " default" : "");
    if (is_default) {
      *default_rms = err.rms_mm;
      *default_bytes = bytes;
    }
  }
  return rms;
}

std::vector<PoseCorrectiveCodec> grid(std::initializer_list<double> ts, std::initializer_list<int> rs, std::initializer_list<int> bs) {
  std::vector<PoseCorrectiveCodec> g;
  for (double t : ts)
    for (int r : rs)
      for (int b : bs) {
        PoseCorrectiveCodec c;
        c.threshold = t;
        c.rank = r;
        c.bits = b;
        g.push_back(c);
      }
  return g;
}

TEST(PoseCorrectivesSlow, BytesAgainstError) {
  const auto t0 = std::chrono::steady_clock::now();
  const PoseCorrectiveCodec def;
  BodyModel procedural = make_procedural_body();
  double rms = -1, none = 0;
  size_t bytes = 0;
  auto g = grid({0.02, 0.1, 0.3}, {1}, {4, 6, 8});
  g.push_back(def);
  sweep("procedural body", procedural, g, &rms, &none, &bytes);
  // The correctives must do their job at the default: most of the uncorrected error gone,
  // at a small fraction of the dense encoding.
  EXPECT_LT(rms, 0.25 * none);
  EXPECT_LT(bytes, procedural.posedirs.size() * 2 / 100);

  BodyModel dense = procedural;
  test::add_dense_pose_correctives(dense);
  rms = -1;
  g = grid({0.02, 0.05, 0.1}, {1, 2, 3, 5}, {6, 8});
  g.push_back(def);
  const std::vector<double> err = sweep("dense stand-in", dense, g, &rms, &none, &bytes);
  // More rows per joint approximate the dense blocks better (t = 0.05, 6 bits: r = 1, 2, 3, 5).
  for (int r = 1; r < 4; ++r) EXPECT_LT(err[size_t(8 + 2 * r)], err[size_t(8 + 2 * (r - 1))]);
  EXPECT_LT(rms, none);
  std::printf("\n(%.1f s)\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

}  // namespace
}  // namespace haha
