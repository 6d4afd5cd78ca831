"""The Blender objects of an imported avatar: armature, textured body, Gaussian layer.

All three live in the avatar's own frame (SMPL-X: metres, Y up, facing +Z): the armature
object turns it Z up (+90 degrees about X) and the body and Gaussians are its children,
so their data stays in the runtime's coordinates.
"""
import math

import bpy
import numpy as np
from mathutils import Vector

from . import shading

SPHERE_SIGMAS = 3.0  # each Gaussian is drawn as the ellipsoid of 3 standard deviations


def _bone_tail(j, heads, children):
    """A tail for bone j: towards its first child, else along its parent's direction."""
    head = Vector(heads[j])
    if children[j]:
        d = Vector(heads[children[j][0]]) - head
        if d.length > 1e-3:
            return head + d
    return head + Vector((0.0, 0.03, 0.0))


def build_armature(name, skeleton, heads, collection):
    """An armature of the file's joints, heads at the rest joints, no roll; bones point to a child."""
    data = bpy.data.armatures.new(name)
    data.display_type = "STICK"
    arm = bpy.data.objects.new(name, data)
    arm.rotation_euler = (math.radians(90.0), 0.0, 0.0)  # Y up -> Blender's Z up
    collection.objects.link(arm)
    children = [[] for _ in skeleton]
    for j, (_, parent) in enumerate(skeleton):
        if parent >= 0:
            children[parent].append(j)
    view_layer = bpy.context.view_layer
    view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    bones = []
    for j, (bone_name, parent) in enumerate(skeleton):
        b = data.edit_bones.new(bone_name)
        b.head = Vector(heads[j])
        b.tail = _bone_tail(j, heads, children)
        b.roll = 0.0
        if parent >= 0:
            b.parent = bones[parent]
        bones.append(b)
    bpy.ops.object.mode_set(mode="OBJECT")
    for pb in arm.pose.bones:
        pb.rotation_mode = "QUATERNION"
    return arm


def _texture_image(name, texture):
    h, w, _ = texture.shape
    img = bpy.data.images.new(name, w, h, alpha=False)
    rgba = np.ones((h, w, 4), np.float32)
    rgba[:, :, :3] = texture[::-1].astype(np.float32) / 255.0  # Blender stores the bottom row first
    img.pixels.foreach_set(rgba.reshape(-1))
    img.pack()
    return img


def build_body(name, avatar, vertices, parent, collection):
    """The body mesh (file vertex order, per-corner UVs) with an unlit textured material."""
    faces = avatar.faces
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(vertices))
    me.vertices.foreach_set("co", vertices.reshape(-1))
    me.loops.add(faces.size)
    me.loops.foreach_set("vertex_index", faces.reshape(-1).astype(np.int32))
    me.polygons.add(len(faces))
    me.polygons.foreach_set("loop_start", np.arange(0, faces.size, 3, dtype=np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(faces), 3, np.int32))
    uv = me.uv_layers.new(name="UVMap")
    uv.data.foreach_set("uv", avatar.face_uvs.reshape(-1))
    me.update()
    me.validate()
    me.polygons.foreach_set("use_smooth", np.ones(len(faces), bool))
    tex = avatar.texture
    image = _texture_image(name + "_texture", tex) if tex is not None else None
    me.materials.append(shading.body_material(name + "_material", image))
    obj = bpy.data.objects.new(name, me)
    obj.parent = parent
    collection.objects.link(obj)
    return obj


def build_gaussians(name, num_gaussians, parent, collection):
    """A point mesh (one vertex per Gaussian, attributes written by pose_sync) drawn as
    instanced ellipsoids by a geometry-nodes modifier."""
    me = bpy.data.meshes.new(name)
    me.vertices.add(num_gaussians)
    for attr, kind in (("haha_rotation", "FLOAT_VECTOR"), ("haha_scale", "FLOAT_VECTOR"),
                       ("haha_color", "FLOAT_COLOR"), ("haha_opacity", "FLOAT"), ("haha_inv0", "FLOAT_VECTOR"),
                       ("haha_inv1", "FLOAT_VECTOR"), ("haha_inv2", "FLOAT_VECTOR")):
        me.attributes.new(attr, kind, "POINT")
    obj = bpy.data.objects.new(name, me)
    obj.parent = parent
    collection.objects.link(obj)
    mod = obj.modifiers.new("HAHA Gaussians", "NODES")
    mod.node_group = shading.gaussian_node_group(SPHERE_SIGMAS)
    return obj

