"""CTest `blender_export`, run by tests/python/blender_export_test.sh in headless Blender:

  blender -b --factory-startup --python blender_export_test.py -- --addons DIR --avatar A.glb --haha HAHA --work W

Imports the avatar with the add-on, turns a 48-frame `haha motion --kind walk` into an
action on its armature, exports armature and body to FBX and to glTF, and re-imports each
in a fresh Blender (blender_reimport.py): the armature, the skin (vertex groups) and the
action are there and the body's vertices at frame 24 match the runtime's reposing of that
motion frame with pose correctives off (the file's skin) within 1 mm; the distance to the
runtime with its correctives is printed. Exit 0 pass, 1 fail.
"""
import argparse
import os
import subprocess
import sys

import bpy
import numpy as np
from mathutils.kdtree import KDTree

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
for a in ("--addons", "--avatar", "--haha", "--work"):
    ap.add_argument(a, required=True)
args = ap.parse_args(argv)
failures = []
FRAME = 24


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


sys.path.insert(0, args.addons)
import io_import_haha_avatar as addon  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
addon.register()
haha = addon.runtime_link.import_haha()
bpy.ops.import_scene.haha_avatar(filepath=args.avatar)
arm = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"][0]
body = arm.data["haha_body"]
avatar = haha.Avatar(args.avatar)
motion_path = os.path.join(args.work, "walk.npz")
subprocess.run([args.haha, "motion", "--out", motion_path, "--kind", "walk"], check=True, stdout=subprocess.DEVNULL)
motion = haha.Motion(motion_path, avatar)
addon.posing.apply_motion(arm, motion, "walk", start=1)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, len(motion)
pose, transl = motion[FRAME - 1]
plain = haha.Avatar.from_bytes(addon.plain_skin.without_pose_correctives(args.avatar), name="plain")
to_world = np.array(arm.matrix_world)


def world(v):
    return v @ to_world[:3, :3].T + to_world[:3, 3]


lbs, full, rest = (world(a.repose(*p).vertices) for a, p in ((plain, (pose, transl)), (avatar, (pose, transl)),
                                                             (plain, ())))
for o in scene.objects:
    o.select_set(o in (arm, body))
bpy.context.view_layer.objects.active = arm
exports = {"fbx": os.path.join(args.work, "walk.fbx"), "glb": os.path.join(args.work, "walk.glb")}
bpy.ops.export_scene.fbx(filepath=exports["fbx"], use_selection=True, add_leaf_bones=False, bake_anim=True,
                         bake_anim_simplify_factor=0.0)  # every frame keyed as it is, not thinned
bpy.ops.export_scene.gltf(filepath=exports["glb"], use_selection=True, export_format="GLB", export_animations=True)
for kind, path in exports.items():
    out = os.path.join(args.work, "reimported_%s.npz" % kind)
    subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                    os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_reimport.py"), "--",
                    path, str(FRAME), out], check=True, stdout=subprocess.DEVNULL)
    r = np.load(out)
    check(int(r["armatures"]) == 1 and int(r["bones"]) == 55, "%s: one armature of %d bones" % (kind, int(r["bones"])))
    check(int(r["groups"]) == len(body.vertex_groups), "%s: %d vertex groups (%d exported)"
          % (kind, int(r["groups"]), len(body.vertex_groups)))
    check(r["frames"][1] - r["frames"][0] + 1 >= len(motion), "%s: the action spans frames %g-%g (%d-frame motion)"
          % (kind, r["frames"][0], r["frames"][1], len(motion)))
    tree = KDTree(len(rest))  # exporters may split vertices at UV seams: match by rest position
    for i, p in enumerate(rest):
        tree.insert(p, i)
    tree.balance()
    found = [tree.find(p) for p in r["rest"]]
    idx = np.array([f[1] for f in found])
    far = max(f[2] for f in found)
    err = np.linalg.norm(r["posed"] - lbs[idx], axis=1)
    check(far <= 1e-5 and err.max() <= 1e-3, "%s: frame %d body vs the file's skin (runtime, correctives off): max "
          "%.3f mm over %d vertices (rest matched within %.1e m)" % (kind, FRAME, 1e3 * err.max(), len(idx), far))
    print("     %s: and %.2f mm (max) from the runtime's reposing with pose correctives"
          % (kind, 1e3 * np.linalg.norm(r["posed"] - full[idx], axis=1).max()), flush=True)
print("PASS" if not failures else "FAILED: %d check(s)" % len(failures), flush=True)
sys.exit(1 if failures else 0)
