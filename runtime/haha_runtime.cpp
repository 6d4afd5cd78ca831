// The C API (include/haha/haha_runtime.h) over haha::AvatarLoader (format/avatar_loader.h).
// Every entry point runs inside `guarded`, which turns any exception into a status and the
// thread's last-error line: no C++ exception crosses the C boundary.
#include "haha/haha_runtime.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <new>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "body/body_model.h"
#include "core/error.h"
#include "core/parallel.h"
#include "format/avatar_loader.h"
#include "format/avatar_unpack.h"
#include "io/body_model_io.h"
#include "io/image.h"
#include "io/motion.h"

// The header's version macros and CMake's project version must agree (the SONAME is made
// from the latter).
static_assert(HAHA_RUNTIME_VERSION_MAJOR == HAHA_PROJECT_VERSION_MAJOR &&
                  HAHA_RUNTIME_VERSION_MINOR == HAHA_PROJECT_VERSION_MINOR &&
                  HAHA_RUNTIME_VERSION_PATCH == HAHA_PROJECT_VERSION_PATCH,
              "haha_runtime.h version macros differ from project(haha VERSION ...) in CMakeLists.txt");
static_assert(HAHA_NUM_JOINTS == haha::kNumJoints && HAHA_NUM_POSE_VALUES == haha::kNumPoseValues);
static_assert(HAHA_MESH_COVERAGE_CUTOFF == haha::kCoverageCutoff);

struct haha_avatar {
  haha::AvatarLoader rt;
  bool wants_correctives = false;  // trained with pose correctives (the file says so)
};

struct haha_posed {
  const haha_avatar* avatar = nullptr;
  bool posed = false;  // repose has succeeded at least once
  haha::SmplxParams params;
  haha::PosedAvatar frame;
  haha::AvatarRenderScratch scratch;
  std::vector<float> rgb;  // the renderer's float RGB, converted into the caller's format
};

struct haha_motion {
  haha::Motion motion;
};

namespace {

thread_local std::string t_last_error;
thread_local const char* t_error_fallback = nullptr;  // when even the message could not be stored

// An error with its status; thrown inside the library only.
struct ApiError {
  haha_status status;
  std::string message;
};

[[noreturn]] void raise(haha_status status, std::string message) { throw ApiError{status, std::move(message)}; }

haha_status record(haha_status status, const std::string& message) noexcept {
  try {
    t_last_error = message;
    for (char& c : t_last_error)
      if (c == '\n' || c == '\r') c = ' ';  // the promise is one line
    t_error_fallback = nullptr;
  } catch (...) {
    t_last_error.clear();
    t_error_fallback = "haha: out of memory while reporting an error";
  }
  return status;
}

// Runs `body`, mapping exceptions to statuses. A haha::Error that was not already
// classified (ApiError) gets `unclassified`: the status of what the call mostly does.
template <class F>
haha_status guarded(const char* call, haha_status unclassified, F&& body) noexcept {
  try {
    body();
    t_last_error.clear();
    t_error_fallback = nullptr;
    return HAHA_OK;
  } catch (const ApiError& e) {
    return record(e.status, e.message);
  } catch (const haha::Error& e) {
    return record(unclassified, e.what());
  } catch (const std::bad_alloc&) {
    return record(HAHA_ERROR_OUT_OF_MEMORY, std::string(call) + ": out of memory");
  } catch (const std::exception& e) {
    return record(HAHA_ERROR_INTERNAL, std::string(call) + ": " + e.what());
  } catch (...) {
    return record(HAHA_ERROR_INTERNAL, std::string(call) + ": unknown exception");
  }
}

// Runs f, giving any haha::Error it throws the status `status`.
template <class F>
auto classified(haha_status status, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const haha::Error& e) {
    raise(status, e.what());
  }
}

// Constant messages only, so that checks on the per-frame path never allocate; messages
// with numbers are built after an explicit test.
void require(bool ok, const char* call, const char* what) {
  if (!ok) raise(HAHA_ERROR_ARGUMENT, std::string(call) + ": " + what);
}
[[noreturn]] void argument_error(const char* call, const std::string& what) {
  raise(HAHA_ERROR_ARGUMENT, std::string(call) + ": " + what);
}

