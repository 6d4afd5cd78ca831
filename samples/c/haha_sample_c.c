/* haha_sample_c: play a motion on a packed avatar with the built-in renderer (plain C99).
 *
 *   haha_sample_c AVATAR.glb MOTION.npz OUTDIR [SIZE [BODY_MODEL.npz]]
 *
 * Loads the avatar, reads the motion (AMASS-style .npz, e.g. from `haha motion`), reposes
 * every frame, renders it SIZE x SIZE (default 512) with a front camera framing the first
 * frame's posed body, writes OUTDIR/frame_%05d.png and prints the repose and render time
 * of each frame. BODY_MODEL.npz (the model the avatar was trained with) supplies pose
 * correctives the file may not embed. Build it against an installed prefix P (README
 * "Embedding"):
 *
 *   export PKG_CONFIG_PATH=P/lib/pkgconfig
 *   cc -std=c99 -O2 samples/c/haha_sample_c.c $(pkg-config --cflags --libs haha_runtime) \
 *      -Wl,-rpath,$(pkg-config --variable=libdir haha_runtime) -o haha_sample_c
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime, mkdir */

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "haha/haha_runtime.h"

static double now_ms(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

/* Prints the failing call's status and the library's one-line message. */
static int failed(const char* what, haha_status s) {
  fprintf(stderr, "haha_sample_c: %s: %s: %s\n", what, haha_status_string(s), haha_last_error());
  return 1;
}

/* A front camera (looking along world -Z at the body, OpenCV axes: y down) framing the
 * box [lo, hi] with a 15% margin; the same framing as `haha render`. */
static haha_camera framing_camera(const float lo[3], const float hi[3], int size) {
  haha_camera c;
  float centre[3], half, dist, eye[3];
  int k;
  memset(&c, 0, sizeof c);
  c.width = c.height = size;
  c.fx = c.fy = 1.5f * (float)size; /* ~37 degrees field of view */
  c.cx = c.cy = 0.5f * (float)size; /* pixel centres at +0.5: the image centre */
  for (k = 0; k < 3; ++k) centre[k] = 0.5f * (lo[k] + hi[k]);
  half = 0.5f * 1.15f * ((hi[0] - lo[0]) > (hi[1] - lo[1]) ? (hi[0] - lo[0]) : (hi[1] - lo[1]));
  dist = half * c.fx / (0.5f * (float)size) + 0.5f * (hi[2] - lo[2]);
  /* R = diag(1, -1, -1): world +Y up becomes image up, the camera looks along world -Z. */
  c.rotation[0] = 1.0f;
  c.rotation[4] = -1.0f;
  c.rotation[8] = -1.0f;
  eye[0] = centre[0];
  eye[1] = centre[1];
  eye[2] = centre[2] + dist;
  /* t = -R eye */
  c.translation[0] = -eye[0];
  c.translation[1] = eye[1];
  c.translation[2] = eye[2];
  c.near_plane = 0.01f;
  c.far_plane = 4.0f * dist + 10.0f;
  return c;
}

int main(int argc, char** argv) {
  const char *avatar_path, *motion_path, *out_dir, *model_path = NULL;
  int size = 512, rc = 1, num_frames = 0, f;
  double fps = 0, sum_repose = 0, sum_render = 0;
  haha_avatar* avatar = NULL;
  haha_posed* posed = NULL;
  haha_motion* motion = NULL;
  haha_avatar_info info;
  haha_status s;
  float pose[HAHA_NUM_POSE_VALUES], transl[3], lo[3], hi[3];
  float* verts = NULL;
  unsigned char* rgb = NULL;
  size_t rgb_bytes, v;
  haha_camera cam;
  char path[4096];

  if (argc < 4 || argc > 6) {
    fprintf(stderr, "usage: %s AVATAR.glb MOTION.npz OUTDIR [SIZE [BODY_MODEL.npz]]\n", argv[0]);
    return 2;
  }
  avatar_path = argv[1];
  motion_path = argv[2];
  out_dir = argv[3];
  if (argc >= 5) size = atoi(argv[4]);
  if (argc == 6) model_path = argv[5];
  if (size < 1 || size > 16384) {
    fprintf(stderr, "haha_sample_c: SIZE must be in 1..16384\n");
    return 2;
  }
  printf("haha runtime %s\n", haha_version_string());

  if ((s = haha_avatar_load(avatar_path, model_path, &avatar)) != HAHA_OK) return failed("load avatar", s);
  if ((s = haha_avatar_get_info(avatar, &info)) != HAHA_OK) { failed("avatar info", s); goto done; }
  printf("%s: %d vertices, %d faces, %d Gaussians, texture %dx%d%s\n", avatar_path, info.num_vertices,
         info.num_faces, info.num_gaussians, info.texture_width, info.texture_height,
         info.missing_pose_correctives ? " (pose correctives missing: pass BODY_MODEL.npz for exact reposes)" : "");
  if ((s = haha_motion_load_for_avatar(motion_path, avatar, &motion)) != HAHA_OK) { failed("load motion", s); goto done; }
  if ((s = haha_motion_info(motion, &num_frames, &fps)) != HAHA_OK) { failed("motion info", s); goto done; }
  printf("%s: %d frames at %.3g fps\n", motion_path, num_frames, fps);
  if ((s = haha_posed_create(avatar, &posed)) != HAHA_OK) { failed("create pose state", s); goto done; }
  if (mkdir(out_dir, 0777) != 0 && errno != EEXIST) {
    fprintf(stderr, "haha_sample_c: %s: cannot create: %s\n", out_dir, strerror(errno));
    goto done;
  }

  /* The camera frames the first frame's posed body: its vertex bounds. */
  verts = malloc(sizeof(float) * 3 * (size_t)info.num_vertices);
  rgb_bytes = (size_t)3 * (size_t)size * (size_t)size;
  rgb = malloc(rgb_bytes);
  if (!verts || !rgb) {
    fprintf(stderr, "haha_sample_c: out of memory\n");
    goto done;
  }
  if ((s = haha_motion_frame(motion, 0, pose, transl)) != HAHA_OK) { failed("motion frame 0", s); goto done; }
  if ((s = haha_repose(posed, pose, transl, NULL, 0, NULL, 0)) != HAHA_OK) { failed("repose frame 0", s); goto done; }
  if ((s = haha_posed_vertices(posed, verts, 3 * (size_t)info.num_vertices)) != HAHA_OK) {
    failed("posed vertices", s);
    goto done;
  }
  lo[0] = lo[1] = lo[2] = 1e30f;
  hi[0] = hi[1] = hi[2] = -1e30f;
  for (v = 0; v < 3 * (size_t)info.num_vertices; ++v) {
    if (verts[v] < lo[v % 3]) lo[v % 3] = verts[v];
    if (verts[v] > hi[v % 3]) hi[v % 3] = verts[v];
  }
  cam = framing_camera(lo, hi, size);

  for (f = 0; f < num_frames; ++f) {
    const float background[3] = {1.0f, 1.0f, 1.0f};
    double t0, t1, t2;
    if ((s = haha_motion_frame(motion, f, pose, transl)) != HAHA_OK) { failed("motion frame", s); goto done; }
    t0 = now_ms();
    if ((s = haha_repose(posed, pose, transl, NULL, 0, NULL, 0)) != HAHA_OK) { failed("repose", s); goto done; }
    t1 = now_ms();
    if ((s = haha_render(posed, &cam, background, 0, HAHA_PIXEL_RGB8, rgb, rgb_bytes)) != HAHA_OK) {
      failed("render", s);
      goto done;
    }
    t2 = now_ms();
    snprintf(path, sizeof path, "%s/frame_%05d.png", out_dir, f);
    if ((s = haha_write_png(path, size, size, 3, rgb)) != HAHA_OK) { failed("write png", s); goto done; }
    printf("frame %5d: repose %7.2f ms  render %7.2f ms  -> %s\n", f, t1 - t0, t2 - t1, path);
    sum_repose += t1 - t0;
    sum_render += t2 - t1;
  }
  printf("%d frames %dx%d: mean repose %.2f ms, mean render %.2f ms\n", num_frames, size, size,
         sum_repose / num_frames, sum_render / num_frames);
  rc = 0;

done:
  free(rgb);
  free(verts);
  haha_posed_free(posed); /* before its avatar */
  haha_motion_free(motion);
  haha_avatar_free(avatar);
  return rc;
}
