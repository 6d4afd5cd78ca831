// Exact k-nearest-neighbour search over 3D points with a uniform grid, for the KNN
// regulariser (losses.h knn_reg). Written here rather than taken from nanoflann so that
// haha_train builds with the standard library alone (the GPU machine has no Debian
// packages); nanoflann serves only as a reference in the test where it is installed.
//
// Exact: cells are visited in growing Chebyshev rings until no unvisited cell can hold a
// closer point. Ties in distance are broken by the smaller index, so the result is
// deterministic and independent of the thread count. Points must be finite.
#pragma once

#include <cstdint>

namespace haha {

// For each point i of `points` (n, 3): the k nearest OTHER points, nearest first, written
// to out_idx[i * k .. i * k + k) and, if out_d2 is given, their squared distances. When
// fewer than k other points exist, the row is padded with -1 (and distance +inf).
void knn_search(const float* points, int64_t n, int k, int32_t* out_idx, float* out_d2 = nullptr);

// The release's neighbour sets (pytorch3d knn_points of a cloud against itself, K = 3):
// row i = [i, its K-1 nearest others]. out_idx is (n, K). This is what knn_reg takes.
void knn_sets(const float* points, int64_t n, int K, int32_t* out_idx);

}  // namespace haha
