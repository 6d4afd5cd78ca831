// `haha info`: counts, bytes per part, quantization, extensions and the storage report of
// a .glb avatar (format/avatar_info.h).
#include <cstdio>
#include <memory>
#include <string>

#include "command.h"
#include "format/avatar_info.h"
#include "format/avatar_unpack.h"

HAHA_COMMAND(info) {
  struct Opts {
    std::string in;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("info", "Describe a .glb avatar: counts, sizes per part, quantization, storage report");
  sub->add_option("avatar", o->in, "avatar .glb")->required();
  sub->add_flag("--json", o->json, "machine-readable output");
  sub->callback([o] {
    const haha::UnpackedAvatar u = haha::read_avatar_file(o->in);
    const haha::StorageReport r = haha::storage_report(u);
    if (o->json) {
      std::printf("%s\n", haha::avatar_summary_json(o->in, u, r).dump(2).c_str());
    } else {
      std::fputs(haha::avatar_summary_text(o->in, u, r).c_str(), stdout);
    }
  });
}
