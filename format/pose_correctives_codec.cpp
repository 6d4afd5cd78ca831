#include "format/pose_correctives_codec.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "body/body_model.h"
#include "core/error.h"
#include "format/draco_io.h"

namespace haha {

namespace {

constexpr int kBlocks = kNumJoints - 1;  // joints 1..54 have pose features
using Mat9 = std::array<double, 81>;

// Eigen-decomposition of a symmetric 9 x 9 matrix by cyclic Jacobi rotations; eigenvalues
// descending, eigenvector k in row k of `vecs`. Exact enough in double for 9 x 9.
void symmetric_eigen9(Mat9 a, std::array<double, 9>& vals, Mat9& vecs) {
  Mat9 v{};
  for (int i = 0; i < 9; ++i) v[size_t(i) * 9 + i] = 1.0;
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0, diag = 0;
    for (int p = 0; p < 9; ++p) {
      diag += a[size_t(p) * 10] * a[size_t(p) * 10];
      for (int q = p + 1; q < 9; ++q) off += a[size_t(p) * 9 + q] * a[size_t(p) * 9 + q];
    }
    if (off <= 1e-30 * diag || off == 0) break;
    for (int p = 0; p < 9; ++p)
      for (int q = p + 1; q < 9; ++q) {
        const double apq = a[size_t(p) * 9 + q];
        if (apq == 0) continue;
        const double theta = (a[size_t(q) * 10] - a[size_t(p) * 10]) / (2 * apq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 9; ++k) {  // a <- J^T a J
          const double akp = a[size_t(k) * 9 + p], akq = a[size_t(k) * 9 + q];
          a[size_t(k) * 9 + p] = c * akp - s * akq;
          a[size_t(k) * 9 + q] = s * akp + c * akq;
        }
        for (int k = 0; k < 9; ++k) {
          const double apk = a[size_t(p) * 9 + k], aqk = a[size_t(q) * 9 + k];
          a[size_t(p) * 9 + k] = c * apk - s * aqk;
          a[size_t(q) * 9 + k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 9; ++k) {
          const double vkp = v[size_t(k) * 9 + p], vkq = v[size_t(k) * 9 + q];
          v[size_t(k) * 9 + p] = c * vkp - s * vkq;
          v[size_t(k) * 9 + q] = s * vkp + c * vkq;
        }
      }
  }
  std::array<int, 9> idx;
  for (int i = 0; i < 9; ++i) idx[size_t(i)] = i;
  std::sort(idx.begin(), idx.end(), [&](int x, int y) { return a[size_t(x) * 10] > a[size_t(y) * 10]; });
  for (int k = 0; k < 9; ++k) {
    vals[size_t(k)] = a[size_t(idx[size_t(k)]) * 10];
    for (int i = 0; i < 9; ++i) vecs[size_t(k) * 9 + i] = v[size_t(i) * 9 + idx[size_t(k)]];
  }
}

// Solves the r x r symmetric positive semi-definite system M x = b (Gaussian elimination
// with partial pivoting); false if singular.
bool solve_small(std::vector<double> M, std::vector<double>& b, int r, int nrhs) {
  for (int c = 0; c < r; ++c) {
    int p = c;
    for (int i = c + 1; i < r; ++i)
      if (std::fabs(M[size_t(i) * r + c]) > std::fabs(M[size_t(p) * r + c])) p = i;
    if (!(std::fabs(M[size_t(p) * r + c]) > 1e-300)) return false;
    for (int k = 0; k < r; ++k) std::swap(M[size_t(c) * r + k], M[size_t(p) * r + k]);
    for (int k = 0; k < nrhs; ++k) std::swap(b[size_t(c) * nrhs + k], b[size_t(p) * nrhs + k]);
    for (int i = c + 1; i < r; ++i) {
      const double f = M[size_t(i) * r + c] / M[size_t(c) * r + c];
      for (int k = c; k < r; ++k) M[size_t(i) * r + k] -= f * M[size_t(c) * r + k];
      for (int k = 0; k < nrhs; ++k) b[size_t(i) * nrhs + k] -= f * b[size_t(c) * nrhs + k];
    }
  }
  for (int c = r - 1; c >= 0; --c)
    for (int k = 0; k < nrhs; ++k) {
      double s = b[size_t(c) * nrhs + k];
      for (int i = c + 1; i < r; ++i) s -= M[size_t(c) * r + i] * b[size_t(i) * nrhs + k];
      b[size_t(c) * nrhs + k] = s / M[size_t(c) * r + c];
    }
  return true;
}

// Whether Draco predicts each coefficient from the previous point's (delta coding).
// Measured on the procedural body (5,408 blocks, rank 1, 6 bits): 7,880 B with, 11,350 B
// without (neighbouring vertices of a joint have similar blocks).
constexpr bool kPredictCoefficients = true;

// (count, 3, rank) coefficients from COEF_X / COEF_Y / COEF_Z.
std::vector<float> coefficients(const dracoio::Decoded& dec, const int* ids, int rank) {
  const char* names[3] = {"COEF_X", "COEF_Y", "COEF_Z"};
  const int n = dec.num_points();
  std::vector<float> out(size_t(n) * 3 * size_t(rank));
  for (int c = 0; c < 3; ++c) {
    const std::vector<float> v = dec.floats(ids[2 + c], rank, names[c]);
    for (int p = 0; p < n; ++p)
      for (int k = 0; k < rank; ++k) out[(size_t(p) * 3 + size_t(c)) * rank + size_t(k)] = v[size_t(p) * rank + size_t(k)];
  }
  return out;
}

const float* block(const std::vector<float>& pd, int v, int c, int j) {
  return pd.data() + (size_t(3) * v + c) * kNumPoseFeatures + 9 * (j - 1);
}

}  // namespace

PoseCorrectiveCodec parse_pose_corrective_codec(const std::string& text, const std::string& option, PoseCorrectiveCodec c) {
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t eq = item.find('=');
    const std::string key = item.substr(0, eq), val = eq == std::string::npos ? "" : item.substr(eq + 1);
    char* end = nullptr;
    const double x = std::strtod(val.c_str(), &end);
    if (val.empty() || *end != '\0' || !std::isfinite(x)) fail(option, "bad entry '" + item + "' (keys: t, r, e, b; e.g. t=0.02,r=4,e=0.995,b=6)");
    if (key == "t" && x >= 0 && x < 1) c.threshold = x;
    else if (key == "e" && x > 0 && x <= 1) c.energy = x;
    else if (key == "r" && x == std::floor(x) && x >= 1 && x <= 9) c.rank = int(x);
    else if (key == "b" && x == std::floor(x) && x >= 0 && x <= 30) c.bits = int(x);
    else fail(option, "bad entry '" + item + "' (t in [0, 1), r in 1..9, e in (0, 1], b in 0..30)");
  }
  return c;
}

