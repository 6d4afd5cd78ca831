// `haha synth-body`: writes the procedural body model (SMPL-X .npz layout).
#include <cstdio>
#include <memory>
#include <string>

#include "body/procedural_body.h"
#include "command.h"
#include "io/body_model_io.h"

HAHA_COMMAND(synth_body) {
  struct Opts {
    std::string out, resolution = "full";
    uint64_t seed = 0;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("synth-body", "Write a procedural body model in the SMPLX_NEUTRAL.npz layout");
  sub->add_option("--out", o->out, "output model .npz")->required();
  sub->add_option("--resolution", o->resolution, "low (~1.9k vertices, for tests) or full (10,476 vertices)")
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "varies small proportions and details")->capture_default_str();
  sub->callback([o] {
    haha::ProceduralBodyOptions opt;
    opt.resolution = haha::parse_body_resolution(o->resolution);
    opt.seed = o->seed;
    const haha::BodyModel m = haha::make_procedural_body(opt);
    haha::save_body_model(m, o->out);
    std::printf("%s: %d vertices, %d faces, %d UV vertices (%s, seed %llu)\n", o->out.c_str(), m.num_verts,
                m.num_faces, m.num_uv(), o->resolution.c_str(), static_cast<unsigned long long>(o->seed));
  });
}
