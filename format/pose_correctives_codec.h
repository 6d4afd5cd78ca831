// Compact pose correctives (format/spec.md, body.poseCorrectives "encoding": "sparse_lowrank").
//
// posedirs (V, 3, 486) split into 54 joints x V blocks of 3 x 9 (the block of vertex v and
// joint j maps that joint's 9 pose features (R_j - I) to v's 3 offset coordinates). Pose
// correctives are local: per joint only the vertices whose block norm exceeds `threshold`
// times that joint's largest block are kept; the kept blocks of a joint, stacked (3K x 9),
// are approximated by a rank-r factorisation C W (C: 3K x r coefficients, W: r x 9 mixing
// rows; r: see PoseCorrectiveCodec::energy). The file stores one Draco point cloud
// (sequential; one point per kept (joint, vertex) pair, sorted by joint then vertex) with
// JOINT (uint8), VERTEX (uint16/uint32) and COEF_X, COEF_Y, COEF_Z (r floats each: the
// coefficients of that coordinate, each joint's scaled into [-1, 1] and quantized with
// `bits`), and the mixing rows (54, r, 9) float32 in a plain buffer. The mixing rows are
// refitted by least squares to the coefficients as quantized, so quantization error is
// partly absorbed.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace haha {

struct PoseCorrectiveCodec {
  // Chosen on the trained demo avatar (haha bench --corrective-sets, 50 poses) and on the
  // procedural body and the dense stand-in (tests/format/pose_correctives_slow_test.cpp);
  // figures in docs/results.md "Storage". Threshold 0.05 cost 0.5 dB on the demo's
  // training poses against 0.02; t=0.01 with 8 bits costs 41 % more bytes for 0.4 dB there.
  double threshold = 0.02;  // keep blocks with norm > threshold x the joint's largest block norm
  int rank = 4;             // at most this many mixing rows per joint, 1..9
  double energy = 0.995;    // file rank: the fewest rows keeping this fraction of every joint's
                            // kept squared norm (the procedural body's blocks need 1), <= rank
  int bits = 6;             // Draco quantization of the coefficients, 1..30 (0 = float32)
};

// "t=0.02,r=4,e=0.995,b=6" (any subset; the others keep `base`); throws haha::Error naming
// `option` on a bad key or value.
PoseCorrectiveCodec parse_pose_corrective_codec(const std::string& text, const std::string& option,
                                                PoseCorrectiveCodec base = {});

struct EncodedPoseCorrectives {
  std::vector<uint8_t> draco;  // the point cloud; empty when no block is kept (count 0)
  std::vector<float> mixing;   // (54, rank, 9): joint j (1..54) at row block j - 1
  int count = 0;               // kept (joint, vertex) pairs
  int rank = 0;
  // Draco unique ids of JOINT, VERTEX, COEF_X, COEF_Y, COEF_Z.
  std::array<int, 5> ids = {-1, -1, -1, -1, -1};
};

// posedirs: (V, 3, 486) as in BodyModel. Throws haha::Error on a size mismatch or bad options.
EncodedPoseCorrectives encode_pose_correctives(const std::vector<float>& posedirs, int V, const PoseCorrectiveCodec& codec);

// Dense (V, 3, 486) posedirs from the stored parts. `mixing` holds 54 x rank x 9 floats.
// Every value is checked (counts, joint in 1..54, vertex < V, strictly increasing (joint,
// vertex) order, finite numbers); throws haha::Error "<where>: <what>: <problem>".
// value(v, c, 9 (j - 1) + s) = float(sum_k double(coef[c r + k]) * double(mixing[j - 1][k][s])),
// summed in k order (the web viewer does the same sums).
// `ids`: the five Draco unique ids (JOINT, VERTEX, COEF_X, COEF_Y, COEF_Z).
std::vector<float> decode_pose_correctives(const uint8_t* draco, size_t size, int count, int rank, const int* ids,
                                           const float* mixing, int V, const std::string& where, const std::string& what);

}  // namespace haha
