// An SMPL-layout stand-in derived from an SMPL-X model (e.g. the procedural body), for
// testing SMPL -> SMPL-X conversion without the licence-gated SMPL files. It differs from
// its source by known offsets, which a correct fit must recover:
//   - its template is the source shaped with `betas` and moved by `shift` (so its root
//     joint and proportions differ: SMPL-X transl = SMPL transl + shift, SMPL-X betas =
//     `betas` + the SMPL betas, pose the same, for SMPL hand joints at rest);
//   - it has SMPL's 24 joints (io/smpl_model_io.h slots): jaw and eye weights fold into the
//     head, each hand's finger weights into SMPL's hand joint (slot 25 / 40);
//   - it drops the vertices that only the eyes' joints use (so not every vertex has a
//     counterpart): smplx_vertex maps each kept vertex to its source vertex.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "body/body_model.h"

namespace haha {

struct SmplStandinOptions {
  std::vector<float> betas;            // source shape baked into the template (<= num_shape)
  std::array<float, 3> shift{};        // template translation, metres
  int num_shape = 10;                  // SMPL shape columns (the source's first ones)
};

// The stand-in in the 55-joint layout (save with io/smpl_model_io.h save_smpl_model).
BodyModel make_smpl_standin(const BodyModel& smplx, const SmplStandinOptions& opt, std::vector<int32_t>* smplx_vertex);

}  // namespace haha
