// Triangle mesh export (posed bodies) as Wavefront .obj (with a UV map when given) or
// binary little-endian .ply, written through OpenMesh. Vertex and face order are kept
// (face i of the input is face i of the file). Atomic: a failed write leaves no file.
#pragma once

#include <cstdint>
#include <string>

#include "body/body_model.h"
#include "body/smplx_params.h"

namespace haha {

// Buffer contract (all caller-owned, row-major):
//   verts (num_verts, 3) float; faces (num_faces, 3) int32 vertex indices;
//   optional UV map: uv (num_uv, 2) float and uv_faces (num_faces, 3) int32 UV indices
//   (per face corner, as SMPL-X vt/ft). The UV map goes to .obj only (.ply has no
//   per-corner UVs).
struct ExportMesh {
  const float* verts = nullptr;
  int num_verts = 0;
  const int32_t* faces = nullptr;
  int num_faces = 0;
  const float* uv = nullptr;
  int num_uv = 0;
  const int32_t* uv_faces = nullptr;
};

enum class MeshFormat { obj, ply };

// From the extension (.obj / .ply, any case); throws haha::Error "path: ..." otherwise.
MeshFormat mesh_format_from_path(const std::string& path);

// Validates the buffers (indices in range, finite positions, no repeated vertex in a
// face, manifold connectivity as OpenMesh needs) and writes the file. Throws haha::Error
// naming the path and the problem.
void write_mesh(const std::string& path, const ExportMesh& mesh);

// Poses `model` with `params` (float LBS, transl included) and writes the mesh; .obj
// files carry the model's UV map (vt/ft) when it has one.
void write_posed_body(const std::string& path, const BodyModel& model, const SmplxParams& params);

}  // namespace haha
