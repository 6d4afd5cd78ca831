"""Blender add-on: File > Import > HAHA avatar (.glb).

Imports a haha avatar (any pack: Draco files too, decoded by libhaha_runtime.so through the
Python package `haha`, not by Blender's glTF importer) as
  - an armature of the file's 55 SMPL-X joints (heads at the rest joints, no roll),
  - the textured body (unlit material: the texture as `haha render` shows it),
  - the Gaussians: a point per Gaussian drawn as oriented, coloured, semi-transparent
    ellipsoids (geometry-nodes instances, EEVEE and Cycles).
Posing the armature or playing an action reposes body and Gaussians exactly as the runtime
does (pose correctives, every Gaussian on its posed triangle's frame): pose_sync.py.
Operator: bpy.ops.import_scene.haha_avatar(filepath=...).
"""
bl_info = {
    "name": "HAHA avatar (.glb)",
    "author": "haha",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "File > Import > HAHA avatar (.glb)",
    "description": "Import a HAHA Gaussian avatar: skinned textured body, armature and Gaussians that follow it",
    "category": "Import-Export",
}

if "bpy" in locals():
    import importlib
    for _m in (camera, glb_skeleton, importer, pose_sync, runtime_link, scene_build, shading):  # noqa: F821
        importlib.reload(_m)

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ImportHelper

from . import camera, glb_skeleton, importer, pose_sync, runtime_link, scene_build, shading  # noqa: F401


class IMPORT_SCENE_OT_haha_avatar(bpy.types.Operator, ImportHelper):
    """Import a HAHA avatar (.glb): body, armature and Gaussians that follow it"""

    bl_idname = "import_scene.haha_avatar"
    bl_label = "Import HAHA avatar"
    bl_options = {"REGISTER", "UNDO"}
    filename_ext = ".glb"
    filter_glob: StringProperty(default="*.glb", options={"HIDDEN"})

    def execute(self, context):
        try:
            importer.import_avatar(context, self.filepath)
        except Exception as e:  # the runtime's one-line message names the file
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return {"FINISHED"}


def _menu(self, _context):
    self.layout.operator(IMPORT_SCENE_OT_haha_avatar.bl_idname, text="HAHA avatar (.glb)")


def register():
    bpy.utils.register_class(IMPORT_SCENE_OT_haha_avatar)
    bpy.types.TOPBAR_MT_file_import.append(_menu)
    pose_sync.register()


def unregister():
    pose_sync.unregister()
    bpy.types.TOPBAR_MT_file_import.remove(_menu)
    bpy.utils.unregister_class(IMPORT_SCENE_OT_haha_avatar)
