#include "app/unpack_run.h"

#include <cstdio>
#include <filesystem>

#include "app/run_dir.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "format/avatar_info.h"
#include "format/avatar_npz.h"
#include "format/avatar_unpack.h"
#include "io/body_model_io.h"
#include "io/mesh_export.h"
#include "io/ply_3dgs.h"

namespace haha {

void run_unpack(const std::string& in, const std::string& out) {
  namespace fs = std::filesystem;
  const UnpackedAvatar u = read_avatar_file(in);
  const Avatar& a = u.avatar;
  ensure_directory(out);
  const fs::path dir(out);

  const std::string tex = (dir / ("texture." + texture_file_extension(u.info.texture_mime))).string();
  write_text_file(tex, std::string(u.texture_image.begin(), u.texture_image.end()));

  ExportMesh mesh;
  mesh.verts = a.body.v_template.data();
  mesh.num_verts = a.body.num_verts;
  mesh.faces = a.body.faces.data();
  mesh.num_faces = a.body.num_faces;
  mesh.uv = a.body.vt.data();
  mesh.num_uv = a.body.num_uv();
  mesh.uv_faces = a.body.ft.data();
  write_mesh((dir / "mesh.obj").string(), mesh);

  write_ply_3dgs((dir / "gaussians.ply").string(), rest_pose_ply(a));

  // A run directory again (app/run_dir.h).
  write_unpacked_run(RunDir(out), a, in);

  const StorageReport r = storage_report(u);
  write_text_file((dir / "summary.json").string(), avatar_summary_json(in, u, r).dump(2) + "\n");
  std::printf("%s: %d Gaussians, %d vertices, %d faces -> %s (texture, mesh.obj, gaussians.ply, summary.json, run files)\n",
              in.c_str(), a.gaussians.size(), a.body.num_verts, a.body.num_faces, out.c_str());
}

}  // namespace haha
