#include "app/run_dir.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "format/avatar_npz.h"
#include "format/avatar_validate.h"
#include "io/body_model_io.h"
#include "io/npy.h"

namespace haha {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

constexpr const char* kRunFormat = "haha-run";
constexpr int kRunVersion = 1;

}  // namespace

std::string RunDir::file(const std::string& name) const { return (fs::path(dir) / name).string(); }

// ---- config.json ------------------------------------------------------------------------

std::string run_info_to_json(const RunInfo& info) {
  ojson j;
  if (!info.trained) {  // only the body model (and where the avatar was unpacked from)
    j["model"] = info.model_path;
    if (!info.unpacked_from.empty()) j["unpacked_from"] = info.unpacked_from;
    return j.dump(2) + "\n";
  }
  j["format"] = kRunFormat;
  j["version"] = kRunVersion;
  j["model"] = info.model_path;
  j["data"] = info.data_path;
  j["lpips_weights"] = info.lpips_weights_path.empty() ? ojson(nullptr) : ojson(info.lpips_weights_path);
  ojson c = ojson::object();
  TrainConfig copy = info.config;
  for (const ConfigEntry& e : config_entries(copy)) {
    switch (e.kind) {
      case ConfigEntry::Kind::Int: c[e.key] = *static_cast<int*>(e.ptr); break;
      case ConfigEntry::Kind::Uint64: c[e.key] = *static_cast<uint64_t*>(e.ptr); break;
      case ConfigEntry::Kind::Double: c[e.key] = *static_cast<double*>(e.ptr); break;
      case ConfigEntry::Kind::Bool: c[e.key] = *static_cast<bool*>(e.ptr); break;
      default: c[e.key] = config_value_string(e); break;
    }
  }
  j["config"] = c;
  return j.dump(2) + "\n";
}

void write_run_info(const RunDir& run, const RunInfo& info) { write_text_file(run.config(), run_info_to_json(info)); }

RunInfo read_run_info(const RunDir& run) {
  const std::string path = run.config();
  if (!fs::exists(path)) fail(path, "missing (a run directory needs config.json naming the body model)");
  ojson j;
  try {
    j = ojson::parse(read_text_file(path));
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) fail(path, "not a haha run config (expected a JSON object)");
  RunInfo r;
  auto str = [&](const char* k) -> std::string {
    if (!j.contains(k) || !j[k].is_string()) fail(path, std::string(k) + ": expected a string");
    return j[k].get<std::string>();
  };
  // A relative model path is looked up in the run directory first.
  const fs::path model = str("model");
  r.model_path = model.is_absolute() || !fs::exists(fs::path(run.dir) / model) ? model.string()
                                                                              : (fs::path(run.dir) / model).string();
  if (!j.contains("format")) {  // an unpacked or hand-made avatar directory: no training config
    r.trained = false;
    if (j.contains("unpacked_from")) r.unpacked_from = str("unpacked_from");
    return r;
  }
  if (j.value("format", "") != kRunFormat) fail(path, "format: not a haha run config");
  if (j.value("version", 0) != kRunVersion) fail(path, "version: unsupported");
  r.data_path = str("data");
  if (j.contains("lpips_weights") && j["lpips_weights"].is_string()) r.lpips_weights_path = j["lpips_weights"];
  if (!j.contains("config") || !j["config"].is_object()) fail(path, "config: expected an object");
  r.config = TrainConfig{};
  for (const auto& [k, v] : j["config"].items()) {
    std::string text;
    if (v.is_string())
      text = v.get<std::string>();
    else if (v.is_boolean())
      text = v.get<bool>() ? "true" : "false";
    else if (v.is_number_unsigned())
      text = std::to_string(v.get<uint64_t>());
    else if (v.is_number_integer())
      text = std::to_string(v.get<int64_t>());
    else if (v.is_number_float()) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.17g", v.get<double>());
      text = buf;
    } else {
      fail(path, "config: " + k + ": unsupported value");
    }
    set_config_value(r.config, k, text, path + ": config");
  }
  return r;
}

RunInfo read_trained_run_info(const RunDir& run, const std::string& what) {
  RunInfo r = read_run_info(run);
  if (!r.trained)
    fail(run.config(), what + " needs a trained run (this config names only a body model" +
                           (r.unpacked_from.empty() ? std::string(")") : "; unpacked from " + r.unpacked_from + ")"));
  return r;
}

std::vector<float> read_texture_evidence(const RunDir& run, int size) {
  const std::string path = run.texture_evidence();
  if (!std::filesystem::exists(path)) return {};
  const NpyArray a = read_npy(path);
  if (a.shape != std::vector<int64_t>{size, size})
    fail(path, "expected a (" + std::to_string(size) + ", " + std::to_string(size) +
                   ") array, the texture's size (a run trained with another s2.texture_size?)");
  std::vector<float> e = a.as_float();
  for (float v : e)
    if (!std::isfinite(v) || v < 0) fail(path, "holds a negative or non-finite evidence value");
  return e;
}

