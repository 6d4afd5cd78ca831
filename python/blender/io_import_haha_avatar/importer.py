"""File > Import > HAHA avatar (.glb): the body, its armature and the Gaussian layer, all
decoded by libhaha_runtime.so through the `haha` package (Draco files included)."""
import os

import bpy

from . import glb_skeleton, pose_sync, runtime_link, scene_build


def import_avatar(context, path):
    """Imports `path`; returns the armature object. Raises with one line naming the file."""
    haha = runtime_link.import_haha()
    path = os.path.abspath(bpy.path.abspath(path))
    avatar = haha.Avatar(path)  # haha.FileError / haha.FormatError: "<file>: <problem>"
    skeleton = glb_skeleton.read_skeleton(path)
    if len(skeleton) != avatar.num_joints:
        raise ValueError("%s: the skin has %d joints, the avatar %d" % (path, len(skeleton), avatar.num_joints))
    rest = avatar.repose()
    name = os.path.splitext(os.path.basename(path))[0]
    collection = context.collection or context.scene.collection
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    arm = scene_build.build_armature(name, skeleton, rest.joints, collection)
    arm.data["haha_avatar_path"] = path
    arm.data["haha_joint_names"] = [n for n, _ in skeleton]
    body = scene_build.build_body(name + "_body", avatar, rest.vertices, arm, collection)
    gaussians = scene_build.build_gaussians(name + "_gaussians", avatar.num_gaussians, arm, collection)
    arm.data["haha_body"] = body
    arm.data["haha_gaussians"] = gaussians
    pose_sync.sync(arm, force=True)
    for o in context.view_layer.objects:
        o.select_set(False)
    arm.select_set(True)
    context.view_layer.objects.active = arm
    return arm
