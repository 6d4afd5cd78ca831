/* haha_runtime.h: the C API of the haha avatar runtime (libhaha_runtime.so).
 *
 * Load a packed HAHA avatar (.glb, format/spec.md), repose it from SMPL-X pose parameters,
 * and either read back the posed mesh and Gaussians for your own renderer or render it
 * with the built-in merged renderer (the trainer's own: textured mesh + Gaussians).
 * Plain C99, usable from C++; no C++ exception ever leaves the library.
 *
 *   haha_avatar* avatar;  haha_posed* posed;  haha_avatar_info info;
 *   if (haha_avatar_load("avatar.glb", NULL, &avatar) != HAHA_OK) {
 *     fprintf(stderr, "%s\n", haha_last_error());   // "avatar.glb: cannot open: ..."
 *     return 1;
 *   }
 *   haha_avatar_get_info(avatar, &info);
 *   haha_posed_create(avatar, &posed);
 *   float pose[HAHA_NUM_POSE_VALUES] = {0}, transl[3] = {0};
 *   pose[3 * 16 + 2] = -1.0f;                       // left shoulder (joint 16) down
 *   haha_repose(posed, pose, transl, NULL, 0, NULL, 0);
 *   float* verts = malloc(3 * sizeof(float) * info.num_vertices);
 *   haha_posed_vertices(posed, verts, 3 * (size_t)info.num_vertices);   // your renderer
 *   haha_render(posed, &camera, NULL, 0, HAHA_PIXEL_RGB8, rgb, 3 * (size_t)w * h);  // or ours
 *   free(verts);  haha_posed_free(posed);  haha_avatar_free(avatar);
 * (samples/c/haha_sample_c.c is a complete program.)
 *
 * Conventions (the project's, docs/architecture.md "Conventions"):
 *   - SMPL-X rest frame, metres, Y up, body facing +Z. A pose is 55 joints x axis-angle
 *     (165 floats: global orient, 21 body, jaw, left eye, right eye, 15 left-hand, 15
 *     right-hand joints) plus a 3-float translation.
 *   - Cameras are OpenCV pinholes (x right, y down, z forward) with world-to-camera
 *     extrinsics; pixel (i, j) covers [i, i+1) x [j, j+1), so its centre is (i+0.5, j+0.5).
 *   - Quaternions are (w, x, y, z). Images are row-major, top row first, channels
 *     interleaved, rows tightly packed.
 *
 * Errors: every call that can fail returns a haha_status. On failure haha_last_error()
 * gives one line naming the file (or the call) and the problem, as "avatar.glb: gaussians:
 * checksum mismatch". Output parameters are left untouched on failure.
 *
 * Memory: every object the library allocates (haha_avatar, haha_posed, haha_motion) is
 * freed by its own haha_*_free call (NULL is accepted and ignored). Every array the caller
 * reads back is a caller-allocated buffer passed with its capacity, in elements of the
 * pointer's type unless the call says otherwise (bytes for haha_render, Gaussians for
 * haha_posed_gaussians); a capacity smaller than needed is HAHA_ERROR_ARGUMENT and nothing
 * is written. The library keeps no pointer to caller memory after a call returns.
 *
 * Threads:
 *   - haha_avatar and haha_motion are immutable after loading: any number of threads may
 *     use one at the same time, in every call that takes it as const: haha_avatar_get_info,
 *     haha_avatar_faces, haha_avatar_face_uvs, haha_avatar_texture,
 *     haha_avatar_mesh_coverage, haha_posed_create,
 *     haha_motion_load_for_avatar, haha_motion_info, haha_motion_frame,
 *     haha_avatar_animation_count, haha_avatar_animation_info,
 *     haha_avatar_sample_animation; also while pose
 *     states made from the avatar repose and render in other threads.
 *   - haha_posed is one pose state with its render scratch: one thread at a time
 *     (haha_repose, haha_posed_*, haha_render on the same haha_posed must not overlap).
 *     Distinct haha_posed objects, even of the same avatar, may be used concurrently:
 *     create one per thread (or per character) to repose/render in parallel.
 *   - Calls on distinct objects do not interfere: loads (from the same file too) and every
 *     other call may run in any number of threads at once; haha_write_png to distinct paths.
 *   - Free a haha_avatar only after every haha_posed made from it is freed and no call
 *     on it is running; free a haha_motion only when no call on it is running.
 *   - haha_last_error() is per thread.
 *   - repose and render run OpenMP-parallel internally; haha_set_num_threads limits that
 *     for the calling thread only (a new thread starts with the default).
 * tests/runtime/runtime_stress_test.cpp holds the library to this under ASan and TSan.
 */
