/* The Python package test's reference: the same calls through the C API alone (C99, only
 * haha/haha_runtime.h), its outputs dumped as raw little-endian arrays for the test to
 * compare with the package's numpy arrays.
 *
 *   c_reference AVATAR.glb POSE.f32 CAMERA.f32 OUTDIR
 *
 * POSE.f32: 168 float32 (165 axis-angle values, 3 translation). CAMERA.f32: 20 float32
 * (width, height, fx, fy, cx, cy, rotation[9] row-major, translation[3], near, far).
 * Writes OUTDIR/{faces.u32, uvs.f32, texture.u8, vertices.f32, normals.f32, joints.f32,
 * means.f32, rotations.f32, scales.f32, colors.f32, opacities.f32, render.u8 (RGB8 on a
 * (0.2, 0.4, 0.6) background), render_alpha.f32 (RGBA32F, black), render_gaussians.u8}. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "haha/haha_runtime.h"

static const char* g_dir;

static int fail(const char* what) {
  fprintf(stderr, "c_reference: %s: %s\n", what, haha_last_error());
  return 1;
}

static int read_floats(const char* path, float* out, size_t n) {
  FILE* f = fopen(path, "rb");
  size_t got = 0;
  if (f) {
    got = fread(out, sizeof(float), n, f);
    fclose(f);
  }
  if (got != n) fprintf(stderr, "c_reference: %s: expected %zu float32\n", path, n);
  return got == n ? 0 : 1;
}

static int dump(const char* name, const void* data, size_t bytes) {
  char path[4096];
  FILE* f;
  snprintf(path, sizeof path, "%s/%s", g_dir, name);
  f = fopen(path, "wb");
  if (!f || fwrite(data, 1, bytes, f) != bytes) {
    fprintf(stderr, "c_reference: cannot write %s\n", path);
    if (f) fclose(f);
    return 1;
  }
  return fclose(f) != 0;
}

/* Reads the pose state back and dumps every array. */
static int dump_posed(const haha_posed* posed, const haha_avatar_info* info) {
  const size_t V = (size_t)info->num_vertices, G = (size_t)info->num_gaussians;
  float* buf = malloc(sizeof(float) * (3 * V + 14 * G + 3 * HAHA_NUM_JOINTS));
  haha_gaussian_arrays g;
  int rc = 1;
  if (!buf) return 1;
  g.capacity = G;
  g.means = buf + 3 * V;
  g.rotations = g.means + 3 * G;
  g.scales = g.rotations + 4 * G;
  g.colors = g.scales + 3 * G;
  g.opacities = g.colors + 3 * G;
  if (haha_posed_vertices(posed, buf, 3 * V) != HAHA_OK) { fail("vertices"); goto done; }
  if (dump("vertices.f32", buf, sizeof(float) * 3 * V)) goto done;
  if (haha_posed_normals(posed, buf, 3 * V) != HAHA_OK) { fail("normals"); goto done; }
  if (dump("normals.f32", buf, sizeof(float) * 3 * V)) goto done;
  if (haha_posed_joints(posed, buf, 3 * HAHA_NUM_JOINTS) != HAHA_OK) { fail("joints"); goto done; }
  if (dump("joints.f32", buf, sizeof(float) * 3 * HAHA_NUM_JOINTS)) goto done;
  if (haha_posed_gaussians(posed, &g) != HAHA_OK) { fail("gaussians"); goto done; }
  rc = dump("means.f32", g.means, sizeof(float) * 3 * G) || dump("rotations.f32", g.rotations, sizeof(float) * 4 * G) ||
       dump("scales.f32", g.scales, sizeof(float) * 3 * G) || dump("colors.f32", g.colors, sizeof(float) * 3 * G) ||
       dump("opacities.f32", g.opacities, sizeof(float) * G);
done:
  free(buf);
  return rc;
}

/* The avatar's pose-independent arrays. */
static int dump_avatar(const haha_avatar* avatar, const haha_avatar_info* info) {
  const size_t F = (size_t)info->num_faces, T = 3 * (size_t)info->texture_width * (size_t)info->texture_height;
  void* buf = malloc(sizeof(float) * 6 * F + T + 1);
  int rc = 1;
  if (!buf) return 1;
  if (haha_avatar_faces(avatar, buf, 3 * F) != HAHA_OK) { fail("faces"); goto done; }
  if (dump("faces.u32", buf, sizeof(uint32_t) * 3 * F)) goto done;
  if (haha_avatar_face_uvs(avatar, buf, 6 * F) != HAHA_OK) { fail("uvs"); goto done; }
  if (dump("uvs.f32", buf, sizeof(float) * 6 * F)) goto done;
  if (T && haha_avatar_texture(avatar, buf, T) != HAHA_OK) { fail("texture"); goto done; }
  rc = dump("texture.u8", buf, T);
done:
  free(buf);
  return rc;
}

static int render(haha_posed* posed, const haha_camera* cam) {
  const size_t n = (size_t)cam->width * (size_t)cam->height;
  const float bg[3] = {0.2f, 0.4f, 0.6f};
  float* buf = malloc(4 * sizeof(float) * n);
  int rc = 1;
  if (!buf) return 1;
  if (haha_render(posed, cam, bg, 0, HAHA_PIXEL_RGB8, buf, 3 * n) != HAHA_OK) { fail("render"); goto done; }
  if (dump("render.u8", buf, 3 * n)) goto done;
  if (haha_render(posed, cam, NULL, 0, HAHA_PIXEL_RGBA32F, buf, 16 * n) != HAHA_OK) { fail("render rgba"); goto done; }
  if (dump("render_alpha.f32", buf, 16 * n)) goto done;
  if (haha_render(posed, cam, bg, HAHA_RENDER_NO_MESH, HAHA_PIXEL_RGB8, buf, 3 * n) != HAHA_OK) {
    fail("render gaussians");
    goto done;
  }
  rc = dump("render_gaussians.u8", buf, 3 * n);
done:
  free(buf);
  return rc;
}

int main(int argc, char** argv) {
  float pose[168], c[20];
  haha_avatar* avatar = NULL;
  haha_posed* posed = NULL;
  haha_avatar_info info;
  haha_camera cam;
  int rc = 1;
  if (argc != 5) {
    fprintf(stderr, "usage: %s AVATAR.glb POSE.f32 CAMERA.f32 OUTDIR\n", argv[0]);
    return 2;
  }
  g_dir = argv[4];
  if (read_floats(argv[2], pose, 168) || read_floats(argv[3], c, 20)) return 1;
  memset(&cam, 0, sizeof cam);
  cam.width = (int32_t)c[0];
  cam.height = (int32_t)c[1];
  cam.fx = c[2], cam.fy = c[3], cam.cx = c[4], cam.cy = c[5];
  memcpy(cam.rotation, c + 6, sizeof cam.rotation);
  memcpy(cam.translation, c + 15, sizeof cam.translation);
  cam.near_plane = c[18], cam.far_plane = c[19];
  if (haha_avatar_load(argv[1], NULL, &avatar) != HAHA_OK) return fail("load");
  if (haha_avatar_get_info(avatar, &info) != HAHA_OK || haha_posed_create(avatar, &posed) != HAHA_OK) {
    fail("info / pose state");
    goto done;
  }
  if (haha_repose(posed, pose, pose + 165, NULL, 0, NULL, 0) != HAHA_OK) { fail("repose"); goto done; }
  rc = dump_avatar(avatar, &info) || dump_posed(posed, &info) || render(posed, &cam);
done:
  haha_posed_free(posed);
  haha_avatar_free(avatar);
  return rc;
}
