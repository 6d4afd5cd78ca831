"""The Blender objects of an imported avatar: armature, textured body, Gaussian layer.

All three live in the avatar's own frame (SMPL-X: metres, Y up, facing +Z): the armature
object turns it Z up (+90 degrees about X) and the body and Gaussians are its children,
so their data stays in the runtime's coordinates. The body is skinned by an Armature
modifier (a vertex group per bone); the Gaussians follow it through geometry nodes.
"""
import math

import bpy
import numpy as np
from mathutils import Vector

from . import gaussian_nodes, shading


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


def build_body(name, avatar, vertices, weights, arm, collection):
    """The body mesh (file vertex order, per-corner UVs, unlit textured material), a vertex
    group per bone holding `weights` (V, J) and an Armature modifier on `arm`."""
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
    coverage = avatar.mesh_coverage  # per body vertex (the file's vertex order), or None
    if coverage is not None:
        me.attributes.new(shading.COVERAGE_ATTRIBUTE, "FLOAT", "POINT").data.foreach_set("value", coverage)
    me.materials.append(shading.body_material(name + "_material", image, coverage is not None))
    obj = bpy.data.objects.new(name, me)
    obj.parent = arm
    collection.objects.link(obj)
    for j, bone_name in enumerate(arm.data["haha_joint_names"]):
        rows = np.flatnonzero(weights[:, j])
        if len(rows) == 0:
            continue
        group = obj.vertex_groups.new(name=bone_name)
        for v in rows:
            group.add([int(v)], float(weights[v, j]), "REPLACE")
    mod = obj.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    mod.use_vertex_groups = True
    return obj


def build_gaussians(name, binding, faces, body, settings, collection):
    """A point per Gaussian carrying its face binding (face_binding.bind) as attributes, the
    geometry-nodes group that poses it from `body` and draws it as a splat. `settings`:
    scale_divisor, depth_margin."""
    G = len(binding["face"])
    me = bpy.data.meshes.new(name)
    me.vertices.add(G)
    corners = faces[binding["face"]]
    for i in range(3):
        me.attributes.new("haha_v%d" % i, "INT", "POINT").data.foreach_set("value", corners[:, i].astype(np.int32))
    local = quat_to_matrix(binding["rotation"])
    for attr, values in (("haha_offset", binding["offset"]), ("haha_scale", binding["scale"]),
                         ("haha_axis0", local[:, :, 0]), ("haha_axis1", local[:, :, 1]), ("haha_axis2", local[:, :, 2])):
        me.attributes.new(attr, "FLOAT_VECTOR", "POINT").data.foreach_set("vector", np.ascontiguousarray(values).reshape(-1))
    rgba = np.ones((G, 4))
    rgba[:, :3] = binding["color"]  # display values: shown unchanged under the view transform Raw
    me.attributes.new("haha_color", "FLOAT_COLOR", "POINT").data.foreach_set("color", rgba.reshape(-1))
    me.attributes.new("haha_opacity", "FLOAT", "POINT").data.foreach_set("value", binding["opacity"])
    obj = bpy.data.objects.new(name, me)
    collection.objects.link(obj)  # at the world origin, unparented: its space is world space
    obj.lock_location = obj.lock_rotation = obj.lock_scale = (True, True, True)
    mod = obj.modifiers.new("HAHA Gaussians", "NODES")
    mod.node_group = gaussian_nodes.gaussian_node_group(shading.splat_material(name + "_splat"))
    set_input(mod, "Body", body)
    set_input(mod, "Scale Divisor", float(settings["scale_divisor"]))
    set_input(mod, "Depth Margin", float(settings["depth_margin"]))
    return obj


def set_input(mod, name, value):
    """Sets a geometry-nodes modifier's input by its socket name."""
    mod[mod.node_group.inputs[name].identifier] = value


def quat_to_matrix(q):
    """(G, 4) (w, x, y, z) -> (G, 3, 3) rotation matrices."""
    w, x, y, z = (q[:, i].astype(np.float64) for i in range(4))
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], 1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], 1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1)], 1)
