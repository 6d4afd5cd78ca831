# Blender between haha's BVH out and `haha motion --retarget` in, CTest `blender_retarget`
# (tests/interop/blender_retarget_test.sh). Two modes:
#   blender -b --factory-startup --python tests/interop/blender_retarget.py -- export IN.bvh OUT_DIR
#     imports haha's BVH (`haha motion --in M.npz --out IN.bvh`) with Blender's own importer,
#     checks the armature (55 bones) and the action (every frame), renames the bones to Mixamo's
#     (`mixamorig:Hips`, ...; jaw and eyes to names no map knows), and writes the armature with
#     Blender's exporters as OUT_DIR/rig.fbx and OUT_DIR/rig.bvh: another rig's names, Blender's
#     bone axes (each bone's Y along it) and, in the FBX, centimetres.
#   blender -b --factory-startup --python tests/interop/blender_retarget.py -- compare M.npz BACK.npz... 
#     every joint of every frame of each BACK (`haha motion --retarget OUT_DIR/rig.fbx ...`)
#     within 1 degree of M's, the root path within 1 cm.
# Exit 0 pass, 1 fail (the failed checks printed).
import os
import sys

import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


SMPLX = ["pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
         "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head",
         "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "jaw",
         "left_eye", "right_eye"]
MIXAMO = ["Hips", "LeftUpLeg", "RightUpLeg", "Spine", "LeftLeg", "RightLeg", "Spine1", "LeftFoot",
          "RightFoot", "Spine2", "LeftToeBase", "RightToeBase", "Neck", "LeftShoulder", "RightShoulder", "Head",
          "LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LeftHand", "RightHand", "FaceJaw", "FaceEyeL",
          "FaceEyeR"]
A_POSE_DEG = 40.0  # the exported rig's arms rest this far below the imported T-pose
TRAVEL_CM = 2.0  # the rig's travel per frame, in the BVH's centimetres
FINGERS = {"index": "Index", "middle": "Middle", "pinky": "Pinky", "ring": "Ring", "thumb": "Thumb"}


def mixamo_name(smplx):
    if smplx in SMPLX:
        return "mixamorig:" + MIXAMO[SMPLX.index(smplx)]
    side, rest = smplx.split("_", 1)  # left_index1 -> LeftHandIndex1
    return "mixamorig:" + side.capitalize() + "Hand" + FINGERS[rest[:-1]] + rest[-1]


def open_without_u(real_open):
    """Blender 3.4's BVH importer opens with mode 'rU', which Python 3.11 (Debian 12's) refuses:
    the same open without the 'U' (universal newlines are the default since Python 3)."""
    def patched(file, mode="r", *args, **kwargs):
        return real_open(file, mode.replace("U", "") if isinstance(mode, str) else mode, *args, **kwargs)
    return patched


def a_pose_copy(src, start, end):
    """A second armature whose rest has the arms A_POSE_DEG down (each arm's bones turned about
    the shoulder), playing the same world motion as src: every bone copies src's bone's world
    rotation (the root also its location), baked into an action; src is removed."""
    from mathutils import Matrix, Vector
    bpy.ops.object.select_all(action="DESELECT")
    src.select_set(True)
    bpy.context.view_layer.objects.active = src
    bpy.ops.object.duplicate()
    tgt = bpy.context.view_layer.objects.active
    tgt.animation_data_clear()
    bpy.ops.object.mode_set(mode="EDIT")
    bones = tgt.data.edit_bones
    for side in ("Left", "Right"):
        upper = bones["mixamorig:" + side + "Arm"]
        pivot = upper.head.copy()
        d = (upper.tail - upper.head).normalized()
        down = Vector((0, 0, -1))
        turn = Matrix.Translation(pivot) @ Matrix.Rotation(np.radians(A_POSE_DEG), 4, d.cross(down).normalized()) @ \
            Matrix.Translation(-pivot)
        for b in [upper] + list(upper.children_recursive):
            b.matrix = turn @ b.matrix
    bpy.ops.object.mode_set(mode="POSE")
    root = [b.name for b in tgt.data.bones if b.parent is None][0]
    for pb in tgt.pose.bones:
        c = pb.constraints.new("COPY_ROTATION")
        c.target, c.subtarget, c.target_space, c.owner_space = src, pb.name, "WORLD", "WORLD"
        if pb.name == root:
            c = pb.constraints.new("COPY_LOCATION")
            c.target, c.subtarget, c.target_space, c.owner_space = src, pb.name, "WORLD", "WORLD"
    bpy.ops.nla.bake(frame_start=start, frame_end=end, only_selected=False, visual_keying=True,
                     clear_constraints=True, bake_types={"POSE"})
    bpy.ops.object.mode_set(mode="OBJECT")
    action = tgt.animation_data.action
    bpy.data.objects.remove(src)
    rest_arm = tgt.data.bones["mixamorig:LeftForeArm"].matrix_local.to_3x3() @ Vector((0, 1, 0))
    check(rest_arm.z < -0.5 * np.sin(np.radians(A_POSE_DEG)), "the copy rests in an A-pose (left forearm %s)" %
          np.round(np.array(rest_arm), 3))
    return tgt, action


