// `haha unpack`: a .glb avatar -> texture, rest-pose OBJ, 3DGS .ply, summary and run files
// (app/unpack_run.h).
#include <memory>
#include <string>

#include "app/unpack_run.h"
#include "command.h"

HAHA_COMMAND(unpack) {
  struct Opts {
    std::string in, out;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("unpack", "Unpack a .glb avatar: texture, rest-pose OBJ, 3DGS .ply, summary, run files");
  sub->add_option("avatar", o->in, "avatar .glb")->required();
  sub->add_option("--out", o->out, "output directory")->required();
  sub->callback([o] {
    haha::run_unpack(o->in, o->out);
  });
}
