// A synthetic garment mesh (synth/synth_subject.h SynthMesh) is well formed: faces and UV
// faces in range, UVs in [0, 1], finite rest positions, and per vertex valid skinning
// weights summing to 1. Shared by the tests of both subjects.
#pragma once

#include <gtest/gtest.h>

#include <cmath>

#include "body/body_model.h"
#include "synth/synth_subject.h"

namespace haha::test {

inline void expect_synth_mesh_well_formed(const SynthMesh& m) {
  ASSERT_EQ(m.ft.size(), m.faces.size());
  ASSERT_EQ(int(m.w_start.size()), m.num_verts() + 1);
  const int nuv = int(m.vt.size() / 2);
  for (size_t i = 0; i < m.faces.size(); ++i) {
    ASSERT_TRUE(m.faces[i] >= 0 && m.faces[i] < m.num_verts());
    ASSERT_TRUE(m.ft[i] >= 0 && m.ft[i] < nuv);
  }
  for (float u : m.vt) ASSERT_TRUE(u >= 0 && u <= 1);
  for (float x : m.rest) ASSERT_TRUE(std::isfinite(x));
  for (int v = 0; v < m.num_verts(); ++v) {
    double sum = 0;
    for (int k = m.w_start[v]; k < m.w_start[v + 1]; ++k) {
      ASSERT_TRUE(m.w_joint[k] >= 0 && m.w_joint[k] < kNumJoints);
      ASSERT_GE(m.w_value[k], 0.0f);
      sum += m.w_value[k];
    }
    ASSERT_NEAR(sum, 1.0, 1e-5) << "vertex " << v;
  }
}

}  // namespace haha::test
