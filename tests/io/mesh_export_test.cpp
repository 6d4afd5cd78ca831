// Mesh export (.obj with UVs, binary .ply) read back by hand and through OpenMesh's
// readers; bad input -> one error naming the file, nothing written; the posed-body path
// of `haha body` (Lbs<float> + export, missing parameter arrays = zeros); the procedural
// body saved in the SMPL-X .npz layout and loaded back.
#include <gtest/gtest.h>
#include <unistd.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "body/lbs.h"
#include "body/procedural_body.h"
#include "core/error.h"
#include "io/body_model_io.h"
#include "io/mesh_export.h"
#include "io/npy.h"
#include "io/smplx_params_io.h"
#include "support/expect_error.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

std::string tmp(const std::string& name) {
  return (fs::temp_directory_path() / ("haha_mesh_" + std::to_string(::getpid()) + "_" + name)).string();
}

// A unit cube (8 vertices, 12 outward triangles) with a UV map that cuts it into 6
// separate squares (24 UV vertices): seams, as in body models.
struct Cube {
  std::vector<float> v = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
  std::vector<int32_t> f = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                            1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};
  std::vector<float> uv;
  std::vector<int32_t> ft;
  Cube() {
    for (int side = 0; side < 6; ++side) {
      const float x0 = 0.1f + 0.3f * (side % 3), y0 = 0.1f + 0.45f * (side / 3);
      uv.insert(uv.end(), {x0, y0, x0 + 0.25f, y0, x0 + 0.25f, y0 + 0.25f, x0, y0 + 0.25f});
      const int b = 4 * side;
      ft.insert(ft.end(), {b, b + 2, b + 1, b, b + 3, b + 2});
    }
  }
  ExportMesh view(bool with_uv) const {
    ExportMesh m;
    m.verts = v.data();
    m.num_verts = 8;
    m.faces = f.data();
    m.num_faces = 12;
    if (with_uv) {
      m.uv = uv.data();
      m.num_uv = 24;
      m.uv_faces = ft.data();
    }
    return m;
  }
};

// Minimal OBJ reader: v, vt, f with "v", "v/vt" or "v/vt/vn" corners (1-based).
struct Obj {
  std::vector<float> v, vt;
  std::vector<int> f, ft;
};
Obj read_obj(const std::string& path) {
  Obj o;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      float x, y, z;
      s >> x >> y >> z;
      o.v.insert(o.v.end(), {x, y, z});
    } else if (tag == "vt") {
      float a, b;
      s >> a >> b;
      o.vt.insert(o.vt.end(), {a, b});
    } else if (tag == "f") {
      std::string c;
      int n = 0;
      while (s >> c) {
        ++n;
        o.f.push_back(std::stoi(c) - 1);
        const size_t slash = c.find('/');
        if (slash != std::string::npos && slash + 1 < c.size() && c[slash + 1] != '/')
          o.ft.push_back(std::stoi(c.substr(slash + 1)) - 1);
      }
      EXPECT_EQ(n, 3) << "triangles only";
    }
  }
  return o;
}

void expect_same_geometry(const Obj& o, const std::vector<float>& v, const std::vector<int32_t>& f) {
  ASSERT_EQ(o.v.size(), v.size());
  ASSERT_EQ(o.f.size(), f.size());
  for (size_t i = 0; i < v.size(); ++i) EXPECT_NEAR(o.v[i], v[i], 1e-6 * (1 + std::abs(v[i]))) << i;
  for (size_t i = 0; i < f.size(); i += 3) {
    // Same face, same orientation, possibly rotated corners.
    int k = 0;
    while (k < 3 && o.f[i] != f[i + k]) ++k;
    ASSERT_LT(k, 3) << "face " << i / 3;
    EXPECT_EQ(o.f[i + 1], f[i + (k + 1) % 3]);
    EXPECT_EQ(o.f[i + 2], f[i + (k + 2) % 3]);
  }
}

TEST(MeshExport, ObjKeepsVerticesAndFacesInOrder) {
  const Cube c;
  const std::string p = tmp("cube.obj");
  write_mesh(p, c.view(false));
  const Obj o = read_obj(p);
  expect_same_geometry(o, c.v, c.f);
  EXPECT_TRUE(o.vt.empty());
  fs::remove(p);
}

TEST(MeshExport, ObjCarriesPerCornerUvs) {
  const Cube c;
  const std::string p = tmp("cube_uv.OBJ");  // extension in any case
  write_mesh(p, c.view(true));
  const Obj o = read_obj(p);
  expect_same_geometry(o, c.v, c.f);
  ASSERT_EQ(o.ft.size(), c.ft.size());
  EXPECT_EQ(o.vt.size(), c.uv.size()) << "every distinct UV vertex written once";
  for (size_t i = 0; i < c.f.size(); ++i) {
    // Corner of the written face that holds the same vertex as input corner i.
    const size_t face = i / 3;
    int k = 0;
    while (o.f[3 * face + k] != c.f[i]) ++k;
    const int t_in = c.ft[i], t_out = o.ft[3 * face + k];
    EXPECT_NEAR(o.vt[2 * t_out], c.uv[2 * t_in], 1e-7) << "corner " << i;
    EXPECT_NEAR(o.vt[2 * t_out + 1], c.uv[2 * t_in + 1], 1e-7) << "corner " << i;
  }
  fs::remove(p);
}

