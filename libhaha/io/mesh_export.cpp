// Mesh export through OpenMesh's OBJ / PLY writers (see mesh_export.h).
#include "io/mesh_export.h"

// MeshIO.hh must come before the mesh type (it registers the readers and writers).
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <unordered_set>
#include <vector>

#include "body/lbs.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/text.h"

namespace haha {
namespace {

using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// OpenMesh's writers log "[OBJWriter] : write file" to omlog; keep command output clean.
class QuietOpenMeshLog {
 public:
  QuietOpenMeshLog() : was_enabled_(omlog().is_enabled()) { omlog().disable(); }
  ~QuietOpenMeshLog() {
    if (was_enabled_) omlog().enable();
  }

 private:
  bool was_enabled_;
};

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  return ascii_lower(path.substr(dot));
}

void validate(const std::string& path, const ExportMesh& m, bool with_uv) {
  if (m.num_verts <= 0 || m.num_faces <= 0 || !m.verts || !m.faces) fail(path, "empty mesh");
  for (int i = 0; i < m.num_verts; ++i)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(m.verts[3 * i + c])) fail(path, "vertex " + std::to_string(i) + " is not finite");
  // OpenMesh keeps a halfedge structure: every directed edge may be used by one face only.
  std::unordered_set<uint64_t> directed;
  directed.reserve(size_t(m.num_faces) * 3);
  for (int f = 0; f < m.num_faces; ++f) {
    const int32_t* t = m.faces + 3 * f;
    for (int k = 0; k < 3; ++k)
      if (t[k] < 0 || t[k] >= m.num_verts)
        fail(path, "face " + std::to_string(f) + " has vertex index " + std::to_string(t[k]) + " outside [0, " +
                       std::to_string(m.num_verts) + ")");
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) fail(path, "face " + std::to_string(f) + " repeats a vertex");
    for (int k = 0; k < 3; ++k) {
      const uint64_t key = (uint64_t(uint32_t(t[k])) << 32) | uint32_t(t[(k + 1) % 3]);
      if (!directed.insert(key).second)
        fail(path, "face " + std::to_string(f) + " reuses a directed edge (non-manifold or inconsistently oriented mesh)");
    }
  }
  if (with_uv) {
    for (int i = 0; i < 2 * m.num_uv; ++i)
      if (!std::isfinite(m.uv[i])) fail(path, "UV coordinate " + std::to_string(i / 2) + " is not finite");
    for (int f = 0; f < m.num_faces; ++f)
      for (int k = 0; k < 3; ++k) {
        const int32_t u = m.uv_faces[3 * f + k];
        if (u < 0 || u >= m.num_uv)
          fail(path, "face " + std::to_string(f) + " has UV index " + std::to_string(u) + " outside [0, " +
                         std::to_string(m.num_uv) + ")");
      }
  }
}

}  // namespace

MeshFormat mesh_format_from_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".obj") return MeshFormat::obj;
  if (ext == ".ply") return MeshFormat::ply;
  fail(path, "unsupported mesh format '" + ext + "' (expected .obj or .ply)");
}

void write_mesh(const std::string& path, const ExportMesh& m) {
  const MeshFormat format = mesh_format_from_path(path);
  const bool with_uv = format == MeshFormat::obj && m.uv && m.uv_faces && m.num_uv > 0;
  validate(path, m, with_uv);

  OmMesh mesh;
  mesh.reserve(size_t(m.num_verts), size_t(m.num_faces) * 3, size_t(m.num_faces));
  if (with_uv) mesh.request_halfedge_texcoords2D();
  std::vector<OmMesh::VertexHandle> vh(m.num_verts);
  for (int i = 0; i < m.num_verts; ++i)
    vh[i] = mesh.add_vertex(OmMesh::Point(m.verts[3 * i], m.verts[3 * i + 1], m.verts[3 * i + 2]));
  for (int f = 0; f < m.num_faces; ++f) {
    const int32_t* t = m.faces + 3 * f;
    const OmMesh::FaceHandle fh = mesh.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
    if (!fh.is_valid()) fail(path, "face " + std::to_string(f) + ": OpenMesh rejected it (non-manifold vertex)");
    if (with_uv) {
      // A halfedge's texture coordinate belongs to the corner at its target vertex.
      for (auto heh : mesh.fh_range(fh)) {
        const int v = mesh.to_vertex_handle(heh).idx();
        const int k = v == t[0] ? 0 : (v == t[1] ? 1 : 2);
        const int32_t u = m.uv_faces[3 * f + k];
        mesh.set_texcoord2D(heh, OmMesh::TexCoord2D(m.uv[2 * u], m.uv[2 * u + 1]));
      }
    }
  }

  OpenMesh::IO::Options opt = OpenMesh::IO::Options::Default;
  if (with_uv) opt += OpenMesh::IO::Options::FaceTexCoord;
  if (format == MeshFormat::ply) {
    opt += OpenMesh::IO::Options::Binary;
    opt += OpenMesh::IO::Options::LSB;
  }
  const std::string ext = format == MeshFormat::obj ? ".obj" : ".ply";
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream os(tmp, std::ios::binary);
    if (!os) fail(path, "cannot open for writing");
    // 9 significant digits round-trip float32 exactly.
    const QuietOpenMeshLog quiet;
    const bool ok = OpenMesh::IO::write_mesh(mesh, os, ext, opt, 9);
    os.flush();
    if (!ok || !os) fail(path, "write failed");
  });
}

void write_posed_body(const std::string& path, const BodyModel& model, const SmplxParams& params) {
  mesh_format_from_path(path);  // fail on a bad extension before posing
  const Lbs<float> lbs(model);
  std::vector<float> verts(size_t(model.num_verts) * 3);
  lbs.forward(params, verts.data(), nullptr, nullptr);
  ExportMesh view;
  view.verts = verts.data();
  view.num_verts = model.num_verts;
  view.faces = model.faces.data();
  view.num_faces = model.num_faces;
  if (!model.vt.empty() && model.ft.size() == model.faces.size()) {
    view.uv = model.vt.data();
    view.num_uv = model.num_uv();
    view.uv_faces = model.ft.data();
  }
  write_mesh(path, view);
}

}  // namespace haha
