# Blender's own glTF importer on an animated plain pack (`haha pack --mesh-compression none
# --no-pose-correctives --animation M.npz`), CTest `blender_animation`
# (tests/interop/blender_animation_test.sh). Run:
#   blender -b --factory-startup --python tests/interop/blender_animation.py -- AVATAR.glb PYTHON_DIR [ADDONS]
# Asserts that the import makes an Action on the armature that plays the motion on the skinned
# body: at frames 0, 15 and 30 of the clip (scene at the clip's 30 fps) every vertex of the
# evaluated mesh is where the haha runtime (the `haha` package in PYTHON_DIR, sampling the
# file's animation and reposing) puts its body vertex, within 1 mm, while frame 30 is more than
# 5 cm from the rest pose somewhere (so a still or wrong action fails). No pose correctives in
# the file: Blender and the runtime then both skin linearly with every influence. With ADDONS
# (build/python/blender/addons), the same for the HAHA add-on's import: the file's animation
# becomes an Action of its name on the add-on's armature, playing the same motion. Exit 0 pass,
# 1 fail (the failed checks printed).
import sys

import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) not in (2, 3):
    print("usage: blender -b --python blender_animation.py -- AVATAR.glb PYTHON_DIR [ADDONS]")
    sys.exit(2)
path, python_dir = argv[:2]
sys.path.insert(0, python_dir)
import haha  # noqa: E402  (the package of PYTHON_DIR)

FPS = 30
TOLERANCE = 1e-3  # metres
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def to_gltf(points):
    """Blender's Z-up world (x, y, z) -> glTF's Y-up (x, z, -y)."""
    p = np.asarray(points, np.float64)
    return np.stack([p[:, 0], p[:, 2], -p[:, 1]], axis=1)


def evaluated(body):
    bpy.context.view_layer.update()
    ev = body.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    pos = to_gltf([body.matrix_world @ v.co for v in me.vertices])
    ev.to_mesh_clear()
    return pos


bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps, scene.render.fps_base = FPS, 1.0  # the importer turns key times into frames at this rate
result = bpy.ops.import_scene.gltf(filepath=path, import_shading="SMOOTH")
check(result == {"FINISHED"}, f"import finished ({result})")
meshes = [o for o in scene.objects if o.type == "MESH" and len(o.data.polygons) > 0]
arms = [o for o in scene.objects if o.type == "ARMATURE"]
check(len(meshes) == 1 and len(arms) == 1, "one mesh and one armature")
if failures:
    sys.exit(1)
body, arm = meshes[0], arms[0]
action = arm.animation_data.action if arm.animation_data else None
check(action is not None, "the armature has an Action")
if failures:
    sys.exit(1)
bones = {fc.data_path.split('"')[1] for fc in action.fcurves if fc.data_path.startswith("pose.bones")}
print(f"action '{action.name}': {len(action.fcurves)} F-curves on {len(bones)} bones, frames {tuple(action.frame_range)}")
check("left_shoulder" in bones and "pelvis" in bones, "the action moves pelvis and left_shoulder")
start = min(fc.keyframe_points[0].co[0] for fc in action.fcurves if len(fc.keyframe_points))
avatar = haha.Avatar(path)
anims = avatar.animations
check(len(anims) == 1, f"the runtime sees one animation ({anims})")


def compare(label, body, start, rest_blender):
    """Body vertices at frames 0, 15, 30 of the clip against the runtime's (matched at rest)."""
    rest_runtime = avatar.repose(np.zeros(165), np.zeros(3)).vertices.astype(np.float64)
    match = np.empty(len(rest_blender), np.int64)
    gap = 0.0
    for i0 in range(0, len(rest_blender), 512):
        d = np.linalg.norm(rest_blender[i0:i0 + 512, None, :] - rest_runtime[None, :, :], axis=2)
        match[i0:i0 + 512] = d.argmin(axis=1)
        gap = max(gap, float(d.min(axis=1).max()))
    check(gap < 1e-5, f"{label}: every vertex has a runtime body vertex at its rest position (worst {gap:.2e} m)")
    for k in (0, 15, 30):
        scene.frame_set(int(round(start)) + k)
        got = evaluated(body)
        pose, transl = avatar.sample_animation(0, k / FPS)
        want = avatar.repose(pose, transl).vertices.astype(np.float64)[match]
        err = np.linalg.norm(got - want, axis=1)
        moved = np.linalg.norm(want - rest_blender, axis=1).max()
        print(f"{label}, frame {k}: worst vertex {1000 * err.max():.3f} mm (mean {1000 * err.mean():.4f} mm) from the "
              f"runtime; the motion moves a vertex up to {100 * moved:.1f} cm from rest")
        check(err.max() <= TOLERANCE, f"{label}, frame {k}: the skinned body within {1000 * TOLERANCE:g} mm of the runtime")
        if k == 30:
            check(moved > 0.05, f"{label}: frame 30 is away from the rest pose (> 5 cm)")


scene.frame_set(0)
compare("glTF importer", body, start, to_gltf([body.matrix_world @ v.co for v in body.data.vertices]))

if len(argv) == 3:  # the HAHA add-on, in a fresh scene
    sys.path.insert(0, argv[2])
    import io_import_haha_avatar as addon  # noqa: E402

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = FPS, 1.0
    addon.register()
    check(bpy.ops.import_scene.haha_avatar(filepath=path) == {"FINISHED"}, "add-on: import finished")
    arm = [o for o in scene.objects if o.type == "ARMATURE"][0]
    body = arm.data["haha_body"]
    action = arm.animation_data.action if arm.animation_data else None
    check(action is not None and action.name == anims[0].name,
          f"add-on: the armature plays an action named like the file's animation ({action and action.name})")
    if action is not None:
        arm.animation_data.action = None  # the rest pose, to match vertices
        addon.posing.set_pose(arm, np.zeros((55, 3)), np.zeros(3))
        rest = evaluated(body)
        arm.animation_data.action = action
        compare("add-on", body, scene.frame_start, rest)

print("PASS" if not failures else f"FAILED: {len(failures)} check(s)")
sys.exit(1 if failures else 0)