TEST(MeshExport, PlyIsBinaryAndReadsBack) {
  const Cube c;
  const std::string p = tmp("cube.ply");
  write_mesh(p, c.view(true));  // UVs are not written to .ply
  {
    std::ifstream in(p, std::ios::binary);
    std::string header, line;
    while (std::getline(in, line) && line != "end_header") header += line + "\n";
    EXPECT_NE(header.find("format binary_little_endian"), std::string::npos) << header;
    EXPECT_NE(header.find("element vertex 8"), std::string::npos) << header;
    EXPECT_NE(header.find("element face 12"), std::string::npos) << header;
  }
  OpenMesh::TriMesh_ArrayKernelT<> mesh;
  ASSERT_TRUE(OpenMesh::IO::read_mesh(mesh, p));
  ASSERT_EQ(mesh.n_vertices(), 8u);
  ASSERT_EQ(mesh.n_faces(), 12u);
  for (int i = 0; i < 8; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(mesh.point(mesh.vertex_handle(i))[k], c.v[3 * i + k]);
  for (int fi = 0; fi < 12; ++fi) {
    std::vector<int> got;
    for (auto vh : mesh.fv_range(mesh.face_handle(fi))) got.push_back(vh.idx());
    ASSERT_EQ(got.size(), 3u);
    int k = 0;
    while (k < 3 && got[0] != c.f[3 * fi + k]) ++k;
    ASSERT_LT(k, 3);
    EXPECT_EQ(got[1], c.f[3 * fi + (k + 1) % 3]);
    EXPECT_EQ(got[2], c.f[3 * fi + (k + 2) % 3]);
  }
  fs::remove(p);
}

void expect_error(const std::string& path, const ExportMesh& m, const std::string& needle) {
  haha::test::expect_error_at(path, [&] { write_mesh(path, m); }, {needle});
}

TEST(MeshExport, BadInputIsOneErrorAndWritesNothing) {
  const std::string dir = tmp("bad");
  fs::create_directories(dir);
  const std::string p = dir + "/out.obj";
  Cube c;
  expect_error(dir + "/out.stl", c.view(false), "unsupported mesh format");
  expect_error(dir + "/out", c.view(false), "unsupported mesh format");
  {
    Cube b;
    b.f[5] = 8;
    expect_error(p, b.view(false), "face 1 has vertex index 8");
    b.f[5] = -1;
    expect_error(p, b.view(false), "face 1 has vertex index -1");
  }
  {
    Cube b;
    b.v[4] = std::nanf("");
    expect_error(p, b.view(false), "vertex 1 is not finite");
  }
  {
    Cube b;
    b.f[2] = b.f[0];
    expect_error(p, b.view(false), "face 0 repeats a vertex");
  }
  {
    Cube b;  // flip one face: its edges now run the same way as its neighbours'
    std::swap(b.f[1], b.f[2]);
    expect_error(p, b.view(false), "reuses a directed edge");
  }
  {
    Cube b;
    b.ft[7] = 24;
    expect_error(p, b.view(true), "face 2 has UV index 24");
  }
  EXPECT_TRUE(fs::is_empty(dir)) << "no partial or temporary files";
  // A failed write leaves an existing file untouched.
  write_mesh(p, c.view(false));
  const auto before = fs::file_size(p);
  Cube b;
  b.v[0] = INFINITY;
  expect_error(p, b.view(false), "not finite");
  EXPECT_EQ(fs::file_size(p), before);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  fs::remove_all(dir);
}

// ---- `haha body` through the library -------------------------------------------------
const BodyModel& low_body() {
  static const BodyModel m = make_procedural_body({BodyResolution::low, 1});
  return m;
}

TEST(PosedBodyExport, ObjAndPlyHoldTheLbsVerticesAndTheUvMap) {
  const BodyModel& m = low_body();
  SmplxParams p;
  p.pose[3 * 18 + 1] = -1.2f;  // left elbow
  p.pose[3 * 4] = 0.9f;        // left knee
  p.pose[3 * 22] = 0.3f;       // jaw
  p.transl = {0.1f, 0.2f, -0.3f};
  p.betas = {1.0f, -0.5f};
  std::vector<float> expect(size_t(m.num_verts) * 3);
  Lbs<float>(m).forward(p, expect.data(), nullptr, nullptr);

  const std::string obj = tmp("posed.obj"), ply = tmp("posed.ply");
  write_posed_body(obj, m, p);
  write_posed_body(ply, m, p);
  const Obj o = read_obj(obj);
  expect_same_geometry(o, expect, m.faces);
  ASSERT_EQ(int(o.vt.size()), 2 * m.num_uv());
  ASSERT_EQ(o.ft.size(), m.ft.size());
  for (size_t i = 0; i < m.faces.size(); ++i) {
    const size_t face = i / 3;
    int k = 0;
    while (o.f[3 * face + k] != m.faces[i]) ++k;
    EXPECT_NEAR(o.vt[2 * o.ft[3 * face + k]], m.vt[2 * m.ft[i]], 1e-7);
    EXPECT_NEAR(o.vt[2 * o.ft[3 * face + k] + 1], m.vt[2 * m.ft[i] + 1], 1e-7);
  }
  OpenMesh::TriMesh_ArrayKernelT<> mesh;
  ASSERT_TRUE(OpenMesh::IO::read_mesh(mesh, ply));
  EXPECT_EQ(int(mesh.n_vertices()), m.num_verts);
  EXPECT_EQ(int(mesh.n_faces()), m.num_faces);
  for (int i = 0; i < m.num_verts; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(mesh.point(mesh.vertex_handle(i))[k], expect[3 * i + k]);
  fs::remove(obj);
  fs::remove(ply);
}

TEST(PosedBodyExport, MissingParameterArraysAreZeros) {
  // A parameter file with only `transl`: the template moved by transl.
  const BodyModel& m = low_body();
  const std::string params = tmp("transl_only.npz"), out = tmp("moved.obj");
  Npz z;
  z.set("transl", NpyArray::from(std::vector<float>{0.5f, -1.0f, 2.0f}, {3}));
  z.write(params);
  const auto frames = read_smplx_params(params, &m);
  ASSERT_EQ(frames.size(), 1u);
  write_posed_body(out, m, frames[0]);
  const Obj o = read_obj(out);
  ASSERT_EQ(int(o.v.size()), 3 * m.num_verts);
  const float t[3] = {0.5f, -1.0f, 2.0f};
  for (int i = 0; i < 3 * m.num_verts; ++i) EXPECT_NEAR(o.v[i], m.v_template[i] + t[i % 3], 2e-6) << i;
  fs::remove(params);
  fs::remove(out);
}

// ---- the procedural body as a SMPL-X file --------------------------------------------
TEST(ProceduralBodyFile, SavesInTheSmplxLayoutAndLoadsBack) {
  const BodyModel& m = low_body();
  const std::string p = tmp("procedural.npz");
  save_body_model(m, p);
  const Npz z = Npz::read(p);
  const int64_t V = m.num_verts, F = m.num_faces;
  EXPECT_EQ(z.get("v_template").shape, (std::vector<int64_t>{V, 3}));
  EXPECT_EQ(z.get("f").shape, (std::vector<int64_t>{F, 3}));
  EXPECT_EQ(z.get("J_regressor").shape, (std::vector<int64_t>{55, V}));
  EXPECT_EQ(z.get("kintree_table").shape, (std::vector<int64_t>{2, 55}));
  EXPECT_EQ(z.get("weights").shape, (std::vector<int64_t>{V, 55}));
  EXPECT_EQ(z.get("shapedirs").shape, (std::vector<int64_t>{V, 3, 400}));
  EXPECT_EQ(z.get("posedirs").shape, (std::vector<int64_t>{V, 3, 486}));
  for (const char* k : {"hands_componentsl", "hands_componentsr"}) EXPECT_EQ(z.get(k).shape, (std::vector<int64_t>{45, 45}));
  for (const char* k : {"hands_meanl", "hands_meanr"}) EXPECT_EQ(z.get(k).shape, (std::vector<int64_t>{45}));
  EXPECT_EQ(z.get("lmk_faces_idx").shape, (std::vector<int64_t>{51}));
  EXPECT_EQ(z.get("lmk_bary_coords").shape, (std::vector<int64_t>{51, 3}));
  EXPECT_EQ(z.get("vt").shape, (std::vector<int64_t>{m.num_uv(), 2}));
  EXPECT_EQ(z.get("ft").shape, (std::vector<int64_t>{F, 3}));

  const BodyModel r = load_body_model(p);
  EXPECT_EQ(r.num_verts, m.num_verts);
  EXPECT_EQ(r.num_faces, m.num_faces);
  EXPECT_EQ(r.num_shape, 300);
  EXPECT_EQ(r.num_expr, 100);
  EXPECT_EQ(r.v_template, m.v_template);
  EXPECT_EQ(r.faces, m.faces);
  EXPECT_EQ(r.j_regressor, m.j_regressor);
  EXPECT_EQ(r.parents, m.parents);
  EXPECT_EQ(r.weights, m.weights);
  EXPECT_EQ(r.shapedirs, m.shapedirs);
  EXPECT_EQ(r.posedirs, m.posedirs);
  EXPECT_EQ(r.hands_components_l, m.hands_components_l);
  EXPECT_EQ(r.hands_components_r, m.hands_components_r);
  EXPECT_EQ(r.hands_mean_l, m.hands_mean_l);
  EXPECT_EQ(r.hands_mean_r, m.hands_mean_r);
  EXPECT_EQ(r.lmk_faces_idx, m.lmk_faces_idx);
  EXPECT_EQ(r.lmk_bary_coords, m.lmk_bary_coords);
  EXPECT_EQ(r.vt, m.vt);
  EXPECT_EQ(r.ft, m.ft);
  fs::remove(p);
}

}  // namespace
}  // namespace haha