void require_capacity(const char* call, const char* what, size_t capacity, size_t needed) {
  if (capacity < needed)
    raise(HAHA_ERROR_ARGUMENT, std::string(call) + ": " + what + ": capacity " + std::to_string(capacity) +
                                   " is too small, need " + std::to_string(needed));
}

std::string errno_text(int err) { return std::error_code(err, std::generic_category()).message(); }

// The whole file, or HAHA_ERROR_IO naming it.
std::vector<uint8_t> read_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) raise(HAHA_ERROR_IO, path + ": cannot open: is a directory");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) raise(HAHA_ERROR_IO, path + ": cannot open: " + errno_text(errno));
  std::vector<uint8_t> bytes;
  uint8_t chunk[1 << 16];
  size_t n;
  while ((n = std::fread(chunk, 1, sizeof chunk, f)) > 0) bytes.insert(bytes.end(), chunk, chunk + n);
  const bool failed = std::ferror(f) != 0;
  const int err = errno;
  std::fclose(f);
  if (failed) raise(HAHA_ERROR_IO, path + ": read error: " + errno_text(err));
  return bytes;
}

// Files read by other layers (npz through libzip): opening is checked here so that a
// missing or unreadable file is HAHA_ERROR_IO and the reader's own errors are about content.
void check_readable(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) raise(HAHA_ERROR_IO, path + ": cannot open: is a directory");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) raise(HAHA_ERROR_IO, path + ": cannot open: " + errno_text(errno));
  std::fclose(f);
}

haha_avatar* make_avatar(const uint8_t* data, size_t size, const std::string& name, const char* body_model_path,
                         int32_t max_gaussians = 0) {
  haha::UnpackOptions options;
  options.max_gaussians = max_gaussians;
  haha::UnpackedAvatar u = classified(HAHA_ERROR_FORMAT, [&] { return haha::unpack_avatar(data, size, name, options); });
  // As AvatarLoader::load: the file says whether it was trained with correctives.
  const bool wanted = u.info.trained_with_pose_correctives || !u.info.pose_correctives.empty();
  haha::AvatarLoader rt = classified(HAHA_ERROR_FORMAT, [&] { return haha::AvatarLoader(std::move(u.avatar)); });
  if (body_model_path && !rt.has_pose_correctives()) {
    check_readable(body_model_path);
    const haha::BodyModel model =
        classified(HAHA_ERROR_FORMAT, [&] { return haha::load_body_model(body_model_path); });
    classified(HAHA_ERROR_ARGUMENT, [&] { rt.set_pose_correctives(model); });
  }
  rt.set_animations(std::move(u.animations));
  return new haha_avatar{std::move(rt), wanted};
}

const haha::Avatar& avatar_of(const haha_avatar* a) { return a->rt.avatar(); }

void require_posed(const haha_posed* p, const char* call) {
  require(p != nullptr, call, "posed is NULL");
  if (!p->posed) raise(HAHA_ERROR_STATE, std::string(call) + ": the pose state was never reposed (call haha_repose first)");
}

void require_finite(const char* call, const char* what, const float* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      raise(HAHA_ERROR_ARGUMENT, std::string(call) + ": " + what + "[" + std::to_string(i) + "] is not finite");
}

uint8_t to_byte(float v) {
  // NaN goes to 0 (comparisons are false), like a clamp would for finite values.
  const float c = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;
  return uint8_t(std::lround(c * 255.0f));
}

// Animation `index` of the avatar's file, or HAHA_ERROR_ARGUMENT.
const haha::AvatarAnimation& animation_of(const haha_avatar* avatar, int32_t index, const char* call) {
  require(avatar != nullptr, call, "avatar is NULL");
  const auto& list = avatar->rt.animations();
  if (index < 0 || size_t(index) >= list.size())
    argument_error(call, "animation " + std::to_string(index) + " is not in 0.." + std::to_string(int64_t(list.size()) - 1));
  return list[size_t(index)];
}

}  // namespace

