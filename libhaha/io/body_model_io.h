// Body model files: SMPLX_{NEUTRAL,MALE,FEMALE}.npz and the procedural stand-in.
#pragma once

#include <string>

#include "body/body_model.h"

namespace haha {

// Loads a body model .npz. Accepts float32/float64 arrays, any integer width for faces,
// 400 (300 shape + 100 expression) or 20 (10 + 10) shapedirs columns, kintree_table with
// any parents[0], object arrays it does not need, and missing optional keys (hand PCA,
// landmarks, UVs). Throws haha::Error "file: key: problem".
BodyModel load_body_model(const std::string& path);

// Writes the model in the SMPL-X .npz layout (float32 arrays, int32 faces). Atomic.
void save_body_model(const BodyModel& m, const std::string& path);

}  // namespace haha
