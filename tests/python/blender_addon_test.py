"""CTest `blender_avatar`, run by tests/python/blender_addon_test.sh in headless Blender:

  blender -b --factory-startup --python blender_addon_test.py -- --addons DIR --avatar A.glb --haha HAHA --work W

With the add-on io_import_haha_avatar (DIR/io_import_haha_avatar, the build tree's copy):
bpy.ops.import_scene.haha_avatar imports the (Draco) avatar: armature of 55 bones, textured
body, Gaussian layer. At rest and with the left shoulder turned 70 degrees, the Gaussian
centres Blender evaluates (the centre of each drawn ellipsoid, world space turned back into
the avatar frame) match the runtime's reposing (<= 0.1 mm), every left-arm Gaussian left its
rest place, >= 90% of the Gaussians evaluated; an action keyframing the shoulder moves them
on frame change. Then a Cycles render of the posed avatar against `haha render` at the same
camera and pose: PSNR printed and held to a floor. Exit 0 pass, 1 fail.
"""
import argparse
import json
import math
import os
import subprocess
import sys

import bpy
import numpy as np
from mathutils import Matrix

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
for a in ("--addons", "--avatar", "--haha", "--work"):
    ap.add_argument(a, required=True)
args = ap.parse_args(argv)
failures = []
RENDER_SIZE, PSNR_FLOOR = 128, 20.0


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


def finish():
    print("PASS" if not failures else "FAILED: %d check(s)" % len(failures), flush=True)
    sys.exit(1 if failures else 0)


sys.path.insert(0, args.addons)
import io_import_haha_avatar as addon  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
addon.register()
haha = addon.runtime_link.import_haha()
result = bpy.ops.import_scene.haha_avatar(filepath=args.avatar)
check(result == {"FINISHED"}, "bpy.ops.import_scene.haha_avatar: %s" % result)
if failures:
    finish()
arms = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
arm = arms[0]
body, gaussians = arm.data["haha_body"], arm.data["haha_gaussians"]
avatar = haha.Avatar(args.avatar)
G = avatar.num_gaussians
check(len(arms) == 1 and len(arm.data.bones) == 55, "one armature of 55 bones (%d)" % len(arm.data.bones))
check(len(body.data.vertices) == avatar.num_vertices and len(body.data.polygons) == avatar.num_faces,
      "body: %d vertices, %d faces (the runtime's)" % (len(body.data.vertices), len(body.data.polygons)))
images = [n.image for n in body.active_material.node_tree.nodes if n.type == "TEX_IMAGE" and n.image]
check(len(images) == 1 and tuple(images[0].size) == avatar.texture_size,
      "body textured (%s)" % (tuple(images[0].size) if images else "no image",))
try:
    bpy.ops.import_scene.haha_avatar(filepath=os.path.join(args.work, "missing.glb"))
    check(False, "a missing file is refused")
except RuntimeError as e:
    check("missing.glb: cannot open" in str(e), "a missing file: %s" % str(e).strip().splitlines()[-1])


