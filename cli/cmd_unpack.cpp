// `haha unpack`: a .glb avatar -> plain files in DIR:
//   texture.<png|jpg|webp>  the embedded image, byte for byte
//   mesh.obj                rest-pose body (subject's shape) with its UV map
//   gaussians.ply           the Gaussians in the rest pose as a standard 3DGS .ply
//   summary.json            counts, sizes, quantization, storage report (as `haha info --json`)
//   avatar.npz, body.npz, config.json   a run directory again: `haha pack DIR` repacks it
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "app/run_dir.h"
#include "command.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "format/avatar_info.h"
#include "format/avatar_npz.h"
#include "format/avatar_unpack.h"
#include "io/body_model_io.h"
#include "io/mesh_export.h"
#include "io/ply_3dgs.h"

HAHA_COMMAND(unpack) {
  struct Opts {
    std::string in, out;
  };
  auto o = std::make_shared<Opts>();
  auto* sub = app.add_subcommand("unpack", "Unpack a .glb avatar: texture, rest-pose OBJ, 3DGS .ply, summary, run files");
  sub->add_option("avatar", o->in, "avatar .glb")->required();
  sub->add_option("--out", o->out, "output directory")->required();
  sub->callback([o] {
    namespace fs = std::filesystem;
    const haha::UnpackedAvatar u = haha::read_avatar_file(o->in);
    const haha::Avatar& a = u.avatar;
    haha::ensure_directory(o->out);
    const fs::path dir(o->out);

    const std::string tex = (dir / ("texture." + haha::texture_file_extension(u.info.texture_mime))).string();
    haha::write_text_file(tex, std::string(u.texture_image.begin(), u.texture_image.end()));

    haha::ExportMesh mesh;
    mesh.verts = a.body.v_template.data();
    mesh.num_verts = a.body.num_verts;
    mesh.faces = a.body.faces.data();
    mesh.num_faces = a.body.num_faces;
    mesh.uv = a.body.vt.data();
    mesh.num_uv = a.body.num_uv();
    mesh.uv_faces = a.body.ft.data();
    haha::write_mesh((dir / "mesh.obj").string(), mesh);

    haha::write_ply_3dgs((dir / "gaussians.ply").string(), haha::rest_pose_ply(a));

    // A run directory again (app/run_dir.h).
    haha::write_unpacked_run(haha::RunDir(o->out), a, o->in);

    const haha::StorageReport r = haha::storage_report(u);
    haha::write_text_file((dir / "summary.json").string(), haha::avatar_summary_json(o->in, u, r).dump(2) + "\n");
    std::printf("%s: %d Gaussians, %d vertices, %d faces -> %s (texture, mesh.obj, gaussians.ply, summary.json, run files)\n",
                o->in.c_str(), a.gaussians.size(), a.body.num_verts, a.body.num_faces, o->out.c_str());
  });
}
