# Blender import check of a Draco-free HAHA avatar (`haha pack --mesh-compression none`), CTest
# `blender_import` (tests/interop/blender_test.sh). Run:
#   blender -b --factory-startup --python tests/interop/blender_import.py -- AVATAR.glb
# Asserts what a Blender user gets from the file alone: no required glTF extension; one triangle
# mesh with the textured material (its image loaded); an armature of the 55 SMPL-X joints; the
# mesh skinned to it (vertex groups + Armature modifier); rotating left_shoulder moves the
# vertices skinned to the left arm and leaves every vertex without a left-arm weight where it
# was (evaluated mesh); a garment primitive (format version 4) comes in skinned with the body.
# Exit 0 pass, 1 fail (the failed checks printed).
import json
import math
import struct
import sys

import bpy
from mathutils import Quaternion

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) != 1:
    print("usage: blender -b --python blender_import.py -- AVATAR.glb")
    sys.exit(2)
path = argv[0]
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def glb_json(p):
    with open(p, "rb") as f:
        head = f.read(20)
        if len(head) < 20 or head[:4] != b"glTF":
            raise SystemExit(f"{p}: not a GLB file")
        n, kind = struct.unpack("<II", head[12:20])
        if kind != 0x4E4F534A:
            raise SystemExit(f"{p}: first GLB chunk is not JSON")
        return json.loads(f.read(n))


gltf = glb_json(path)
check(not gltf.get("extensionsRequired"), f"no extensionsRequired (file lists {gltf.get('extensionsRequired', [])})")

bpy.ops.wm.read_factory_settings(use_empty=True)
# 'SMOOTH': the default 'NORMALS' fails on Debian 12's numpy 1.24 (np.bool) for files without normals.
result = bpy.ops.import_scene.gltf(filepath=path, import_shading="SMOOTH")
check(result == {"FINISHED"}, f"import finished ({result})")

objs = list(bpy.context.scene.objects)
meshes = [o for o in objs if o.type == "MESH" and len(o.data.polygons) > 0]
arms = [o for o in objs if o.type == "ARMATURE"]
check(len(meshes) == 1, f"one triangle mesh (found {[o.name for o in meshes]})")
check(len(arms) == 1, f"one armature (found {[o.name for o in arms]})")
if failures:
    sys.exit(1)
body, arm = meshes[0], arms[0]
print(f"mesh '{body.name}': {len(body.data.vertices)} vertices, {len(body.data.polygons)} faces")

# Textured material: an Image Texture node feeding the shader, with pixels.
mats = [m for m in body.data.materials if m is not None]
check(len(mats) >= 1, f"a material ({[m.name for m in mats]})")
images = []
for m in mats:
    if m.use_nodes:
        images += [n.image for n in m.node_tree.nodes if n.type == "TEX_IMAGE" and n.image is not None]
check(len(images) >= 1, "the material has an image texture")
if images:
    img = images[0]
    w, h = img.size
    check(w > 0 and h > 0 and img.has_data, f"image '{img.name}' loaded ({w} x {h})")
uv_layer = body.data.uv_layers.active
check(uv_layer is not None, "the mesh has UVs")
if uv_layer is not None:
    us = [d.uv[0] for d in uv_layer.data]
    vs = [d.uv[1] for d in uv_layer.data]
    # Normalized unsigned-short UVs must come back in [0, 1] (an importer that ignores
    # `normalized` gets 0..65535: one texel colour over the whole body).
    check(min(us) >= -1e-6 and max(us) <= 1 + 1e-6 and min(vs) >= -1e-6 and max(vs) <= 1 + 1e-6,
          f"UVs in [0, 1] (u {min(us):.3f}..{max(us):.3f}, v {min(vs):.3f}..{max(vs):.3f})")
    check(max(us) - min(us) > 0.5 and max(vs) - min(vs) > 0.5, "UVs spread over the texture")

# Skeleton and skin.
bones = arm.data.bones
check(len(bones) == 55, f"armature has 55 bones (has {len(bones)})")
check("left_shoulder" in bones and "pelvis" in bones, "joint names (pelvis, left_shoulder)")
mods = [md for md in body.modifiers if md.type == "ARMATURE" and md.object == arm]
check(len(mods) == 1, "the mesh has an Armature modifier on the armature")
groups = {g.index: g.name for g in body.vertex_groups}
check(len(groups) >= 20, f"the mesh has vertex groups ({len(groups)})")
if failures:
    sys.exit(1)

# Which vertices the left arm (left_shoulder and everything below it) influences.
arm_bones = {b.name for b in bones["left_shoulder"].children_recursive} | {"left_shoulder"}
arm_weight = []
for v in body.data.vertices:
    arm_weight.append(sum(g.weight for g in v.groups if groups.get(g.group) in arm_bones))