#ifndef HAHA_RUNTIME_H
#define HAHA_RUNTIME_H

#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__) || defined(__clang__)
#define HAHA_API __attribute__((visibility("default")))
#else
#define HAHA_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* The version of this header. haha_version() reports the library's: a program built
 * against one minor version needs a library with the same major.minor (0.x: no ABI
 * promise across minor versions; the SONAME is libhaha_runtime.so.MAJOR.MINOR). */
#define HAHA_RUNTIME_VERSION_MAJOR 0
#define HAHA_RUNTIME_VERSION_MINOR 1
#define HAHA_RUNTIME_VERSION_PATCH 0

#define HAHA_NUM_JOINTS 55        /* SMPL-X skin joints */
#define HAHA_NUM_POSE_VALUES 165  /* 55 joints x axis-angle */

typedef enum haha_status {
  HAHA_OK = 0,
  HAHA_ERROR_ARGUMENT = 1,      /* NULL where an object is required, a value out of range,
                                   a buffer too small, an option that cannot be honoured */
  HAHA_ERROR_IO = 2,            /* a file could not be opened, read or written */
  HAHA_ERROR_FORMAT = 3,        /* a file's contents are invalid: not a .glb / .npz,
                                   truncated, checksum mismatch, unsupported version, ... */
  HAHA_ERROR_STATE = 4,         /* wrong call order (reading a pose state never reposed) */
  HAHA_ERROR_OUT_OF_MEMORY = 5,
  HAHA_ERROR_INTERNAL = 6       /* anything else: a bug, please report haha_last_error() */
} haha_status;

typedef struct haha_avatar haha_avatar;  /* a loaded avatar (opaque) */
typedef struct haha_posed haha_posed;    /* one pose state of an avatar + render scratch */
typedef struct haha_motion haha_motion;  /* a loaded motion (sequence of poses) */

/* ---- Version and errors (cannot fail) ---------------------------------------------- */

/* The library's version numbers; any pointer may be NULL. Always HAHA_OK. */
HAHA_API haha_status haha_version(int* major, int* minor, int* patch);
/* "0.1.0"; a static string owned by the library. */
HAHA_API const char* haha_version_string(void);
/* The last error of the calling thread: one line, "" after a successful call. Every call
 * returning a haha_status sets it. The pointer is owned by the library and valid until
 * the next haha_* call in the same thread: copy it if you keep it. */
HAHA_API const char* haha_last_error(void);
/* "HAHA_OK", "HAHA_ERROR_IO", ...; a static string ("unknown status" for other values). */
HAHA_API const char* haha_status_string(haha_status status);

/* OpenMP threads used by repose and render started from the calling thread (OpenMP's
 * per-thread setting; the default is one per core). n >= 1, else HAHA_ERROR_ARGUMENT. */
HAHA_API haha_status haha_set_num_threads(int n);

/* ---- Avatars ------------------------------------------------------------------------- */

/* Loads and validates a .glb avatar. Everything is checked (structure, checksums,
 * versions, index ranges, NaN): a bad file gives HAHA_ERROR_IO (cannot open/read) or
 * HAHA_ERROR_FORMAT (contents), never a crash.
 * body_model_path (may be NULL): the SMPL-X body model .npz the avatar was trained with.
 * It supplies the pose-corrective blend shapes when the file does not embed them, so
 * reposes match the trainer's exactly; it is ignored when the file embeds them. A model
 * whose mesh is not the avatar's is HAHA_ERROR_ARGUMENT.
 * On success *out_avatar is a new avatar the caller frees with haha_avatar_free. */
HAHA_API haha_status haha_avatar_load(const char* path, const char* body_model_path, haha_avatar** out_avatar);

/* The same from the file's bytes in memory (size bytes at data). name (may be NULL:
 * "<memory>") names the buffer in error messages. The bytes are decoded during the call:
 * the caller may free them as soon as it returns. */