extern "C" {

HAHA_API haha_status haha_version(int* major, int* minor, int* patch) {
  if (major) *major = HAHA_RUNTIME_VERSION_MAJOR;
  if (minor) *minor = HAHA_RUNTIME_VERSION_MINOR;
  if (patch) *patch = HAHA_RUNTIME_VERSION_PATCH;
  t_last_error.clear();
  t_error_fallback = nullptr;
  return HAHA_OK;
}

HAHA_API const char* haha_version_string(void) { return HAHA_PROJECT_VERSION_STRING; }

HAHA_API const char* haha_last_error(void) { return t_error_fallback ? t_error_fallback : t_last_error.c_str(); }

HAHA_API const char* haha_status_string(haha_status status) {
  switch (status) {
    case HAHA_OK: return "HAHA_OK";
    case HAHA_ERROR_ARGUMENT: return "HAHA_ERROR_ARGUMENT";
    case HAHA_ERROR_IO: return "HAHA_ERROR_IO";
    case HAHA_ERROR_FORMAT: return "HAHA_ERROR_FORMAT";
    case HAHA_ERROR_STATE: return "HAHA_ERROR_STATE";
    case HAHA_ERROR_OUT_OF_MEMORY: return "HAHA_ERROR_OUT_OF_MEMORY";
    case HAHA_ERROR_INTERNAL: return "HAHA_ERROR_INTERNAL";
  }
  return "unknown status";
}

HAHA_API haha_status haha_set_num_threads(int n) {
  return guarded("haha_set_num_threads", HAHA_ERROR_ARGUMENT, [&] {
    if (n < 1) argument_error("haha_set_num_threads", "n must be >= 1, not " + std::to_string(n));
    haha::set_num_threads(n);
  });
}

// ---- Avatars --------------------------------------------------------------------------

HAHA_API haha_status haha_avatar_load(const char* path, const char* body_model_path, haha_avatar** out_avatar) {
  return guarded("haha_avatar_load", HAHA_ERROR_FORMAT, [&] {
    require(path != nullptr, "haha_avatar_load", "path is NULL");
    require(out_avatar != nullptr, "haha_avatar_load", "out_avatar is NULL");
    std::vector<uint8_t> bytes = read_file(path);
    *out_avatar = make_avatar(bytes.data(), bytes.size(), path, body_model_path);
  });
}

HAHA_API haha_status haha_avatar_load_lod(const char* path, const char* body_model_path, int32_t max_gaussians,
                                          haha_avatar** out_avatar) {
  return guarded("haha_avatar_load_lod", HAHA_ERROR_FORMAT, [&] {
    require(path != nullptr, "haha_avatar_load_lod", "path is NULL");
    require(out_avatar != nullptr, "haha_avatar_load_lod", "out_avatar is NULL");
    std::vector<uint8_t> bytes = read_file(path);
    *out_avatar = make_avatar(bytes.data(), bytes.size(), path, body_model_path, max_gaussians);
  });
}

HAHA_API haha_status haha_avatar_load_memory(const void* data, size_t size, const char* name,
                                             const char* body_model_path, haha_avatar** out_avatar) {
  return guarded("haha_avatar_load_memory", HAHA_ERROR_FORMAT, [&] {
    const std::string where = name ? name : "<memory>";
    require(data != nullptr || size == 0, "haha_avatar_load_memory", "data is NULL");
    require(out_avatar != nullptr, "haha_avatar_load_memory", "out_avatar is NULL");
    *out_avatar = make_avatar(static_cast<const uint8_t*>(data), size, where, body_model_path);
  });
}

HAHA_API void haha_avatar_free(haha_avatar* avatar) { delete avatar; }

HAHA_API haha_status haha_avatar_get_info(const haha_avatar* avatar, haha_avatar_info* out_info) {
  return guarded("haha_avatar_get_info", HAHA_ERROR_INTERNAL, [&] {
    require(avatar != nullptr, "haha_avatar_get_info", "avatar is NULL");
    require(out_info != nullptr, "haha_avatar_get_info", "out_info is NULL");
    const haha::Avatar& a = avatar_of(avatar);
    haha_avatar_info info{};
    info.num_vertices = a.body.num_verts;
    info.num_faces = a.body.num_faces;
    info.num_gaussians = a.gaussians.size();
    info.num_joints = int32_t(a.body.parents.size());
    info.texture_width = a.texture.width;
    info.texture_height = a.texture.height;
    info.has_pose_correctives = avatar->rt.has_pose_correctives() ? 1 : 0;
    // Not rt.missing_pose_correctives(): a runtime built from an Avatar cannot know what
    // the file said about training (AvatarLoader::load sets that privately).
    info.missing_pose_correctives = avatar->wants_correctives && !avatar->rt.has_pose_correctives() ? 1 : 0;
    *out_info = info;
  });
}

HAHA_API haha_status haha_avatar_faces(const haha_avatar* avatar, uint32_t* indices, size_t capacity) {
  return guarded("haha_avatar_faces", HAHA_ERROR_INTERNAL, [&] {
    require(avatar != nullptr, "haha_avatar_faces", "avatar is NULL");
    require(indices != nullptr, "haha_avatar_faces", "indices is NULL");
    const std::vector<int32_t>& f = avatar_of(avatar).body.faces;
    require_capacity("haha_avatar_faces", "indices", capacity, f.size());
    for (size_t i = 0; i < f.size(); ++i) indices[i] = uint32_t(f[i]);  // validated in range on load
  });
}

HAHA_API haha_status haha_avatar_face_uvs(const haha_avatar* avatar, float* uvs, size_t capacity) {
  return guarded("haha_avatar_face_uvs", HAHA_ERROR_INTERNAL, [&] {
    require(avatar != nullptr, "haha_avatar_face_uvs", "avatar is NULL");
    require(uvs != nullptr, "haha_avatar_face_uvs", "uvs is NULL");
    const haha::BodyModel& b = avatar_of(avatar).body;
    if (b.ft.size() != b.faces.size()) raise(HAHA_ERROR_FORMAT, b.source + ": the avatar has no UV map");
    require_capacity("haha_avatar_face_uvs", "uvs", capacity, b.ft.size() * 2);
    for (size_t i = 0; i < b.ft.size(); ++i) {
      uvs[2 * i] = b.vt[size_t(b.ft[i]) * 2];
      uvs[2 * i + 1] = b.vt[size_t(b.ft[i]) * 2 + 1];
    }
  });
}

HAHA_API haha_status haha_avatar_texture(const haha_avatar* avatar, uint8_t* rgb, size_t capacity) {
  return guarded("haha_avatar_texture", HAHA_ERROR_INTERNAL, [&] {
    require(avatar != nullptr, "haha_avatar_texture", "avatar is NULL");
    const haha::Texture& t = avatar_of(avatar).texture;
    require(rgb != nullptr || t.rgb.empty(), "haha_avatar_texture", "rgb is NULL");
    require_capacity("haha_avatar_texture", "rgb", capacity, t.rgb.size());
    for (size_t i = 0; i < t.rgb.size(); ++i) rgb[i] = to_byte(t.rgb[i]);
  });
}

HAHA_API haha_status haha_avatar_mesh_coverage(const haha_avatar* avatar, float* per_vertex, size_t capacity,
                                               int32_t* has_coverage) {
  return guarded("haha_avatar_mesh_coverage", HAHA_ERROR_INTERNAL, [&] {
    require(avatar != nullptr, "haha_avatar_mesh_coverage", "avatar is NULL");
    const haha::Avatar& a = avatar_of(avatar);
    const size_t V = size_t(a.body.num_verts);
    if (per_vertex) {
      require_capacity("haha_avatar_mesh_coverage", "per_vertex", capacity, V);
      // Without a coverage every vertex draws: 1 keeps one shader path for every avatar.
      for (size_t v = 0; v < V; ++v) per_vertex[v] = a.mesh_coverage.empty() ? 1.0f : a.mesh_coverage[v];
    }
    if (has_coverage) *has_coverage = a.mesh_coverage.empty() ? 0 : 1;
  });
}

// ---- Pose states ------------------------------------------------------------------------

HAHA_API haha_status haha_posed_create(const haha_avatar* avatar, haha_posed** out_posed) {
  return guarded("haha_posed_create", HAHA_ERROR_INTERNAL, [&] {
    require(avatar != nullptr, "haha_posed_create", "avatar is NULL");
    require(out_posed != nullptr, "haha_posed_create", "out_posed is NULL");
    auto* p = new haha_posed;
    p->avatar = avatar;
    *out_posed = p;
  });
}

HAHA_API void haha_posed_free(haha_posed* posed) { delete posed; }

HAHA_API haha_status haha_repose(haha_posed* posed, const float* pose, const float* translation, const float* betas,
                                 size_t num_betas, const float* expression, size_t num_expression) {
  const char* call = "haha_repose";
  return guarded(call, HAHA_ERROR_INTERNAL, [&] {
    require(posed != nullptr, call, "posed is NULL");
    // A packed avatar's rest shape has its betas/expression baked in and no shape blend
    // shapes to apply new ones with (format/avatar_unpack.h).
    require(betas == nullptr && num_betas == 0, call,
            "betas: a packed avatar has its shape baked in, an override cannot be honoured (pass NULL, 0)");
    require(expression == nullptr && num_expression == 0, call,
            "expression: a packed avatar has its expression baked in, an override cannot be honoured (pass NULL, 0)");
    haha::SmplxParams& p = posed->params;
    if (pose) {
      require_finite(call, "pose", pose, HAHA_NUM_POSE_VALUES);
      std::memcpy(p.pose.data(), pose, sizeof(float) * HAHA_NUM_POSE_VALUES);
    } else {
      p.pose.fill(0.0f);
    }
    if (translation) {
      require_finite(call, "translation", translation, 3);
      std::memcpy(p.transl.data(), translation, sizeof(float) * 3);
    } else {
      p.transl.fill(0.0f);
    }
    posed->posed = false;  // stays false if repose throws half-way
    posed->avatar->rt.repose(p, posed->frame);
    posed->posed = true;
  });
}

HAHA_API haha_status haha_posed_vertices(const haha_posed* posed, float* xyz, size_t capacity) {
  return guarded("haha_posed_vertices", HAHA_ERROR_INTERNAL, [&] {
    require_posed(posed, "haha_posed_vertices");
    require(xyz != nullptr, "haha_posed_vertices", "xyz is NULL");
    const std::vector<float>& v = posed->frame.verts;
    require_capacity("haha_posed_vertices", "xyz", capacity, v.size());
    std::memcpy(xyz, v.data(), v.size() * sizeof(float));
  });
}

HAHA_API haha_status haha_posed_normals(const haha_posed* posed, float* xyz, size_t capacity) {
  return guarded("haha_posed_normals", HAHA_ERROR_INTERNAL, [&] {
    require_posed(posed, "haha_posed_normals");
    require(xyz != nullptr, "haha_posed_normals", "xyz is NULL");
    const std::vector<float>& v = posed->frame.verts;
    const std::vector<int32_t>& f = avatar_of(posed->avatar).body.faces;
    require_capacity("haha_posed_normals", "xyz", capacity, v.size());
    std::fill(xyz, xyz + v.size(), 0.0f);
    // The unnormalised cross product is the face normal times twice its area: summing it
    // weights each face by its area.
    for (size_t t = 0; t + 2 < f.size(); t += 3) {
      const float* a = &v[size_t(f[t]) * 3];
      const float* b = &v[size_t(f[t + 1]) * 3];
      const float* c = &v[size_t(f[t + 2]) * 3];
      const float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      const float e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      for (int k = 0; k < 3; ++k)
        for (int c3 = 0; c3 < 3; ++c3) xyz[size_t(f[t + k]) * 3 + c3] += n[c3];
    }
    for (size_t i = 0; i < v.size(); i += 3) {
      const float len = std::sqrt(xyz[i] * xyz[i] + xyz[i + 1] * xyz[i + 1] + xyz[i + 2] * xyz[i + 2]);
      if (len > 0.0f && std::isfinite(len)) {
        for (int c3 = 0; c3 < 3; ++c3) xyz[i + c3] /= len;
      } else {
        for (int c3 = 0; c3 < 3; ++c3) xyz[i + c3] = 0.0f;
      }
    }
  });
}

HAHA_API haha_status haha_posed_joints(const haha_posed* posed, float* xyz, size_t capacity) {
  return guarded("haha_posed_joints", HAHA_ERROR_INTERNAL, [&] {
    require_posed(posed, "haha_posed_joints");
    require(xyz != nullptr, "haha_posed_joints", "xyz is NULL");
    const std::vector<float>& j = posed->frame.joints;
    require_capacity("haha_posed_joints", "xyz", capacity, j.size());
    std::memcpy(xyz, j.data(), j.size() * sizeof(float));
  });
}

HAHA_API haha_status haha_posed_gaussians(const haha_posed* posed, const haha_gaussian_arrays* out) {
  const char* call = "haha_posed_gaussians";
  return guarded(call, HAHA_ERROR_INTERNAL, [&] {
    require_posed(posed, call);
    require(out != nullptr, call, "out is NULL");
    const haha::PosedAvatar& f = posed->frame;
    const size_t n = size_t(f.num_gaussians);
    require_capacity(call, "out->capacity (Gaussians)", out->capacity, n);
    auto copy = [n](float* dst, const float* src, size_t width) {
      if (dst && n) std::memcpy(dst, src, n * width * sizeof(float));
    };
    copy(out->means, f.means.data(), 3);
    copy(out->rotations, f.quats.data(), 4);
    copy(out->scales, f.scales.data(), 3);
    copy(out->colors, f.colors, 3);
    copy(out->opacities, f.opacities, 1);
  });
}

// ---- Rendering ----------------------------------------------------------------------------

HAHA_API haha_status haha_render(haha_posed* posed, const haha_camera* camera, const float* background, uint32_t flags,
                                 haha_pixel_format format, void* pixels, size_t capacity_bytes) {
  const char* call = "haha_render";
  return guarded(call, HAHA_ERROR_ARGUMENT, [&] {
    require_posed(posed, call);
    require(camera != nullptr, call, "camera is NULL");
    require(pixels != nullptr, call, "pixels is NULL");
    const haha_camera& c = *camera;
    if (!(c.width >= 1 && c.width <= 16384 && c.height >= 1 && c.height <= 16384))
      argument_error(call, "camera size " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                               " is not in 1..16384");
    require(std::isfinite(c.fx) && std::isfinite(c.fy) && c.fx > 0 && c.fy > 0 && std::isfinite(c.cx) &&
                std::isfinite(c.cy),
            call, "camera intrinsics must be finite with fx, fy > 0");
    require_finite(call, "camera rotation", c.rotation, 9);
    require_finite(call, "camera translation", c.translation, 3);
    if (flags & ~(HAHA_RENDER_NO_MESH | HAHA_RENDER_NO_GAUSSIANS)) argument_error(call, "unknown flags " + std::to_string(flags));
    int channels = 0;
    size_t bytes_per_value = 0;
    // A C caller may pass any int: read it as one (loading an out-of-range enum is UB in C++).
    int format_value;
    static_assert(sizeof format_value == sizeof format);
    std::memcpy(&format_value, &format, sizeof format_value);
    switch (format_value) {
      case HAHA_PIXEL_RGB8: channels = 3, bytes_per_value = 1; break;
      case HAHA_PIXEL_RGBA8: channels = 4, bytes_per_value = 1; break;
      case HAHA_PIXEL_RGB32F: channels = 3, bytes_per_value = 4; break;
      case HAHA_PIXEL_RGBA32F: channels = 4, bytes_per_value = 4; break;
      default: argument_error(call, "unknown pixel format " + std::to_string(format_value));
    }
    const size_t P = size_t(c.width) * size_t(c.height);
    require_capacity(call, "pixels (bytes)", capacity_bytes, P * size_t(channels) * bytes_per_value);
    require(bytes_per_value == 1 || reinterpret_cast<uintptr_t>(pixels) % alignof(float) == 0, call,
            "float pixels must be 4-byte aligned");

    haha::Camera cam;
    cam.width = c.width;
    cam.height = c.height;
    cam.fx = c.fx, cam.fy = c.fy, cam.cx = c.cx, cam.cy = c.cy;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) cam.R.a[i][j] = c.rotation[i * 3 + j];
    cam.t = haha::Vec3f(c.translation[0], c.translation[1], c.translation[2]);
    if (c.near_plane > 0) cam.near_plane = c.near_plane;
    if (c.far_plane > 0) cam.far_plane = c.far_plane;
    require(std::isfinite(cam.near_plane) && std::isfinite(cam.far_plane) && cam.far_plane > cam.near_plane, call,
            "camera far_plane must be greater than near_plane");

    haha::AvatarRenderOptions opt;
    if (background) {
      require_finite(call, "background", background, 3);
      for (int k = 0; k < 3; ++k) opt.background[k] = background[k];
    }
    opt.draw_mesh = !(flags & HAHA_RENDER_NO_MESH);
    opt.draw_gaussians = !(flags & HAHA_RENDER_NO_GAUSSIANS);
    posed->avatar->rt.render(cam, posed->frame, posed->rgb, opt, posed->scratch);

    // Coverage: Gaussians A over the mesh mask m (render/merge.h), for the alpha channel.
    const haha::AvatarRenderBuffers& buf = posed->scratch.buffers;
    const float* A = buf.alpha.size() == P ? buf.alpha.data() : nullptr;
    const float* m = buf.mesh.mask;
    const float* rgb = posed->rgb.data();
    const bool bytes = bytes_per_value == 1;
    auto* out8 = static_cast<uint8_t*>(pixels);
    auto* out32 = static_cast<float*>(pixels);
    haha::parallel_for(int64_t(P), [&](int64_t i) {
      const float a = A ? A[i] : 0.0f;
      const float alpha = a + (1.0f - a) * (m ? m[i] : 0.0f);
      for (int k = 0; k < channels; ++k) {
        const float v = k < 3 ? rgb[size_t(i) * 3 + size_t(k)] : alpha;
        if (bytes) {
          out8[size_t(i) * size_t(channels) + size_t(k)] = to_byte(v);
        } else {
          out32[size_t(i) * size_t(channels) + size_t(k)] = v;
        }
      }
    });
  });
}

