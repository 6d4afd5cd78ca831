"""File > Import > HAHA avatar (.glb): the armature, the body skinned by it and the Gaussian
layer bound to the body, all decoded by libhaha_runtime.so through the `haha` package
(Draco files included), and the file's glTF animations as actions on the armature. Nothing
runs in Python after the import: the Armature modifier and the geometry nodes do the posing."""
import os
import tempfile

import bpy
import numpy as np

from . import face_binding, glb_skeleton, plain_skin, posing, runtime_link, scene_build


def _settings(path):
    ext = glb_skeleton.read_gltf_json(path)["extensions"]["HAHA_gaussian_avatar"]
    return {"scale_divisor": ext["faceFrame"]["scaleDivisor"],
            "depth_margin": ext.get("depthTest", {}).get("margin", 0.0)}


def set_color_management(scene):
    """Raw view transform (display values in and out, so splats blend like haha render's)
    and enough transparent bounces for stacked splats in Cycles."""
    scene.view_settings.view_transform = "Raw"
    scene.view_settings.look = "None"
    if hasattr(scene, "cycles"):
        scene.cycles.transparent_max_bounces = max(scene.cycles.transparent_max_bounces, 256)
    scene.eevee.use_taa_reprojection = False


def _plain_avatar(haha, path, max_gaussians):
    """The file without its pose correctives (plain_skin), with at most max_gaussians of its
    importance tiers (haha pack --lod; 0: all). The runtime reads tiers from files only."""
    data = plain_skin.without_pose_correctives(path)
    if max_gaussians <= 0:
        return haha.Avatar.from_bytes(data, name=path)
    with tempfile.TemporaryDirectory() as d:
        tmp = os.path.join(d, os.path.basename(path))
        with open(tmp, "wb") as f:
            f.write(data)
        return haha.Avatar(tmp, max_gaussians=max_gaussians)


def import_avatar(context, path, max_gaussians=0):
    """Imports `path`; returns the armature object. Raises with one line naming the file.
    max_gaussians > 0: a file packed with importance tiers brings only the tiers within that
    count (the first always), as haha_avatar_load_lod does for a distant avatar."""
    haha = runtime_link.import_haha()
    path = os.path.abspath(bpy.path.abspath(path))
    full = haha.Avatar(path)  # haha.FileError / haha.FormatError: "<file>: <problem>"
    skeleton = glb_skeleton.read_skeleton(path)
    plain = _plain_avatar(haha, path, max_gaussians)
    if len(skeleton) != plain.num_joints:
        raise ValueError("%s: the skin has %d joints, the avatar %d" % (path, len(skeleton), plain.num_joints))
    rest = plain.repose()
    weights = plain_skin.skin_weights(plain, [p for _, p in skeleton], rest.vertices, rest.joints)
    settings = _settings(path)
    name = os.path.splitext(os.path.basename(path))[0]
    collection = context.collection or context.scene.collection
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    arm = scene_build.build_armature(name, skeleton, rest.joints, collection)
    arm.data["haha_avatar_path"] = path
    arm.data["haha_joint_names"] = [n for n, _ in skeleton]
    body = scene_build.build_body(name + "_body", plain, rest.vertices, weights, arm, collection)
    arm.data["haha_body"] = body
    if plain.num_gaussians:
        binding = face_binding.bind(plain, plain.faces, settings["scale_divisor"])
        gaussians = scene_build.build_gaussians(name + "_gaussians", binding, plain.faces, body, settings, collection)
        arm.data["haha_gaussians"] = gaussians
        arm.data["haha_binding_error"] = float(np.max(binding["error"]))
        if context.scene.camera is not None:
            from .camera import use_camera
            use_camera(gaussians, context.scene.camera, context.scene)
    posing.import_animations(full, arm, context.scene)  # the file's glTF animations, as actions
    set_color_management(context.scene)
    for o in context.view_layer.objects:
        o.select_set(False)
    arm.select_set(True)
    context.view_layer.objects.active = arm
    return arm