HAHA_API haha_status haha_avatar_load_memory(const void* data, size_t size, const char* name,
                                             const char* body_model_path, haha_avatar** out_avatar);

/* As haha_avatar_load, for a file packed with importance tiers (haha pack --lod): loads
 * only the tiers whose running Gaussian count stays within max_gaussians (the first tier
 * always), e.g. for a distant avatar. max_gaussians <= 0, or a file without tiers: every
 * Gaussian. */
HAHA_API haha_status haha_avatar_load_lod(const char* path, const char* body_model_path, int32_t max_gaussians,
                                          haha_avatar** out_avatar);

/* Frees an avatar (NULL: no-op). Free its haha_posed objects first. */
HAHA_API void haha_avatar_free(haha_avatar* avatar);

typedef struct haha_avatar_info {
  int32_t num_vertices;    /* V: body vertices (the file's body-vertex order; glTF vertices
                              split at UV seams are merged back) */
  int32_t num_faces;       /* F: triangles */
  int32_t num_gaussians;   /* N */
  int32_t num_joints;      /* skin joints: 55 */
  int32_t texture_width;   /* pixels; 0 if the avatar has no texture */
  int32_t texture_height;
  int32_t has_pose_correctives;      /* 1: reposes apply pose-corrective blend shapes
                                        (embedded in the file or from the body model) */
  int32_t missing_pose_correctives;  /* 1: the avatar was trained with pose correctives but
                                        this runtime has none: pass body_model_path to
                                        match the trainer under strong poses */
} haha_avatar_info;

/* Counts and metadata. Thread-safe. */
HAHA_API haha_status haha_avatar_get_info(const haha_avatar* avatar, haha_avatar_info* out_info);

/* Triangle vertex indices (F x 3, into the V body vertices) in the body model's winding
 * (SMPL-X: counter-clockwise seen from outside). capacity >= 3 * num_faces elements.
 * Pose-independent. */
HAHA_API haha_status haha_avatar_faces(const haha_avatar* avatar, uint32_t* indices, size_t capacity);

/* Texture coordinates per face corner (F x 3 x (u, v)), in the same order as the faces:
 * UV seams make them per corner, not per vertex. v points up (OBJ / OpenGL): v = 1 is the
 * top row of haha_avatar_texture. capacity >= 6 * num_faces floats. */
HAHA_API haha_status haha_avatar_face_uvs(const haha_avatar* avatar, float* uvs, size_t capacity);

/* The texture as 8-bit RGB (H x W x 3, top row first; values as stored, display-encoded
 * like the training images, no colour-space conversion).
 * capacity >= 3 * texture_width * texture_height bytes. */
HAHA_API haha_status haha_avatar_texture(const haha_avatar* avatar, uint8_t* rgb, size_t capacity);

/* The mesh's coverage (haha pack writes it as COLOR_0 alpha with alphaMode MASK): one value
 * in [0, 1] per body vertex (V, the order of haha_avatar_faces). The textured mesh draws a
 * point only where the perspective-correct barycentric interpolation of its face's three
 * values is >= HAHA_MESH_COVERAGE_CUTOFF, so an engine that draws the mesh itself
 * discards the other fragments (an alpha test), in its depth pass too: the Gaussians and
 * the background show there. per_vertex (may be NULL: only the flag) gets V floats,
 * capacity >= num_vertices; an avatar without a coverage gives 1 everywhere (the whole
 * mesh draws). has_coverage (may be NULL): 1 when the file carries one, else 0. */
#define HAHA_MESH_COVERAGE_CUTOFF 0.5f
HAHA_API haha_status haha_avatar_mesh_coverage(const haha_avatar* avatar, float* per_vertex, size_t capacity,
                                               int32_t* has_coverage);
/* ---- Pose states ------------------------------------------------------------------- */

/* A new pose state of `avatar` (which must outlive it), in no pose yet: call haha_repose
 * before reading it back or rendering it (else HAHA_ERROR_STATE). Free with
 * haha_posed_free. It owns the posed arrays and the render scratch and reuses them from
 * frame to frame (keep one per character rather than creating one per frame). */
HAHA_API haha_status haha_posed_create(const haha_avatar* avatar, haha_posed** out_posed);
HAHA_API void haha_posed_free(haha_posed* posed);