// ---- Motions and images -------------------------------------------------------------------

HAHA_API haha_status haha_avatar_animation_count(const haha_avatar* avatar, int32_t* count) {
  return guarded("haha_avatar_animation_count", HAHA_ERROR_INTERNAL, [&] {
    require(avatar != nullptr, "haha_avatar_animation_count", "avatar is NULL");
    require(count != nullptr, "haha_avatar_animation_count", "count is NULL");
    *count = int32_t(avatar->rt.animations().size());
  });
}

HAHA_API haha_status haha_avatar_animation_info(const haha_avatar* avatar, int32_t index, char* name, size_t name_capacity,
                                                double* duration, int32_t* frames, double* fps) {
  const char* call = "haha_avatar_animation_info";
  return guarded(call, HAHA_ERROR_INTERNAL, [&] {
    const haha::AvatarAnimation& a = animation_of(avatar, index, call);
    if (name) require_capacity(call, "name", name_capacity, a.name.size() + 1);
    if (name) std::memcpy(name, a.name.c_str(), a.name.size() + 1);
    if (duration) *duration = a.duration;
    if (frames) *frames = a.frames;
    if (fps) *fps = haha::animation_rate(a);
  });
}

HAHA_API haha_status haha_avatar_sample_animation(const haha_avatar* avatar, int32_t index, double time, float* pose,
                                                  float* translation) {
  const char* call = "haha_avatar_sample_animation";
  return guarded(call, HAHA_ERROR_INTERNAL, [&] {
    const haha::AvatarAnimation& a = animation_of(avatar, index, call);
    if (!std::isfinite(time)) argument_error(call, "time is not finite");
    const haha::SmplxParams p = haha::sample_animation(a, time);
    if (pose) std::memcpy(pose, p.pose.data(), sizeof(float) * HAHA_NUM_POSE_VALUES);
    if (translation) std::memcpy(translation, p.transl.data(), sizeof(float) * 3);
  });
}