std::array<double, 3> read_train_seconds(const RunDir& run) {
  const std::string path = run.train_summary();
  std::array<double, 3> out{0, 0, 0};
  if (!fs::exists(path)) return out;
  try {
    const ojson j = ojson::parse(read_text_file(path));
    const ojson& s = j.at("stage_seconds");
    for (size_t i = 0; i < 3 && i < s.size(); ++i) out[i] = s[i].get<double>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("stage_seconds: ") + e.what());
  }
  return out;
}

// ---- checkpoints ------------------------------------------------------------------------

void write_checkpoint(const std::string& path, const TrainCheckpoint& ck) {
  Npz z(path);
  for (const auto& [k, v] : ck.f32) z.set("f32/" + k, NpyArray::from(v, {int64_t(v.size())}));
  for (const auto& [k, v] : ck.i32) z.set("i32/" + k, NpyArray::from(v, {int64_t(v.size())}));
  for (const auto& [k, v] : ck.f64) z.set("f64/" + k, NpyArray::from(v, {int64_t(v.size())}));
  z.write(path);
}

TrainCheckpoint read_checkpoint(const std::string& path) {
  const Npz z = Npz::read(path);
  TrainCheckpoint ck;
  for (const std::string& k : z.keys()) {
    const NpyArray& a = z.get(k);
    if (k.rfind("f32/", 0) == 0) {
      if (a.dtype != DType::f32) fail(path, k + ": expected float32");
      ck.f32[k.substr(4)] = a.as_float();
    } else if (k.rfind("i32/", 0) == 0) {
      if (a.dtype != DType::i32) fail(path, k + ": expected int32");
      ck.i32[k.substr(4)] = a.as_int32();
    } else if (k.rfind("f64/", 0) == 0) {
      if (a.dtype != DType::f64) fail(path, k + ": expected float64");
      ck.f64[k.substr(4)] = a.as_double();
    }
  }
  if (ck.i32.count("meta.version") == 0) fail(path, "not a haha training checkpoint (meta.version missing)");
  return ck;
}

// ---- avatars ------------------------------------------------------------------------------

Avatar load_run_avatar(const RunDir& run, const std::string& model_path) {
  if (!fs::is_directory(run.dir)) fail(run.dir, "not a directory (expected a trained run directory)");
  Avatar a = load_avatar_npz(run.avatar());
  attach_body(a, load_body_model(model_path.empty() ? read_run_info(run).model_path : model_path), run.avatar());
  validate_gaussians(a.gaussians, a.body.num_faces, run.avatar());
  return a;
}

Avatar load_stage1_avatar(const RunDir& run, const BodyModel& body) {
  Avatar a = load_avatar_npz(run.stage1_avatar());
  attach_body(a, body, run.stage1_avatar());
  validate_gaussians(a.gaussians, a.body.num_faces, run.stage1_avatar());
  return a;
}

namespace {

// The body part of a body with a garment appended (body/garment.h), its UVs back in the
// whole texture: the body model of an unpacked run, to which load_run_avatar appends the
// garment avatar.npz keeps (append_garment shrinks the body's UVs again).
BodyModel body_without_garment(const BodyModel& b) {
  if (!b.has_garment()) return b;
  const size_t V = size_t(b.garment_first_vert), F = size_t(b.garment_first_face), T = size_t(b.garment_first_uv);
  BodyModel out = b;
  out.num_verts = int(V);
  out.num_faces = int(F);
  out.v_template.resize(V * 3);
  out.faces.resize(F * 3);
  out.ft.resize(F * 3);
  out.vt.resize(T * 2);
  for (size_t i = 0; i < out.vt.size(); i += 2) out.vt[i] = std::min(1.0f, out.vt[i] / (1.0f - b.garment_chart));
  out.weights.resize(V * kNumJoints);
  if (!b.posedirs.empty()) out.posedirs.resize(V * 3 * kNumPoseFeatures);
  if (!b.shapedirs.empty()) out.shapedirs.resize(b.shapedirs.size() / size_t(b.num_verts) * V);
  if (!b.j_regressor.empty()) {
    out.j_regressor.assign(size_t(kNumJoints) * V, 0.0f);
    for (size_t j = 0; j < size_t(kNumJoints); ++j)
      std::copy_n(&b.j_regressor[j * size_t(b.num_verts)], V, &out.j_regressor[j * V]);
  }
  out.rest_offsets.clear();
  out.garment_first_vert = out.garment_first_face = out.garment_first_uv = 0;
  out.garment_chart = 0;
  return out;
}

}  // namespace

void write_unpacked_run(const RunDir& run, const Avatar& avatar, const std::string& unpacked_from) {
  save_avatar_npz(avatar, run.avatar());  // with the garment, when the body carries one
  save_body_model(body_without_garment(avatar.body), run.file("body.npz"));
  RunInfo info;
  info.trained = false;
  info.model_path = "body.npz";
  info.unpacked_from = unpacked_from;
  write_run_info(run, info);
}

}  // namespace haha
