"""CTest `python_package`: the Python package `haha` (python/haha) against the C API.

  haha_package_test.py --python-dir BUILD/python --fixture EXE --reference EXE --sample EXE --work DIR

Makes a realistic-size Draco avatar and a 3-frame motion (python_avatar_fixture), then:
  - every array the package returns (faces, UVs, texture, posed vertices, normals, joints,
    Gaussians, renders in three formats) is bit-identical to what the C API gives a C program
    (c_reference.c) for the same pose and camera;
  - the package's renders of the motion with haha.framing_camera are byte-identical to the
    frames samples/c (haha_sample_c) writes;
  - bad input raises the right exception with one clear line naming the file or argument;
  - Avatar.mesh_coverage gives a file's coverage per body vertex (None without one).
Exit 0 pass, 1 fail (each check printed).
"""
import argparse
import os
import shutil
import struct
import subprocess
import sys
import zlib

import numpy as np

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        sys.exit("command failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stdout))
    return r.stdout


def read_png(path):
    """8-bit non-interlaced PNG (grey / RGB / RGBA) -> (H, W, C) uint8; enough for haha_write_png's files."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, head = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            head = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, depth, ctype, _, _, interlace = head
    assert depth == 8 and interlace == 0, path
    c = {0: 1, 2: 3, 4: 2, 6: 4}[ctype]
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + w * c)
    out = np.zeros((h, w * c), np.int32)
    for y in range(h):
        f, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        prev = out[y - 1] if y else np.zeros(w * c, np.int32)
        if f in (0, 2):
            out[y] = (line + (prev if f == 2 else 0)) & 255
            continue
        row = np.zeros(w * c, np.int32)
        for i in range(w * c):
            a = row[i - c] if i >= c else 0
            b, d = prev[i], prev[i - c] if i >= c else 0
            if f == 1:
                pred = a
            elif f == 3:
                pred = (a + b) // 2
            else:
                p = a + b - d
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - d)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else d)
            row[i] = (line[i] + pred) & 255
        out[y] = row
    return out.astype(np.uint8).reshape(h, w, c)


def test_equals_c_api(haha, args, glb):
    """The package's arrays against c_reference's dump of the same pose and camera."""
    rng = np.random.default_rng(7)
    pose = rng.normal(0.0, 0.25, (55, 3)).astype(np.float32)
    pose[haha.joint_index("left_shoulder")] = (0.2, -0.3, -1.1)
    transl = np.array([0.03, -0.02, 0.1], np.float32)
    avatar = haha.Avatar(glb)
    posed = avatar.repose(pose, transl=transl)
    cam = haha.framing_camera(posed.vertices, 96)
    cam_values = np.array([cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, *cam.rotation.reshape(-1),
                           *cam.translation, cam.near, cam.far], np.float32)
    ref_dir = os.path.join(args.work, "c_reference")
    os.makedirs(ref_dir)
    np.concatenate([pose.reshape(-1), transl]).tofile(os.path.join(ref_dir, "pose.f32"))
    cam_values.tofile(os.path.join(ref_dir, "camera.f32"))
    run([args.reference, glb, os.path.join(ref_dir, "pose.f32"), os.path.join(ref_dir, "camera.f32"), ref_dir])

    def ref(name, dtype, shape):
        return np.fromfile(os.path.join(ref_dir, name), dtype).reshape(shape)

    V, F, G = avatar.num_vertices, avatar.num_faces, avatar.num_gaussians
    w, h = avatar.texture_size
    print("avatar: %d vertices, %d faces, %d Gaussians, texture %d x %d, correctives %s"
          % (V, F, G, w, h, avatar.has_pose_correctives))
    check(G > 1000 and V > 10000, "a realistic-size avatar (%d Gaussians, %d vertices)" % (G, V))
    same = {
        "faces": (avatar.faces, ref("faces.u32", np.uint32, (F, 3))),
        "face_uvs": (avatar.face_uvs, ref("uvs.f32", np.float32, (F, 3, 2))),
        "texture": (avatar.texture, ref("texture.u8", np.uint8, (h, w, 3))),
        "vertices": (posed.vertices, ref("vertices.f32", np.float32, (V, 3))),
        "normals": (posed.normals, ref("normals.f32", np.float32, (V, 3))),
        "joints": (posed.joints, ref("joints.f32", np.float32, (55, 3))),
        "means": (posed.means, ref("means.f32", np.float32, (G, 3))),
        "rotations": (posed.rotations, ref("rotations.f32", np.float32, (G, 4))),
        "scales": (posed.scales, ref("scales.f32", np.float32, (G, 3))),
        "colors": (posed.colors, ref("colors.f32", np.float32, (G, 3))),
        "opacities": (posed.opacities, ref("opacities.f32", np.float32, (G,))),
    }
    gauss = np.concatenate([same[k][1].reshape(G, -1) for k in ("means", "rotations", "scales", "colors", "opacities")], 1)
    same["gaussians (G, 14)"] = (posed.gaussians, gauss)
    same["render RGB8"] = (avatar.render(cam, background=(0.2, 0.4, 0.6)), ref("render.u8", np.uint8, (96, 96, 3)))
    same["render RGBA32F"] = (avatar.render(cam, alpha=True, float32=True), ref("render_alpha.f32", np.float32, (96, 96, 4)))
    same["render Gaussians only"] = (avatar.render(cam, background=(0.2, 0.4, 0.6), layers="gaussians"),
                                     ref("render_gaussians.u8", np.uint8, (96, 96, 3)))
    for name, (mine, theirs) in same.items():
        eq = mine.shape == theirs.shape and mine.dtype == theirs.dtype and np.array_equal(mine, theirs)
        check(eq, "%s %s %s equals the C API's, bit for bit" % (name, mine.dtype, mine.shape))
    moved = np.abs(posed.vertices - avatar.repose().vertices).max()
    check(moved > 0.1, "the pose moves the body (max %.3f m)" % moved)
    check(posed.gaussians.shape == (G, 14) and np.array_equal(posed.gaussians[:, :3], posed.means),
          "gaussians[:, :3] are the centres")


def test_equals_c_sample(haha, args, glb, motion_path):
    """haha_sample_c's PNG frames against the package's renders of the same motion frames."""
    frames_dir = os.path.join(args.work, "sample_c")
    run([args.sample, glb, motion_path, frames_dir, "80"])
    avatar = haha.Avatar(glb)
    motion = haha.Motion(motion_path, avatar)
    check(len(motion) == 3 and motion.fps == 30.0, "motion: %d frames at %g fps" % (len(motion), motion.fps))
    pose0, transl0 = motion[0]
    cam = haha.framing_camera(avatar.repose(pose0, transl0).vertices, 80)
    for f, (pose, transl) in enumerate(motion):
        mine = avatar.render(cam, pose=pose, transl=transl, background=(1, 1, 1))
        theirs = read_png(os.path.join(frames_dir, "frame_%05d.png" % f))
        diff = int(np.abs(mine.astype(int) - theirs.astype(int)).max())
        check(mine.shape == theirs.shape and diff == 0,
              "motion frame %d: the package's render equals haha_sample_c's frame (max difference %d)" % (f, diff))


def test_animation(haha, args, motion_path):
    """The file's animation, sampled by the runtime, against the motion it was packed from."""
    avatar = haha.Avatar(os.path.join(args.work, "animated.glb"))
    anims = avatar.animations
    check(len(anims) == 1 and anims[0].name == "fixture" and anims[0].frames == 3 and abs(anims[0].fps - 30) < 1e-3,
          "animations: %r" % (anims,))
    check(haha.Avatar(os.path.join(args.work, "avatar.glb")).animations == [], "a file without animations lists none")
    motion = haha.Motion(motion_path, avatar)
    for f, (pose, transl) in enumerate(motion):
        p, t = avatar.sample_animation("fixture", f / 30.0)
        q, _ = avatar.sample_animation(0, f / 30.0)
        # 16-bit rotations: a small angle's axis-angle is off by about the angle error, < 1e-4 rad
        check(np.abs(p - pose).max() < 1e-4 and np.abs(t - transl).max() < 1e-5 and np.array_equal(p, q),
              "animation frame %d equals the motion (pose %.2g, transl %.2g)" % (f, np.abs(p - pose).max(), np.abs(t - transl).max()))
    expect_error(haha, haha.ArgumentError, ["no animation", "fixture"], lambda: avatar.sample_animation("run", 0))


def test_mesh_coverage(haha, args):
    """The fixture's coverage (0, 1, 0.3 for v % 3 = 0, 1, 2) within half an 8-bit step."""
    avatar = haha.Avatar(os.path.join(args.work, "coverage.glb"))
    c = avatar.mesh_coverage
    want = np.array([0.0, 1.0, 0.3], np.float32)[np.arange(avatar.num_vertices) % 3]
    check(c is not None and c.shape == (avatar.num_vertices,) and c.dtype == np.float32
          and np.abs(c - want).max() <= 0.5 / 255 + 1e-7, "mesh_coverage per body vertex")
    check(np.array_equal(c >= haha.MESH_COVERAGE_CUTOFF, want >= 0.5), "every vertex on its side of the cut")
    check(haha.Avatar(os.path.join(args.work, "avatar.glb")).mesh_coverage is None, "a file without a coverage gives None")


def expect_error(haha, cls, words, fn):
    try:
        fn()
    except haha.HahaError as e:
        msg = str(e)
        ok = isinstance(e, cls) and all(w in msg for w in words) and "\n" not in msg
        check(ok, "%s: %s(%r)" % (cls.__name__, type(e).__name__, msg))
        return
    check(False, "%s expected, nothing raised (%s)" % (cls.__name__, words))


def test_errors(haha, args, glb):
    work = args.work
    missing = os.path.join(work, "missing.glb")
    expect_error(haha, haha.FileError, [missing, "cannot open"], lambda: haha.Avatar(missing))
    check(issubclass(haha.FileError, OSError) and issubclass(haha.FormatError, ValueError),
          "FileError is an OSError, FormatError a ValueError")
    truncated = os.path.join(work, "truncated.glb")
    with open(glb, "rb") as f:
        data = f.read()
    with open(truncated, "wb") as f:
        f.write(data[: len(data) // 2])
    expect_error(haha, haha.FormatError, [truncated, "truncated"], lambda: haha.Avatar(truncated))
    text = os.path.join(work, "not_a_glb.glb")
    with open(text, "w") as f:
        f.write("hello\n")
    expect_error(haha, haha.FormatError, [text], lambda: haha.Avatar(text))
    expect_error(haha, haha.FormatError, ["bytes.glb"], lambda: haha.Avatar.from_bytes(data[:100], "bytes.glb"))
    avatar = haha.Avatar.from_bytes(data, "memory.glb")
    check(avatar.num_gaussians == haha.Avatar(glb).num_gaussians, "Avatar.from_bytes loads the same avatar")
    expect_error(haha, haha.ArgumentError, ["pose", "(54, 3)"], lambda: avatar.repose(np.zeros((54, 3))))
    expect_error(haha, haha.ArgumentError, ["pose", "(164,)"], lambda: avatar.repose(np.zeros(164)))
    expect_error(haha, haha.ArgumentError, ["pose", "non-finite"], lambda: avatar.repose(np.full(165, np.nan)))
    expect_error(haha, haha.ArgumentError, ["transl", "(2,)"], lambda: avatar.repose(None, transl=[0, 0]))
    expect_error(haha, haha.ArgumentError, ["betas"], lambda: avatar.repose(None, betas=np.ones(10)))
    expect_error(haha, haha.ArgumentError, ["layers"], lambda: avatar.render(haha.Camera(8, 8, 8, 8, 4, 4), layers="x"))
    expect_error(haha, haha.FileError, [missing], lambda: haha.Motion(missing))
    env = dict(os.environ, HAHA_RUNTIME_LIBRARY=os.path.join(work, "nowhere.so"), PYTHONPATH=args.python_dir)
    r = subprocess.run([sys.executable, "-c", "import haha\ntry:\n haha.Avatar('a.glb')\nexcept haha.LibraryNotFoundError"
                        " as e:\n print(e)"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    check(r.returncode == 0 and "HAHA_RUNTIME_LIBRARY=" in r.stdout and "cannot load" in r.stdout,
          "a missing library: LibraryNotFoundError naming it (%s)" % r.stdout.strip())


def main():
    ap = argparse.ArgumentParser()
    for a in ("--python-dir", "--fixture", "--reference", "--sample", "--work"):
        ap.add_argument(a, required=True)
    args = ap.parse_args()
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    run([args.fixture, args.work])
    glb, motion = os.path.join(args.work, "avatar.glb"), os.path.join(args.work, "motion.npz")
    os.environ.pop("HAHA_RUNTIME_LIBRARY", None)  # the build tree's package finds its own library
    sys.path.insert(0, args.python_dir)
    import haha
    check(os.path.realpath(haha.library_path()).startswith(os.path.realpath(os.path.dirname(args.python_dir))),
          "the build tree's package loads the build tree's library (%s)" % haha.library_path())
    test_equals_c_api(haha, args, glb)
    test_equals_c_sample(haha, args, glb, motion)
    test_errors(haha, args, glb)
    test_animation(haha, args, motion)
    test_mesh_coverage(haha, args)
    print("PASS" if not failures else "FAILED: %d check(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
