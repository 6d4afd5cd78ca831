"""Blender add-on: File > Import > HAHA avatar (.glb).

Imports a haha avatar (any pack: Draco files too, decoded by libhaha_runtime.so through the
Python package `haha`, not by Blender's glTF importer) as
  - an armature of the file's 55 SMPL-X joints (heads at the rest joints, no roll),
  - the textured body (unlit material: the texture as `haha render` shows it),
  - the textured body, skinned by an Armature modifier with the file's joint weights,
  - the Gaussians: a point per Gaussian bound to its body face, posed by geometry nodes on
    the deformed body's face frames and drawn as camera-facing splats (EEVEE and Cycles).
Posing, actions, drivers and export work as for any rigged character; no Python runs after
the import. The body has no pose correctives (plain linear blend skinning).
Operator: bpy.ops.import_scene.haha_avatar(filepath=..., max_gaussians=0); max_gaussians > 0
imports only the importance tiers within that count of a file packed with haha pack --lod.
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
    for _m in (node_util, camera, glb_skeleton, plain_skin, face_binding, gaussian_nodes, shading, scene_build,
               posing, importer, runtime_link):  # noqa: F821
        importlib.reload(_m)

import bpy
from bpy.props import IntProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from . import (camera, face_binding, gaussian_nodes, glb_skeleton, importer, node_util, plain_skin,  # noqa: F401
               posing, runtime_link, scene_build, shading)


class IMPORT_SCENE_OT_haha_avatar(bpy.types.Operator, ImportHelper):
    """Import a HAHA avatar (.glb): body, armature and Gaussians that follow it"""

    bl_idname = "import_scene.haha_avatar"
    bl_label = "Import HAHA avatar"
    bl_options = {"REGISTER", "UNDO"}
    filename_ext = ".glb"
    filter_glob: StringProperty(default="*.glb", options={"HIDDEN"})
    max_gaussians: IntProperty(
        name="Max Gaussians", default=0, min=0,
        description="Files packed with importance tiers (haha pack --lod): import only the tiers within this "
                    "count, the first always (0 = all)")

    def execute(self, context):
        try:
            importer.import_avatar(context, self.filepath, self.max_gaussians)
        except Exception as e:  # the runtime's one-line message names the file
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return {"FINISHED"}


def _menu(self, _context):
    self.layout.operator(IMPORT_SCENE_OT_haha_avatar.bl_idname, text="HAHA avatar (.glb)")


def register():
    bpy.utils.register_class(IMPORT_SCENE_OT_haha_avatar)
    bpy.types.TOPBAR_MT_file_import.append(_menu)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_menu)
    bpy.utils.unregister_class(IMPORT_SCENE_OT_haha_avatar)