def evaluated_positions():
    bpy.context.view_layer.update()
    dg = bpy.context.evaluated_depsgraph_get()
    ev = body.evaluated_get(dg)
    me = ev.to_mesh()
    pos = [body.matrix_world @ v.co for v in me.vertices]  # world space (the body node has no transform)
    ev.to_mesh_clear()
    return pos


rest = evaluated_positions()
pb = arm.pose.bones["left_shoulder"]
pb.rotation_mode = "QUATERNION"
pb.rotation_quaternion = Quaternion((1.0, 0.0, 0.0), math.radians(70.0)) @ Quaternion((0.0, 0.0, 1.0), math.radians(40.0))
posed = evaluated_positions()
check(len(rest) == len(posed) == len(body.data.vertices), "evaluated mesh keeps the vertex count")
moved = [(p - r).length for p, r in zip(posed, rest)]
on_arm = [i for i, w in enumerate(arm_weight) if w > 0.5]
off_arm = [i for i, w in enumerate(arm_weight) if w == 0.0]
check(len(on_arm) > 0 and len(off_arm) > 0, f"vertices on the left arm: {len(on_arm)}, without left-arm weight: {len(off_arm)}")
if on_arm and off_arm:
    min_on = min(moved[i] for i in on_arm)
    max_off = max(moved[i] for i in off_arm)
    mean_on = sum(moved[i] for i in on_arm) / len(on_arm)
    print(f"left_shoulder rotated: arm vertices moved {min_on * 1000:.2f} .. mean {mean_on * 1000:.1f} mm; "
          f"others at most {max_off * 1000:.6f} mm")
    check(min_on > 1e-3, "every vertex skinned mostly to the left arm moves (> 1 mm)")
    check(mean_on > 0.02, "the left arm moves on average > 2 cm")
    check(max_off < 1e-6, "no vertex without a left-arm weight moves")
pb.rotation_quaternion = Quaternion()
back = evaluated_positions()
check(max((b - r).length for b, r in zip(back, rest)) < 1e-6, "the rest pose comes back")


# A garment (format version 4: the body mesh's primitive 1) comes in with the body, skinned
# to the same armature: rotating left_hip moves the garment's vertices weighted to the left
# leg and leaves those without a left-leg weight where they were.
def garment_checks():
    ext = gltf.get("extensions", {}).get("HAHA_gaussian_avatar", {})
    if "garment" not in ext.get("body", {}):
        return
    prims = gltf["meshes"][ext["body"]["mesh"]]["primitives"]
    check(len(prims) == 2, f"the garment is the body mesh's second primitive ({len(prims)} primitives)")
    counts = [gltf["accessors"][p["attributes"]["POSITION"]]["count"] for p in prims]
    check(len(body.data.vertices) == sum(counts),
          f"both primitives imported into the body mesh ({len(body.data.vertices)} vertices, primitives {counts})")
    if failures:
        return
    garment = range(counts[0], sum(counts))
    check(all(len(body.data.vertices[i].groups) > 0 for i in garment), f"every garment vertex is skinned ({len(garment)})")
    leg_bones = {b.name for b in bones["left_hip"].children_recursive} | {"left_hip"}
    leg_weight = {i: sum(g.weight for g in body.data.vertices[i].groups if groups.get(g.group) in leg_bones) for i in garment}
    hip = arm.pose.bones["left_hip"]
    hip.rotation_mode = "QUATERNION"
    hip.rotation_quaternion = Quaternion((1.0, 0.0, 0.0), math.radians(-30.0))
    posed = evaluated_positions()
    hip.rotation_quaternion = Quaternion()
    on_leg = [i for i in garment if leg_weight[i] > 0.2]
    off_leg = [i for i in garment if leg_weight[i] == 0.0]
    moved = {i: (posed[i] - rest[i]).length for i in garment}
    print(f"left_hip rotated: {len(on_leg)} garment vertices on the left leg moved "
          f"{min([moved[i] for i in on_leg] or [0]) * 1000:.2f} mm or more; {len(off_leg)} without a left-leg weight "
          f"moved at most {max([moved[i] for i in off_leg] or [0]) * 1000:.6f} mm")
    check(len(on_leg) > 0, "garment vertices weighted to the left leg")
    check(all(moved[i] > 1e-3 for i in on_leg), "they move with the leg (> 1 mm)")
    check(all(moved[i] < 1e-6 for i in off_leg), "garment vertices without a left-leg weight stay")


garment_checks()

print("PASS" if not failures else f"FAILED: {len(failures)} check(s)")
sys.exit(1 if failures else 0)