def evaluated_centres():
    """Centres of the ellipsoids Blender evaluates (mean of each instance's 42 ico-sphere
    vertices), world space turned back into the avatar frame; and the number of instances."""
    bpy.context.view_layer.update()
    dg = bpy.context.evaluated_depsgraph_get()
    ev = gaussians.evaluated_get(dg)
    me = ev.to_mesh()
    co = np.zeros(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    n = len(co) // (3 * 42)
    to_avatar = np.array(arm.matrix_world.inverted() @ ev.matrix_world)
    world = co.reshape(n, 42, 3).mean(axis=1)
    return world @ to_avatar[:3, :3].T + to_avatar[:3, 3], n


def set_shoulder(aa):
    """Turns left_shoulder by the SMPL-X axis-angle `aa` (avatar frame): basis = B^T R B."""
    pb = arm.pose.bones["left_shoulder"]
    b = pb.bone.matrix_local.to_3x3()
    angle = float(np.linalg.norm(aa))
    r = Matrix.Rotation(angle, 3, (np.asarray(aa) / angle).tolist()) if angle > 0 else Matrix.Identity(3)
    pb.rotation_quaternion = (b.transposed() @ r @ b).to_quaternion()


def compare(label, pose):
    ref = avatar.repose(pose)
    centres, n = evaluated_centres()
    check(n >= 0.9 * G, "%s: %d of %d Gaussians evaluated (>= 90%%)" % (label, n, G))
    err = np.linalg.norm(centres[:G] - ref.means, axis=1) if n == G else np.array([np.inf])
    check(err.max() <= 1e-4, "%s: Gaussian centres vs the runtime: max %.2e mm, mean %.2e mm (<= 0.1 mm)"
          % (label, 1e3 * err.max(), 1e3 * err.mean()))
    verts = np.zeros(avatar.num_vertices * 3)
    body.data.vertices.foreach_get("co", verts)
    verr = np.abs(verts.reshape(-1, 3) - ref.vertices).max()
    check(verr <= 1e-6, "%s: body vertices vs the runtime: max %.2e m" % (label, verr))
    return centres, ref


rest_centres, rest_ref = compare("rest pose", None)
pose = np.zeros((55, 3))
pose[haha.joint_index("left_shoulder")] = (0.0, 0.0, -math.radians(70.0))  # the left arm down 70 degrees
set_shoulder(pose[16])
posed_centres, posed_ref = compare("left shoulder 70 degrees", pose)
arm_g = np.linalg.norm(posed_ref.means - rest_ref.means, axis=1) > 0.05
left = np.linalg.norm(posed_centres[arm_g] - rest_ref.means[arm_g], axis=1)
check(arm_g.sum() > 0.02 * G and left.min() > 0.01,
      "none of the %d left-arm Gaussians stays at the rest arm (closest %.1f mm from it)" % (arm_g.sum(), 1e3 * left.min()))

# An action: rest at frame 1, the turned shoulder at frame 11; frame changes repose.
pb = arm.pose.bones["left_shoulder"]
pb.keyframe_insert("rotation_quaternion", frame=11)
pb.rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
pb.keyframe_insert("rotation_quaternion", frame=1)
bpy.context.scene.frame_set(1)
compare("action, frame 1", None)
bpy.context.scene.frame_set(11)
compare("action, frame 11", pose)


def render_against_haha():
    """Cycles at the camera and pose of `haha render` (same cam.json); PSNR of the two PNGs."""
    cam = haha.framing_camera(posed_ref.vertices, RENDER_SIZE).to_dict()
    cam_path, motion_path = os.path.join(args.work, "cam.json"), os.path.join(args.work, "pose.npz")
    with open(cam_path, "w") as f:
        json.dump(cam, f)
    np.savez(motion_path, poses=pose.reshape(1, 165), trans=np.zeros((1, 3)), mocap_frame_rate=np.array(30.0),
             up=np.array([0.0, 1.0, 0.0]))
    out_dir = os.path.join(args.work, "haha_render")
    subprocess.run([args.haha, "render", args.avatar, "--motion", motion_path, "--camera", cam_path, "--out", out_dir,
                    "--background", "1,1,1"], check=True, stdout=subprocess.DEVNULL)
    scene = bpy.context.scene
    addon.camera.match_haha_render(scene, RENDER_SIZE, RENDER_SIZE, (1.0, 1.0, 1.0), samples=64)
    scene.camera = addon.camera.add_opencv_camera("haha camera", cam, arm, scene.collection)
    scene.render.filepath = os.path.join(args.work, "blender_render.png")
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    bpy.ops.render.render(write_still=True)
    mine, theirs = (_png_pixels(p) for p in (scene.render.filepath, os.path.join(out_dir, "frame_00000.png")))
    mse = np.mean((mine - theirs) ** 2)
    psnr = 10 * math.log10(1.0 / max(mse, 1e-12))
    body_mask = np.any(theirs < 0.99, axis=2)
    mse_body = np.mean((mine[body_mask] - theirs[body_mask]) ** 2)
    check(psnr >= PSNR_FLOOR, "Cycles render vs haha render (%d px, white background): PSNR %.2f dB over the image, "
          "%.2f dB over the body's pixels (floor %.0f dB)" % (RENDER_SIZE, psnr, 10 * math.log10(1 / mse_body), PSNR_FLOOR))
    side = np.concatenate([mine, np.ones((RENDER_SIZE, 4, 3)), theirs], axis=1)
    img = bpy.data.images.new("side_by_side", side.shape[1], side.shape[0])
    rgba = np.ones(side.shape[:2] + (4,), np.float32)
    rgba[:, :, :3] = side[::-1]
    img.pixels.foreach_set(rgba.reshape(-1))
    img.filepath_raw = os.path.join(args.work, "blender_vs_haha.png")
    img.file_format = "PNG"
    img.save()


def _png_pixels(path):
    """(H, W, 3) display values in [0, 1], top row first."""
    img = bpy.data.images.load(path)
    img.colorspace_settings.name = "Non-Color"
    w, h = img.size
    px = np.zeros(w * h * 4, np.float32)
    img.pixels.foreach_get(px)
    return px.reshape(h, w, 4)[::-1, :, :3].astype(np.float64)


render_against_haha()
finish()