HAHA_API haha_status haha_motion_load(const char* path, haha_motion** out_motion) {
  return guarded("haha_motion_load", HAHA_ERROR_FORMAT, [&] {
    require(path != nullptr, "haha_motion_load", "path is NULL");
    require(out_motion != nullptr, "haha_motion_load", "out_motion is NULL");
    check_readable(path);
    haha::Motion m = classified(HAHA_ERROR_FORMAT, [&] { return haha::read_motion(path); });
    if (m.frames.empty()) raise(HAHA_ERROR_FORMAT, std::string(path) + ": no frames");
    *out_motion = new haha_motion{std::move(m)};
  });
}

HAHA_API haha_status haha_motion_load_for_avatar(const char* path, const haha_avatar* avatar, haha_motion** out_motion) {
  return guarded("haha_motion_load_for_avatar", HAHA_ERROR_FORMAT, [&] {
    require(path != nullptr, "haha_motion_load_for_avatar", "path is NULL");
    require(avatar != nullptr, "haha_motion_load_for_avatar", "avatar is NULL");
    require(out_motion != nullptr, "haha_motion_load_for_avatar", "out_motion is NULL");
    check_readable(path);
    haha::Motion m = classified(HAHA_ERROR_FORMAT, [&] { return haha::read_motion(path); });
    if (m.frames.empty()) raise(HAHA_ERROR_FORMAT, std::string(path) + ": no frames");
    // AMASS is Z-up: turn it about this avatar's rest pelvis (io/motion.h).
    haha::PosedAvatar rest;
    avatar->rt.repose(haha::SmplxParams{}, rest);
    haha::motion_to_y_up(m, {rest.joints[0], rest.joints[1], rest.joints[2]});
    *out_motion = new haha_motion{std::move(m)};
  });
}

