// `haha body`: poses a body model with one frame of SMPL-X parameters and writes the mesh.
#include <cstdio>
#include <memory>
#include <string>

#include "command.h"
#include "core/error.h"
#include "io/body_model_io.h"
#include "io/mesh_export.h"
#include "io/smplx_params_io.h"

HAHA_COMMAND(body) {
  struct Opts {
    std::string model, params, out;
    int frame = 0;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("body", "Pose a body model with SMPL-X parameters and write the mesh (.obj or .ply)");
  sub->add_option("--model", o->model, "body model .npz (SMPLX_*.npz or `haha synth-body` output)")->required();
  sub->add_option("--params", o->params,
                  "parameters .npz (global_orient, body_pose, jaw_pose, leye_pose, reye_pose, left_hand_pose, "
                  "right_hand_pose, betas, expression, transl; (D) or (N, D); missing arrays are zeros)")
      ->required();
  sub->add_option("--frame", o->frame, "frame index into the parameter arrays")->capture_default_str();
  sub->add_option("--out", o->out, "posed mesh: .obj (with the model's UV map) or .ply")->required();
  sub->callback([o] {
    haha::mesh_format_from_path(o->out);  // reject a bad extension before any work
    const haha::BodyModel model = haha::load_body_model(o->model);
    const auto frames = haha::read_smplx_params(o->params, &model);
    if (o->frame < 0 || o->frame >= int(frames.size()))
      haha::fail(o->params, "frame " + std::to_string(o->frame) + " out of range: the file has " +
                                std::to_string(frames.size()) + " frame(s)");
    haha::write_posed_body(o->out, model, frames[o->frame]);
    std::printf("%s: %d vertices, %d faces (frame %d of %zu)\n", o->out.c_str(), model.num_verts, model.num_faces,
                o->frame, frames.size());
  });
}
