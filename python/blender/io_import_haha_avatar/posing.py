"""SMPL-X poses on the imported armature: a joint's axis-angle (avatar frame) is its bone's
rotation B^T R B (B: the bone's rest axes), the root bone's location the translation
B^T t. Used to pose from code, to turn a motion (.npz) into an ordinary action, and to bring
the file's own glTF animations in as actions."""
import math

import numpy as np
from mathutils import Matrix, Quaternion, Vector


def _rotation(aa):
    aa = np.asarray(aa, np.float64)
    angle = float(np.linalg.norm(aa))
    return Matrix.Rotation(angle, 3, Vector(aa / angle)) if angle > 0 else Matrix.Identity(3)


def bone_quaternion(pose_bone, aa):
    """The rotation_quaternion of `pose_bone` that turns its joint by axis-angle `aa`."""
    b = pose_bone.bone.matrix_local.to_3x3()
    return (b.transposed() @ _rotation(aa) @ b).to_quaternion()


def set_pose(arm, pose, transl=None):
    """Poses armature `arm` with SMPL-X `pose` (J, 3) and translation `transl` (3,)."""
    names = list(arm.data["haha_joint_names"])
    pose = np.asarray(pose, np.float64).reshape(len(names), 3)
    for j, name in enumerate(names):
        pb = arm.pose.bones[name]
        pb.rotation_mode = "QUATERNION"
        pb.rotation_quaternion = bone_quaternion(pb, pose[j])
        if j == 0:
            pb.location = pb.bone.matrix_local.to_3x3().transposed() @ Vector(np.zeros(3) if transl is None else transl)


def apply_motion(arm, frames, name="HAHA motion", start=1):
    """An action on `arm` keyframing every bone for each (pose, transl) of `frames` (a
    haha.Motion or a list), from frame `start`; it becomes the armature's active action."""
    import bpy
    action = bpy.data.actions.new(name)
    if arm.animation_data is None:
        arm.animation_data_create()
    arm.animation_data.action = action
    names = list(arm.data["haha_joint_names"])
    curves = {}
    for j, bname in enumerate(names):
        path = 'pose.bones["%s"].' % bname
        curves[j] = [action.fcurves.new(path + "rotation_quaternion", index=i, action_group=bname) for i in range(4)]
        if j == 0:
            curves["t"] = [action.fcurves.new(path + "location", index=i, action_group=bname) for i in range(3)]
    frames = list(frames)
    for fc in [c for cs in curves.values() for c in cs]:
        fc.keyframe_points.add(len(frames))
    for f, (pose, transl) in enumerate(frames):
        pose = np.asarray(pose, np.float64).reshape(len(names), 3)
        for j, bname in enumerate(names):
            pb = arm.pose.bones[bname]
            q = bone_quaternion(pb, pose[j])
            if f > 0:  # the shorter way round from the previous key
                prev = Quaternion([c.keyframe_points[f - 1].co[1] for c in curves[j]])
                if prev.dot(q) < 0:
                    q.negate()
            for i in range(4):
                curves[j][i].keyframe_points[f].co = (start + f, q[i])
        loc = arm.pose.bones[names[0]].bone.matrix_local.to_3x3().transposed() @ Vector(np.asarray(transl, np.float64))
        for i in range(3):
            curves["t"][i].keyframe_points[f].co = (start + f, loc[i])
    for fc in [c for cs in curves.values() for c in cs]:
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"
        fc.update()
    return action


def import_animations(avatar, arm, scene):
    """The file's glTF animations (`haha pack --animation`) as actions on `arm`, named like
    them: each sampled by the runtime (`avatar`: a haha.Avatar; slerp between its keys, as
    glTF viewers play it) at the scene's frame rate, keyed on every frame from
    scene.frame_start. The first becomes the armature's action; every one keeps a fake user,
    so the others stay in the file for the Action editor and the NLA. Returns the actions."""
    fps = scene.render.fps / scene.render.fps_base
    actions = []
    for a in avatar.animations:
        n = int(math.floor(a.duration * fps + 1e-6)) + 1
        frames = [avatar.sample_animation(a.index, k / fps) for k in range(n)]
        action = apply_motion(arm, frames, name=a.name, start=scene.frame_start)
        action.use_fake_user = True
        action["haha_animation"] = a.name
        actions.append(action)
    if actions:
        arm.animation_data.action = actions[0]
    return actions