HAHA_API void haha_motion_free(haha_motion* motion) { delete motion; }

HAHA_API haha_status haha_motion_info(const haha_motion* motion, int32_t* num_frames, double* fps) {
  return guarded("haha_motion_info", HAHA_ERROR_INTERNAL, [&] {
    require(motion != nullptr, "haha_motion_info", "motion is NULL");
    if (num_frames) *num_frames = int32_t(motion->motion.frames.size());
    if (fps) *fps = motion->motion.fps;
  });
}

HAHA_API haha_status haha_motion_frame(const haha_motion* motion, int32_t frame, float* pose, float* translation) {
  return guarded("haha_motion_frame", HAHA_ERROR_INTERNAL, [&] {
    require(motion != nullptr, "haha_motion_frame", "motion is NULL");
    const auto& frames = motion->motion.frames;
    if (frame < 0 || size_t(frame) >= frames.size())
      argument_error("haha_motion_frame",
                     "frame " + std::to_string(frame) + " is not in 0.." + std::to_string(int64_t(frames.size()) - 1));
    const haha::SmplxParams& p = frames[size_t(frame)];
    if (pose) std::memcpy(pose, p.pose.data(), sizeof(float) * HAHA_NUM_POSE_VALUES);
    if (translation) std::memcpy(translation, p.transl.data(), sizeof(float) * 3);
  });
}

HAHA_API haha_status haha_write_png(const char* path, int32_t width, int32_t height, int32_t channels,
                                    const uint8_t* pixels) {
  const char* call = "haha_write_png";
  return guarded(call, HAHA_ERROR_IO, [&] {
    require(path != nullptr, call, "path is NULL");
    const std::string p = path;
    if (p.size() <= 4 || p.compare(p.size() - 4, 4, ".png") != 0) argument_error(call, p + ": the name must end in .png");
    if (width < 1 || height < 1 || width > 65535 || height > 65535)
      argument_error(call, p + ": size " + std::to_string(width) + "x" + std::to_string(height) + " is not in 1..65535");
    if (channels < 1 || channels > 4) argument_error(call, p + ": channels must be 1..4, not " + std::to_string(channels));
    require(pixels != nullptr, call, "pixels is NULL");
    haha::Image img(width, height, channels);
    for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = float(pixels[i]) / 255.0f;  // exact on write
    haha::write_image(p, img);
  });
}

}  // extern "C"