EncodedPoseCorrectives encode_pose_correctives(const std::vector<float>& pd, int V, const PoseCorrectiveCodec& codec) {
  if (V <= 0 || pd.size() != size_t(V) * 3 * kNumPoseFeatures) fail("pose correctives", "posedirs must be V x 3 x 486");
  if (codec.rank < 1 || codec.rank > 9 || codec.bits < 0 || codec.bits > 30 || !(codec.threshold >= 0 && codec.threshold < 1)) {
    fail("pose correctives", "codec: threshold in [0, 1), rank in 1..9, bits in 0..30");
  }
  std::vector<std::vector<double>> blocks(kBlocks + 1);  // kept blocks of each joint, (3K x 9)
  std::vector<std::vector<int>> kept_of(kBlocks + 1);
  std::vector<std::array<double, 9>> vals_of(kBlocks + 1);
  std::vector<Mat9> vecs_of(kBlocks + 1);
  // The file's rank: what the most demanding joint needs to keep `energy` of its kept
  // blocks' squared norm, at most codec.rank (extra rows would cost bytes for nothing).
  int R = 1;
  for (int j = 1; j <= kBlocks; ++j) {
    std::vector<double> norm(static_cast<size_t>(V));
    double mx = 0;
    for (int v = 0; v < V; ++v) {
      double s = 0;
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 9; ++k) s += double(block(pd, v, c, j)[k]) * block(pd, v, c, j)[k];
      norm[size_t(v)] = std::sqrt(s);
      mx = std::max(mx, norm[size_t(v)]);
    }
    if (mx == 0) continue;
    std::vector<int>& kept = kept_of[size_t(j)];
    for (int v = 0; v < V; ++v)
      if (norm[size_t(v)] > codec.threshold * mx) kept.push_back(v);
    std::vector<double>& A = blocks[size_t(j)];
    A.resize(kept.size() * 27);
    for (size_t i = 0; i < kept.size(); ++i)
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 9; ++k) A[(i * 3 + size_t(c)) * 9 + size_t(k)] = block(pd, kept[i], c, j)[k];
    Mat9 G{};
    for (size_t row = 0; row < kept.size() * 3; ++row)
      for (int p = 0; p < 9; ++p)
        for (int q = 0; q < 9; ++q) G[size_t(p) * 9 + q] += A[row * 9 + size_t(p)] * A[row * 9 + size_t(q)];
    std::array<double, 9>& vals = vals_of[size_t(j)];
    symmetric_eigen9(G, vals, vecs_of[size_t(j)]);
    double total = 0, sum = 0;
    for (double x : vals) total += std::max(0.0, x);
    int need = 0;
    while (need < 9 && sum < codec.energy * total) sum += std::max(0.0, vals[size_t(need++)]);
    R = std::max(R, std::min(codec.rank, need));
  }
  EncodedPoseCorrectives e;
  e.rank = R;
  e.mixing.assign(size_t(kBlocks) * R * 9, 0.0f);
  std::vector<uint8_t> joint;
  std::vector<uint32_t> vertex;
  std::vector<float> coef;                 // (count, 3 R)
  std::vector<int> first(kBlocks + 2, 0);  // first point of each joint
  for (int j = 1; j <= kBlocks; ++j) {
    first[size_t(j)] = int(joint.size());
    const std::vector<int>& kept = kept_of[size_t(j)];
    if (kept.empty()) continue;
    const std::vector<double>& A = blocks[size_t(j)];
    const std::array<double, 9>& vals = vals_of[size_t(j)];
    const Mat9& W = vecs_of[size_t(j)];
    // Directions the kept blocks do not use are left out (zero coefficients and rows).
    int r = 0;
    while (r < R && vals[size_t(r)] > 1e-20 * vals[0] && vals[size_t(r)] > 0) ++r;
    std::vector<double> C(kept.size() * 3 * size_t(R), 0.0);
    double cmax = 0;
    for (size_t row = 0; row < kept.size() * 3; ++row)
      for (int k = 0; k < r; ++k) {
        double s = 0;
        for (int q = 0; q < 9; ++q) s += A[row * 9 + size_t(q)] * W[size_t(k) * 9 + q];
        C[row * R + size_t(k)] = s;
        cmax = std::max(cmax, std::fabs(s));
      }
    // Coefficients scaled into [-1, 1] (one quantization range for all joints); the scale
    // moves into the mixing rows.
    for (size_t i = 0; i < kept.size(); ++i) {
      joint.push_back(uint8_t(j));
      vertex.push_back(uint32_t(kept[i]));
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < R; ++k) coef.push_back(float(C[(i * 3 + size_t(c)) * R + size_t(k)] / cmax));
    }
    for (int k = 0; k < r; ++k)
      for (int q = 0; q < 9; ++q) e.mixing[(size_t(j - 1) * R + size_t(k)) * 9 + size_t(q)] = float(cmax * W[size_t(k) * 9 + q]);
  }
  first[kBlocks + 1] = int(joint.size());
  e.count = int(joint.size());
  if (e.count == 0) return e;

  using dracoio::AttrIn;
  using dracoio::Kind;
  using dracoio::Type;
  const bool u16 = V <= 65536;
  std::vector<uint16_t> vertex16(vertex.begin(), vertex.end());
  // Joint and vertex indices ascend: delta prediction makes them cheap (766 B for the
  // procedural body's 5,408 blocks).
  std::vector<float> cxyz[3];  // one attribute per coordinate (Draco takes <= 16 components)
  for (int c = 0; c < 3; ++c) {
    cxyz[c].resize(size_t(e.count) * R);
    for (int p = 0; p < e.count; ++p)
      for (int k = 0; k < R; ++k) cxyz[c][size_t(p) * R + size_t(k)] = coef[(size_t(p) * 3 + size_t(c)) * R + size_t(k)];
  }
  const std::vector<AttrIn> attrs = {
      {"JOINT", Kind::generic, Type::u8, 1, joint.data(), 0, true},
      {"VERTEX", Kind::generic, u16 ? Type::u16 : Type::u32, 1, u16 ? static_cast<const void*>(vertex16.data()) : vertex.data(), 0, true},
      {"COEF_X", Kind::generic, Type::f32, R, cxyz[0].data(), codec.bits, kPredictCoefficients},
      {"COEF_Y", Kind::generic, Type::f32, R, cxyz[1].data(), codec.bits, kPredictCoefficients},
      {"COEF_Z", Kind::generic, Type::f32, R, cxyz[2].data(), codec.bits, kPredictCoefficients}};
  dracoio::Encoded enc = dracoio::encode(e.count, attrs, nullptr, 0);
  e.draco = std::move(enc.bytes);
  for (int i = 0; i < 5; ++i) e.ids[size_t(i)] = enc.unique_ids[size_t(i)];

  // Refit each joint's mixing rows to the coefficients as a reader decodes them:
  // W = (Cq^T Cq)^-1 Cq^T A (least squares), so the quantization error is partly undone.
  if (codec.bits > 0) {
    dracoio::Decoded dec(e.draco.data(), e.draco.size(), false, "pose correctives", "encoder check", e.count);
    const std::vector<float> cq = coefficients(dec, e.ids.data(), R);
    for (int j = 1; j <= kBlocks; ++j) {
      const int p0 = first[size_t(j)], p1 = first[size_t(j) + 1];
      if (p1 == p0) continue;
      int r = 0;  // the rows the SVD used
      for (int k = 0; k < R; ++k)
        for (int q = 0; q < 9; ++q)
          if (e.mixing[(size_t(j - 1) * R + size_t(k)) * 9 + size_t(q)] != 0.0f) r = k + 1;
      if (r == 0) continue;
      std::vector<double> M(size_t(r) * r, 0.0), B(size_t(r) * 9, 0.0);
      const std::vector<double>& A = blocks[size_t(j)];
      for (int p = p0; p < p1; ++p)
        for (int c = 0; c < 3; ++c) {
          const float* cr = &cq[(size_t(p) * 3 + size_t(c)) * R];
          const double* ar = &A[(size_t(p - p0) * 3 + size_t(c)) * 9];
          for (int a = 0; a < r; ++a) {
            for (int b = 0; b < r; ++b) M[size_t(a) * r + b] += double(cr[a]) * cr[b];
            for (int q = 0; q < 9; ++q) B[size_t(a) * 9 + q] += double(cr[a]) * ar[q];
          }
        }
      if (!solve_small(M, B, r, 9)) continue;  // keep the SVD rows
      for (int k = 0; k < r; ++k)
        for (int q = 0; q < 9; ++q) e.mixing[(size_t(j - 1) * R + size_t(k)) * 9 + size_t(q)] = float(B[size_t(k) * 9 + q]);
    }
  }
  return e;
}

