// SMPL body model files (SMPL_{NEUTRAL,MALE,FEMALE}.npz, licence-gated, never shipped) and
// SMPL pose vectors, held in the 55-joint BodyModel / SmplxParams layout so that the
// SMPL-X LBS (body/lbs.h) poses them unchanged.
//
// SMPL file keys: v_template (V, 3), f (F, 3), J_regressor (24, V) dense, kintree_table
// (2, 24), weights (V, 24), shapedirs (V, 3, S) (S = 10 or 300 shape columns, no
// expression), posedirs (V, 3, 207) (23 x 9, the same (R_j - I) features as SMPL-X's).
// SMPL joints 0-21 are SMPL-X joints 0-21; SMPL's hand joints 22 and 23 (children of the
// wrists) go to slots 25 and 40 (SMPL-X's first finger joint of each hand, also a wrist
// child); the other SMPL-X slots have no regressor row, weight or corrective.
// SMPL's official .pkl files hold chumpy and scipy objects that are not read here: convert
// them to .npz with the keys above (numpy arrays, J_regressor dense).
#pragma once

#include <string>
#include <vector>

#include "body/body_model.h"
#include "body/smplx_params.h"

namespace haha {

constexpr int kSmplJoints = 24;
// SMPL joint j -> slot in the 55-joint layout.
constexpr int kSmplJointSlot[kSmplJoints] = {0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11,
                                             12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 25, 40};

// Throws haha::Error "file: key: problem" (wrong shapes, a non-SMPL joint tree, .pkl).
BodyModel load_smpl_model(const std::string& path);
// Writes a model in the 55-joint layout (as load_smpl_model returns, e.g. a stand-in) in
// the SMPL file layout above. Throws if a slot outside kSmplJointSlot carries weight.
void save_smpl_model(const BodyModel& m, const std::string& path);

// An SMPL frame (pose 72 = 24 joints x axis-angle, betas, transl) in SmplxParams layout.
SmplxParams smpl_params(const double* pose72, const std::vector<float>& betas, const double* transl);

}  // namespace haha