def export(bvh, out):
    import builtins
    builtins.open = open_without_u(builtins.open)
    bpy.ops.import_anim.bvh(filepath=bvh, rotate_mode="NATIVE", update_scene_fps=True, update_scene_duration=True)
    arms = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
    check(len(arms) == 1, "one armature imported (%d)" % len(arms))
    arm = arms[0]
    check(len(arm.data.bones) == 55, "55 bones (%d)" % len(arm.data.bones))
    action = arm.animation_data.action if arm.animation_data else None
    check(action is not None, "an action on the armature")
    if failures:
        return
    start, end = (int(round(x)) for x in action.frame_range)
    print("imported %s: %d bones, frames %d..%d at %g fps" % (bvh, len(arm.data.bones), start, end,
                                                           bpy.context.scene.render.fps))
    # A root path to carry: the root bone walks TRAVEL_CM along the armature's X a frame (the
    # procedural motions stand in place; Blender's BVH exporter ignores the object's motion).
    root = arm.pose.bones[[b.name for b in arm.data.bones if b.parent is None][0]]
    scene = bpy.context.scene
    for f in range(start, end + 1):
        scene.frame_set(f)
        m = root.matrix.copy()
        m.translation.x += (f - start) * TRAVEL_CM
        root.matrix = m
        root.keyframe_insert(data_path="location", frame=f)
    for b in arm.data.bones:  # fcurve paths follow a renamed bone
        b.name = mixamo_name(b.name)
    check(any('"mixamorig:LeftForeArm"' in fc.data_path for fc in action.fcurves), "the action follows the new names")
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = start, end
    arm, action = a_pose_copy(arm, start, end)
    bpy.ops.object.select_all(action="DESELECT")
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.export_anim.bvh(filepath=os.path.join(out, "rig.bvh"), frame_start=start, frame_end=end,
                            rotate_mode="NATIVE")
    # An armature-only FBX has no bind pose: its bones' default transforms are the pose shown
    # at export. Shown at rest (the action kept aside, every bone's pose cleared), they are
    # the rig's rest, and the exporter bakes the action from "all actions".
    action.use_fake_user = True
    arm.animation_data.action = None
    for pb in arm.pose.bones:
        pb.matrix_basis.identity()
    bpy.context.view_layer.update()
    bpy.ops.export_scene.fbx(filepath=os.path.join(out, "rig.fbx"), use_selection=True, object_types={"ARMATURE"},
                             add_leaf_bones=False, bake_anim=True, bake_anim_use_all_actions=True,
                             bake_anim_use_nla_strips=False, bake_anim_simplify_factor=0.0,
                             apply_scale_options="FBX_SCALE_UNITS", global_scale=1.0)
    for f in ("rig.fbx", "rig.bvh"):
        p = os.path.join(out, f)
        check(os.path.isfile(p) and os.path.getsize(p) > 0, "wrote " + p)


def rotations(poses):
    """(T, 165) axis-angle -> (T, 55, 3, 3)."""
    aa = poses.reshape(poses.shape[0], -1, 3)
    th = np.linalg.norm(aa, axis=-1, keepdims=True)
    k = np.where(th > 1e-12, aa / np.maximum(th, 1e-12), 0.0)
    K = np.zeros(aa.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    s, c = np.sin(th)[..., None], np.cos(th)[..., None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def compare(ref_path, backs):
    ref = np.load(ref_path)
    R0, t0 = rotations(ref["poses"]), ref["trans"]
    for path in backs:
        back = np.load(path)
        check(back["poses"].shape == ref["poses"].shape, "%s: %s frames as the original %s" %
              (path, back["poses"].shape, ref["poses"].shape))
        if back["poses"].shape != ref["poses"].shape:
            continue
        R1 = rotations(back["poses"])
        cos = (np.einsum("tjab,tjab->tj", R0, R1) - 1) / 2  # trace(R0^T R1) = 1 + 2 cos
        deg = np.degrees(np.arccos(np.clip(cos, -1, 1)))
        worst = np.unravel_index(np.argmax(deg), deg.shape)
        check(deg.max() <= 1.0, "%s: every joint within 1 degree (worst %.3f deg: joint %d, frame %d; mean %.4f deg)" %
              (path, deg.max(), worst[1], worst[0], deg.mean()))
        # The root path: the original's (which stands in place) plus the rig's travel, TRAVEL_CM
        # a frame along one horizontal axis, in metres; the height up to a constant (the
        # retargeter stands the lowest ankle on the rest ankle height). Both files are Y up.
        d = back["trans"] - t0
        d = d - d[0]
        frames = np.arange(len(d))
        along = np.hypot(d[:, 0], d[:, 2])
        err = np.abs(along - frames * TRAVEL_CM / 100)
        check(float(err.max()) <= 0.01 and float(np.ptp(d[:, 1])) <= 0.01,
              "%s: root travels %.3f m over the clip as the rig's %.3f m (worst %.4f m off), height within %.4f m" %
              (path, along[-1], frames[-1] * TRAVEL_CM / 100, err.max(), np.ptp(d[:, 1])))


if len(argv) >= 3 and argv[0] == "export":
    export(argv[1], argv[2])
elif len(argv) >= 3 and argv[0] == "compare":
    compare(argv[1], argv[2:])
else:
    print("usage: blender -b --python blender_retarget.py -- export IN.bvh OUT_DIR | compare M.npz BACK.npz...")
    sys.exit(2)
if failures:
    print("%d check(s) failed" % len(failures))
    sys.exit(1)
print("all checks passed")