/* Poses the avatar: LBS of the body (with pose correctives if present), then every
 * Gaussian follows its face (mu' = k R mu + T).
 *   pose: HAHA_NUM_POSE_VALUES (165) axis-angle floats, SMPL-X joint order; NULL = rest.
 *   translation: 3 floats added to every vertex; NULL = 0.
 *   betas / expression: a shape override CANNOT be honoured: a packed avatar stores the
 *   subject's rest shape with its betas and expression baked in (no shape blend shapes).
 *   Pass NULL, 0 for both; anything else is HAHA_ERROR_ARGUMENT. (The parameters exist so
 *   a future file version with shape directions can honour them without an API change.)
 * Non-finite pose or translation values are HAHA_ERROR_ARGUMENT. An argument error leaves
 * the previous pose in place. */
HAHA_API haha_status haha_repose(haha_posed* posed, const float* pose, const float* translation, const float* betas,
                                 size_t num_betas, const float* expression, size_t num_expression);

/* Posed body vertices (V x 3, world space, metres), in the file's body-vertex order, as
 * indexed by haha_avatar_faces. capacity >= 3 * num_vertices floats. */
HAHA_API haha_status haha_posed_vertices(const haha_posed* posed, float* xyz, size_t capacity);

/* Unit per-vertex normals (V x 3) of the posed mesh: the area-weighted sum of the normals
 * of the faces around each vertex (right-handed with the face winding: outward for
 * SMPL-X), computed on every call from the posed vertices. A vertex no non-degenerate face
 * touches gets (0, 0, 0). capacity >= 3 * num_vertices. */
HAHA_API haha_status haha_posed_normals(const haha_posed* posed, float* xyz, size_t capacity);

/* Posed joint positions (55 x 3, world space). capacity >= 3 * HAHA_NUM_JOINTS floats. */
HAHA_API haha_status haha_posed_joints(const haha_posed* posed, float* xyz, size_t capacity);

/* Caller buffers for the posed Gaussians as a structure of arrays. `capacity` is the
 * number of Gaussians each non-NULL array holds (>= num_gaussians); a NULL array is
 * skipped. Colours and opacities are pose-independent. */
typedef struct haha_gaussian_arrays {
  size_t capacity;
  float* means;      /* capacity x 3: centres, world space (x, y, z) */
  float* rotations;  /* capacity x 4: world rotations, unit quaternions (w, x, y, z) */
  float* scales;     /* capacity x 3: world standard deviations along the rotated axes
                        (linear, metres, not log) */
  float* colors;     /* capacity x 3: RGB in [0, 1] (view-independent) */
  float* opacities;  /* capacity: in [0, 1] */
} haha_gaussian_arrays;

/* Copies the posed Gaussians into the caller's arrays. */
HAHA_API haha_status haha_posed_gaussians(const haha_posed* posed, const haha_gaussian_arrays* out);

/* ---- Rendering --------------------------------------------------------------------- */

/* OpenCV pinhole camera: x_cam = rotation * x_world + translation; pixel = (fx x/z + cx,
 * fy y/z + cy) with pixel centres at +0.5 (a centred principal point is cx = width / 2). */
typedef struct haha_camera {
  int32_t width, height;   /* pixels, 1..16384 */
  float fx, fy, cx, cy;    /* intrinsics in pixels */
  float rotation[9];       /* world-to-camera rotation, row-major */
  float translation[3];    /* world-to-camera translation */
  float near_plane, far_plane;  /* clip distances along z; <= 0 selects 0.01 / 100 */
} haha_camera;

typedef enum haha_pixel_format {
  HAHA_PIXEL_RGB8 = 0,     /* 3 x uint8 per pixel */
  HAHA_PIXEL_RGBA8 = 1,    /* 4 x uint8 */
  HAHA_PIXEL_RGB32F = 2,   /* 3 x float, the renderer's values (not clamped) */
  HAHA_PIXEL_RGBA32F = 3   /* 4 x float */
} haha_pixel_format;

/* haha_render flags (OR them): draw only one layer. */
#define HAHA_RENDER_NO_MESH 1u       /* Gaussians only */
#define HAHA_RENDER_NO_GAUSSIANS 2u  /* textured mesh only */

