#include "format/avatar_info.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "body/face_frames.h"
#include "core/error.h"
#include "format/avatar_pack.h"

namespace haha {

namespace fs = std::filesystem;

GaussianPly rest_pose_ply(const Avatar& a, int sh_degree) {
  const int N = a.gaussians.size();
  const std::vector<float> rest = baked_rest_vertices(a);
  GaussianPly p;
  p.sh_degree = sh_degree;
  p.means.resize(size_t(N) * 3);
  p.quats.resize(size_t(N) * 4);
  std::vector<float> scales(size_t(N) * 3);
  pose_gaussians(rest.data(), a.body, a.face_scale_divisor, a.gaussians, p.means.data(), p.quats.data(), scales.data());
  const int K = (sh_degree + 1) * (sh_degree + 1);
  p.sh.assign(size_t(N) * K * 3, 0.0f);
  p.opacity_logit.resize(size_t(N));
  p.log_scales.resize(size_t(N) * 3);
  constexpr double kC0 = 0.28209479177387814;  // SH degree-0 basis constant
  for (int i = 0; i < N; ++i) {
    for (int c = 0; c < 3; ++c) p.sh[size_t(i) * K * 3 + c] = float((a.gaussians.color[size_t(i) * 3 + c] - 0.5) / kC0);
    const double o = std::clamp(double(a.gaussians.opacity[size_t(i)]), 1e-6, 1 - 1e-6);
    p.opacity_logit[size_t(i)] = float(std::log(o / (1 - o)));
    for (int k = 0; k < 3; ++k) p.log_scales[size_t(i) * 3 + k] = std::log(std::max(scales[size_t(i) * 3 + k], 1e-30f));
  }
  return p;
}

std::optional<TextureSpeckle> avatar_texture_speckle(const Avatar& a) {
  const Texture& t = a.texture;
  if (t.width <= 0 || t.height <= 0 || t.rgb.size() != size_t(t.width) * t.height * 3 || a.body.vt.empty() ||
      a.body.ft.size() != size_t(a.body.num_faces) * 3)
    return std::nullopt;
  return texture_speckle(a.body, t.rgb, t.width, t.height);
}

namespace {

// Body vertices whose mesh coverage is under the cutoff (the mesh is cut around them).
int vertices_cut(const Avatar& a) {
  return int(std::count_if(a.mesh_coverage.begin(), a.mesh_coverage.end(), [](float c) { return c < kCoverageCutoff; }));
}

size_t serialized_size(const GaussianPly& p) {
  static std::atomic<int> counter{0};
  const fs::path tmp = fs::temp_directory_path() /
                       ("haha-ply-size-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".ply");
  write_ply_3dgs(tmp.string(), p);
  std::error_code ec;
  const auto n = fs::file_size(tmp, ec);
  fs::remove(tmp, ec);
  return size_t(n);
}

std::string bytes(size_t n) {
  std::string s = std::to_string(n), out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (i && (s.size() - i) % 3 == 0) out += ',';
    out += s[i];
  }
  return out + " B";
}

std::string bits_text(const std::map<std::string, int>& bits) {
  std::string s;
  for (auto& [k, v] : bits) s += (s.empty() ? "" : " ") + k + "=" + (v > 0 ? std::to_string(v) : std::string("float32"));
  return s;
}

}  // namespace

StorageReport storage_report(const UnpackedAvatar& u) {
  StorageReport r;
  const PackedSizes& s = u.info.sizes;
  r.num_gaussians = s.num_gaussians;
  r.file_bytes = s.total;
  r.avatar_part_bytes = s.gaussians + s.texture;
  r.ply_3dgs_bytes = serialized_size(rest_pose_ply(u.avatar, 0));
  r.ply_3dgs_sh3_bytes = serialized_size(rest_pose_ply(u.avatar, 3));
  r.paper_bytes = kPaperBytesPerGaussian * size_t(s.num_gaussians) + kPaperTextureBytes;
  r.avatar_part_vs_paper = double(r.avatar_part_bytes) / double(r.paper_bytes);
  r.file_vs_paper = double(r.file_bytes) / double(r.paper_bytes);
  return r;
}

nlohmann::json avatar_summary_json(const std::string& path, const UnpackedAvatar& u, const StorageReport& r) {
  const AvatarFileInfo& i = u.info;
  const PackedSizes& s = i.sizes;
  nlohmann::json j;
  j["file"] = path;
  j["extension"] = {{"name", kAvatarExtension}, {"version", i.version}};
  j["extensionsUsed"] = i.extensions_used;
  j["extensionsRequired"] = i.extensions_required;
  j["counts"] = {{"gaussians", s.num_gaussians},
                 {"bodyVertices", i.body_vertex_count},
                 {"gltfVertices", s.num_vertices},
                 {"faces", s.num_faces},
                 {"joints", kNumJoints},
                 {"skinSets", s.skin_sets},
                 {"maxInfluences", s.max_influences},
                 {"jointRegressorNonzeros", i.joint_regressor_nonzeros}};
  j["bytes"] = {{"total", s.total},
                {"json", s.json},
                {"mesh", s.mesh},
                {"skeleton", s.skeleton},
                {"gaussians", s.gaussians},
                {"texture", s.texture},
                {"textureExact", s.texture_exact},
                {"poseCorrectives", s.pose_correctives},
                {"splats", s.splats},
                {"animations", s.animations}};
  j["animations"] = nlohmann::json::array();
  for (const AvatarAnimation& a : u.animations) {
    j["animations"].push_back({{"name", a.name}, {"duration", a.duration}, {"frames", a.frames}, {"bytes", a.bytes}});
  }
  j["quantizationBits"] = {{"gaussians", i.gaussian_bits}, {"mesh", i.mesh_bits}};
  j["scaleEncoding"] = i.scale_encoding;
  j["rotationEncoding"] = i.rotation_encoding;
  j["gaussianOrder"] = i.gaussian_order;
  j["meshEncoding"] = !s.draco_mesh ? "none" : s.edgebreaker ? "edgebreaker" : "sequential";
  j["gaussianFaceOrder"] = i.gaussian_face_order;
  {
    nlohmann::json tiers = nlohmann::json::array();
    for (size_t t = 0; t < i.lod_counts.size(); ++t) {
      nlohmann::json tier = {{"count", i.lod_counts[t]}};
      if (std::isfinite(i.lod_psnr[t])) tier["psnr"] = i.lod_psnr[t];
      tiers.push_back(tier);
    }
    j["tiers"] = tiers;
  }
  j["texture"] = {{"mimeType", i.texture_mime}, {"width", i.texture_width}, {"height", i.texture_height},
                  {"exactFloatCopy", i.texture_exact}};
  if (const auto sp = avatar_texture_speckle(u.avatar)) {
    nlohmann::json parts, texels;
    for (int p = 0; p < kSpeckleParts; ++p) {
      parts[speckle_part_name(p)] = sp->per_mille[size_t(p)];
      texels[speckle_part_name(p)] = sp->texels[size_t(p)];
    }
    parts["allCharts"] = sp->all_per_mille;
    texels["allCharts"] = sp->all_texels;
    j["texture"]["speckle"] = {{"perMille", parts}, {"texels", texels}, {"luminanceStep", kSpeckleStep}};
  }
  j["poseCorrectives"] = {{"embedded", i.pose_correctives.empty() ? "none" : i.pose_correctives},
                          {"trainedWith", i.trained_with_pose_correctives},
                          {"topologyCrc32", i.topology_crc32}};
  if (i.pose_correctives == "sparse_lowrank") {
    j["poseCorrectives"]["blocks"] = i.pose_corrective_blocks;
    j["poseCorrectives"]["rank"] = i.pose_corrective_rank;
    j["poseCorrectives"]["quantizationBits"] = i.pose_corrective_bits;
  }
  j["khrGaussianSplatting"] = i.splats;
  j["garment"] = nullptr;  // none: the body mesh is one primitive
  if (i.garment_first_vertex >= 0)
    j["garment"] = {{"firstVertex", i.garment_first_vertex}, {"firstFace", i.garment_first_face},
                    {"vertices", i.body_vertex_count - i.garment_first_vertex},
                    {"faces", s.num_faces - i.garment_first_face}, {"gaussians", i.garment_gaussians}};
  j["meshCoverage"] = nullptr;  // none: the whole mesh draws
  if (!u.avatar.mesh_coverage.empty()) {
    const int n = int(u.avatar.mesh_coverage.size()), cut = vertices_cut(u.avatar);
    j["meshCoverage"] = {{"vertices", n}, {"cutoff", kCoverageCutoff}, {"verticesUnderCutoff", cut}, {"shareUnderCutoff", double(cut) / n}};
  }
  j["subject"] = {{"betas", u.avatar.betas}, {"expression", u.avatar.expression},
                  {"faceScaleDivisor", u.avatar.face_scale_divisor}};
  j["storage"] = {{"fileBytes", r.file_bytes},
                  {"gaussiansPlusTextureBytes", r.avatar_part_bytes},
                  {"ply3dgsBytes", r.ply_3dgs_bytes},
                  {"ply3dgsSh3Bytes", r.ply_3dgs_sh3_bytes},
                  {"paperAccountingBytes", r.paper_bytes},
                  {"gaussiansPlusTextureVsPaper", r.avatar_part_vs_paper},
                  {"fileVsPaper", r.file_vs_paper}};
  return j;
}

std::string avatar_summary_text(const std::string& path, const UnpackedAvatar& u, const StorageReport& r) {
  const AvatarFileInfo& i = u.info;
  const PackedSizes& s = i.sizes;
  std::ostringstream o;
  char buf[256];
  o << path << ": " << kAvatarExtension << " v" << i.version << ", " << bytes(s.total) << "\n";
  std::snprintf(buf, sizeof buf, "%.2f", s.num_gaussians ? double(s.gaussians) / s.num_gaussians : 0.0);
  o << "  gaussians     " << s.num_gaussians << " (Draco point cloud " << bytes(s.gaussians) << ", " << buf
    << " B/Gaussian; bits " << bits_text(i.gaussian_bits) << ", scale " << i.scale_encoding << ", rotation "
    << i.rotation_encoding << ", order " << i.gaussian_order << ")\n";
  if (!i.lod_counts.empty()) {
    o << "  tiers         ";
    int prefix = 0;
    for (size_t t = 0; t < i.lod_counts.size(); ++t) {
      prefix += i.lod_counts[t];
      std::snprintf(buf, sizeof buf, "%s%d", t ? ", " : "", prefix);
      o << buf;
      if (std::isfinite(i.lod_psnr[t])) {
        std::snprintf(buf, sizeof buf, " (%.1f dB)", i.lod_psnr[t]);
        o << buf;
      }
    }
    o << " Gaussians: prefixes a loader can take, PSNR vs all in the rest pose\n";
  }
  o << "  mesh          " << i.body_vertex_count << " body vertices (" << s.num_vertices << " glTF vertices), "
    << s.num_faces << " faces, " << s.skin_sets << " skin set(s) for up to " << s.max_influences
    << " influences (" << (!s.draco_mesh ? "plain accessors, no Draco " : s.edgebreaker ? "Draco edgebreaker " : "Draco sequential ")
    << bytes(s.mesh) << (s.draco_mesh ? "; bits " + bits_text(i.mesh_bits) : std::string()) << ")\n";
  if (i.garment_first_vertex >= 0) {
    o << "  garment       vertices from " << i.garment_first_vertex << ", faces from " << i.garment_first_face << " ("
      << (i.body_vertex_count - i.garment_first_vertex) << " vertices, " << (s.num_faces - i.garment_first_face)
      << " faces), carrying " << i.garment_gaussians << " Gaussians\n";
  }
  if (!u.avatar.mesh_coverage.empty()) {
    const int n = int(u.avatar.mesh_coverage.size()), cut = vertices_cut(u.avatar);
    std::snprintf(buf, sizeof buf, "%d of %d body vertices (%.1f %%) under the cutoff %g: the mesh is cut around them", cut, n,
                  100.0 * cut / n, double(kCoverageCutoff));
    o << "  coverage      " << buf << " (COLOR_0 alpha, alphaMode MASK)\n";
  }
  if (i.joint_regressor_nonzeros > 0) {
    o << "  skeleton      55 joints, joint regressor " << i.joint_regressor_nonzeros << " nonzeros (" << bytes(s.skeleton) << ")\n";
  } else {
    o << "  skeleton      55 joints, rest joints in the inverse bind matrices (" << bytes(s.skeleton) << ")\n";
  }
  o << "  texture       " << i.texture_mime << " " << i.texture_width << " x " << i.texture_height << " (" << bytes(s.texture) << ")";
  if (i.texture_exact) o << " + exact float32 copy (" << bytes(s.texture_exact) << ")";
  o << "\n";
  if (const auto sp = avatar_texture_speckle(u.avatar)) {
    char sb[200];
    std::snprintf(sb, sizeof sb, "neck %.1f, hands %.1f, feet %.1f per mille (all charts %.1f)", sp->per_mille[0],
                  sp->per_mille[1], sp->per_mille[2], sp->all_per_mille);
    o << "  speckle       " << sb << " (chart texels > " << kSpeckleStep << " luminance off their 5x5 median)\n";
  }
  o << "  correctives   " << (i.pose_correctives.empty() ? std::string("not embedded") : i.pose_correctives + " (" + bytes(s.pose_correctives) + ")");
  if (i.pose_correctives == "sparse_lowrank") {
    o << ": " << i.pose_corrective_blocks << " (vertex, joint) blocks, rank " << i.pose_corrective_rank << ", "
      << (i.pose_corrective_bits > 0 ? std::to_string(i.pose_corrective_bits) + "-bit" : std::string("float32")) << " coefficients";
  }
  o << (i.trained_with_pose_correctives ? "; trained with them" : "; trained without") << "\n";
  o << "  splats        " << (i.splats ? "KHR_gaussian_splatting primitive, skinned in version 3 (" + bytes(s.splats) + ")" : std::string("none")) << "\n";
  for (size_t k = 0; k < u.animations.size(); ++k) {
    const AvatarAnimation& a = u.animations[k];
    std::snprintf(buf, sizeof buf, "%.3g s, %d frames at %.4g fps, ", a.duration, a.frames, animation_rate(a));
    o << (k ? "                " : "  animations    ") << k << " '" << a.name << "': " << buf << bytes(a.bytes) << "\n";
  }
  o << "  JSON          " << bytes(s.json) << "\n";
  o << "  extensions    used:";
  for (auto& e : i.extensions_used) o << " " << e;
  o << "; required:";
  for (auto& e : i.extensions_required) o << " " << e;
  if (i.extensions_required.empty()) o << " none";
  o << "\n";
  o << "storage compared\n";
  std::snprintf(buf, sizeof buf, "%.3f", r.file_vs_paper);
  o << "  this file                          " << bytes(r.file_bytes) << " (" << buf << " x paper)\n";
  std::snprintf(buf, sizeof buf, "%.3f", r.avatar_part_vs_paper);
  o << "  Gaussians + texture in this file   " << bytes(r.avatar_part_bytes) << " (" << buf << " x paper)\n";
  o << "  same Gaussians as 3DGS .ply        " << bytes(r.ply_3dgs_bytes) << " (SH degree 0), "
    << bytes(r.ply_3dgs_sh3_bytes) << " (SH degree 3 layout)\n";
  o << "  paper's accounting                 " << bytes(r.paper_bytes) << " (56 B x " << r.num_gaussians
    << " + 256 x 256 x 3 texture)\n";
  return o.str();
}

}  // namespace haha
