"""Helper of CTest `blender_export` (tests/python/blender_export_test.py), run in a fresh
headless Blender: imports an exported FBX or glTF and writes what came back to OUT.npz:
bones, vertex groups, the action's frame range, the skinned mesh's rest and frame-F
vertices (world space).
  blender -b --factory-startup --python blender_reimport.py -- FILE FRAME OUT.npz"""
import sys

import bpy
import numpy as np

path, frame, out = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
if path.endswith(".fbx"):
    bpy.ops.import_scene.fbx(filepath=path)
else:
    bpy.ops.import_scene.gltf(filepath=path, import_shading="SMOOTH")  # NORMALS fails on Debian's numpy
arms = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
meshes = [o for o in bpy.context.scene.objects if o.type == "MESH" and o.find_armature() is not None]
arm, body = arms[0], meshes[0]
action = arm.animation_data.action if arm.animation_data else None
rest = np.array([body.matrix_world @ v.co for v in body.data.vertices])
bpy.context.scene.frame_set(int(frame))
dg = bpy.context.evaluated_depsgraph_get()
ev = body.evaluated_get(dg)
me = ev.to_mesh()
posed = np.array([ev.matrix_world @ v.co for v in me.vertices])
ev.to_mesh_clear()
np.savez(out, bones=len(arm.data.bones), groups=len(body.vertex_groups), armatures=len(arms),
         frames=np.array(action.frame_range if action else (0, 0)), rest=rest, posed=posed)