std::vector<float> decode_pose_correctives(const uint8_t* data, size_t size, int count, int rank, const int* ids,
                                           const float* mixing, int V, const std::string& where, const std::string& what) {
  if (rank < 1 || rank > 9) fail(where, what + ".rank: must be in 1..9");
  for (size_t i = 0; i < size_t(kBlocks) * rank * 9; ++i)
    if (!std::isfinite(mixing[i])) fail(where, what + ": non-finite mixing row");
  std::vector<float> pd(size_t(V) * 3 * kNumPoseFeatures, 0.0f);
  if (count == 0) return pd;
  dracoio::Decoded dec(data, size, false, where, what, count);
  if (dec.num_points() != count) fail(where, what + ": Draco stream has " + std::to_string(dec.num_points()) + " points, the file says " + std::to_string(count));
  const std::vector<int64_t> joint = dec.ints(ids[0], 1, "JOINT");
  const std::vector<int64_t> vertex = dec.ints(ids[1], 1, "VERTEX");
  const std::vector<float> coef = coefficients(dec, ids, rank);
  int64_t prev = -1;
  for (int p = 0; p < count; ++p) {
    const int64_t j = joint[size_t(p)], v = vertex[size_t(p)];
    if (j < 1 || j > kBlocks) fail(where, what + ": joint " + std::to_string(j) + " out of range [1, 54]");
    if (v < 0 || v >= V) fail(where, what + ": vertex " + std::to_string(v) + " out of range [0, " + std::to_string(V) + ")");
    const int64_t key = j * V + v;
    if (key <= prev) fail(where, what + ": (joint, vertex) pairs not in strictly increasing order");
    prev = key;
    const float* m = mixing + size_t(j - 1) * rank * 9;
    for (int c = 0; c < 3; ++c) {
      const float* cr = &coef[(size_t(p) * 3 + size_t(c)) * rank];
      for (int k = 0; k < rank; ++k)
        if (!std::isfinite(cr[k])) fail(where, what + ": non-finite coefficient");
      float* out = &pd[(size_t(3) * size_t(v) + size_t(c)) * kNumPoseFeatures + 9 * size_t(j - 1)];
      for (int s = 0; s < 9; ++s) {
        double acc = 0;
        for (int k = 0; k < rank; ++k) acc += double(cr[k]) * double(m[size_t(k) * 9 + size_t(s)]);
        out[s] = float(acc);
      }
    }
  }
  return pd;
}

}  // namespace haha
