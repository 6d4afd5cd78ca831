"""CTest `blender_addon_zip`, run by tests/python/blender_zip_test.sh in a headless Blender
with a fresh user profile and no HAHA_* variable: installs the zip of
scripts/blender-addon-zip.sh with bpy.ops.preferences.addon_install, enables it and imports
the avatar (armature, skinned body, Gaussians). Exit 0 pass, 1 fail.
  blender -b --factory-startup --python blender_zip_test.py -- ZIP AVATAR.glb"""
import os
import sys

import addon_utils
import bpy

zip_path, avatar = sys.argv[sys.argv.index("--") + 1:]
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


check(not [k for k in os.environ if k.startswith("HAHA_")], "no HAHA_* variable set")
check("haha" not in sys.modules, "no `haha` package importable before the install")
bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
addon_utils.enable("io_import_haha_avatar", default_set=True)
bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("io_import_haha_avatar", default_set=True)
result = bpy.ops.import_scene.haha_avatar(filepath=avatar)
check(result == {"FINISHED"}, "import from the installed zip: %s" % result)
arms = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
check(len(arms) == 1 and "haha_gaussians" in arms[0].data and "haha_body" in arms[0].data,
      "armature, body and Gaussians imported")
import haha  # noqa: E402
check(os.path.dirname(haha.__file__).startswith(bpy.utils.user_resource("SCRIPTS")),
      "the package used is the zip's (%s)" % os.path.dirname(haha.__file__))
print("PASS" if not failures else "FAILED: %d check(s)" % len(failures), flush=True)
sys.exit(1 if failures else 0)