/* Renders the last repose of `posed` with the merged renderer
 *   I = C_front + (1 - A) (m M + (1 - m) B)
 * (Gaussians in front of the mesh over the textured mesh over the background B).
 * background: 3 floats in [0, 1]; NULL = black. Alpha (RGBA formats) is the coverage
 * A + (1 - A) m; the colour is already composited over the background (premultiplied
 * when the background is black). 8-bit values are round(255 * clamp(v, 0, 1)).
 * pixels: caller buffer of height rows of width pixels, tightly packed, top row first;
 * capacity_bytes >= width * height * channels * (1 for 8-bit, 4 for float); float
 * buffers must be 4-byte aligned. Uses posed's scratch: not concurrently with other
 * calls on the same posed. */
HAHA_API haha_status haha_render(haha_posed* posed, const haha_camera* camera, const float* background, uint32_t flags,
                                 haha_pixel_format format, void* pixels, size_t capacity_bytes);

/* ---- Animations stored in the avatar's file (haha pack --animation) ------------------- */

/* Number of glTF animations of the avatar's skeleton in its file (0 when it has none). */
HAHA_API haha_status haha_avatar_animation_count(const haha_avatar* avatar, int32_t* count);
/* Animation `index` in [0, count): its name, NUL-terminated into name[name_capacity] (name
 * NULL to skip; a capacity below the name's length + 1 is HAHA_ERROR_ARGUMENT), its
 * duration in seconds, its frames (keys of its longest track) and the frame rate they were
 * written at. Any output pointer may be NULL. */
HAHA_API haha_status haha_avatar_animation_info(const haha_avatar* avatar, int32_t index, char* name, size_t name_capacity,
                                                double* duration, int32_t* frames, double* fps);
/* Animation `index` at `time` seconds (clamped to [0, duration]) as SMPL-X pose parameters:
 * pose[165] axis-angle and translation[3] (either may be NULL), ready for haha_repose.
 * Keys are interpolated as glTF viewers play them (slerp / lerp, STEP held); joints the
 * animation does not move stay at rest (zero). */
HAHA_API haha_status haha_avatar_sample_animation(const haha_avatar* avatar, int32_t index, double time, float* pose,
                                                  float* translation);

/* ---- Motions and images (helpers for tools and samples) ----------------------------- */

/* Reads a motion .npz: AMASS SMPL-X (poses (T, 165), trans (T, 3), mocap_frame_rate),
 * AMASS SMPL+H (poses (T, 156); no face joints) or a native SMPL-X parameter file
 * (global_orient, body_pose, ..., transl; fps 30 unless it stores one). Frame shapes
 * (betas) are ignored. Free with haha_motion_free. */
HAHA_API haha_status haha_motion_load(const char* path, haha_motion** out_motion);
/* As haha_motion_load, for posing `avatar`: an AMASS motion (Z-up world, no `up` key)
 * is turned into haha's Y-up world about the avatar's rest pelvis, so it stands upright
 * and keeps its path (root' = R root, transl' = R (J0 + transl) - J0). haha_motion_load
 * returns frames as stored; files written by `haha motion` are Y-up either way. */
HAHA_API haha_status haha_motion_load_for_avatar(const char* path, const haha_avatar* avatar, haha_motion** out_motion);
HAHA_API void haha_motion_free(haha_motion* motion);
/* Frame count and frames per second; either pointer may be NULL. */
HAHA_API haha_status haha_motion_info(const haha_motion* motion, int32_t* num_frames, double* fps);
/* One frame's pose into pose[165] and translation[3] (caller arrays of exactly those
 * sizes; either may be NULL to skip). frame in [0, num_frames). */
HAHA_API haha_status haha_motion_frame(const haha_motion* motion, int32_t frame, float* pose, float* translation);

/* Writes 8-bit pixels (height rows of width x channels bytes, top row first; channels 1
 * grey, 2 grey+alpha, 3 RGB, 4 RGBA) as a PNG. The path must end in ".png". The file
 * appears complete or not at all (written to a temporary name, then renamed). */
HAHA_API haha_status haha_write_png(const char* path, int32_t width, int32_t height, int32_t channels,
                                    const uint8_t* pixels);

#ifdef __cplusplus
}  /* extern "C" */
#endif

#endif /* HAHA_RUNTIME_H */
