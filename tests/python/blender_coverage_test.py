"""CTest `blender_coverage`, run by tests/python/blender_coverage_test.sh in headless Blender:

  blender -b --factory-startup --python blender_coverage_test.py -- --addons DIR --cut C.glb --whole W.glb --work W

C.glb and W.glb: the same avatar with and without a mesh coverage (python_avatar_fixture's
coverage.glb, vertex v at 0, 1, 0.3 for v % 3 = 0, 1, 2, and animated.glb). The add-on's body
carries the coverage as the point attribute haha_coverage (the runtime's values) and its
material clips by it; a Cycles render of the body alone shows fewer pixels of the cut body,
none outside the whole body's. Exit 0 pass, 1 fail.
"""
import argparse
import os
import sys

import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
for a in ("--addons", "--cut", "--whole", "--work"):
    ap.add_argument(a, required=True)
args = ap.parse_args(argv)
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


sys.path.insert(0, args.addons)
import io_import_haha_avatar as addon  # noqa: E402

addon.register()
haha = addon.runtime_link.import_haha()


def body_mask(path, tag):
    """Imports `path` into an empty scene; returns (body object, lit mask of a Cycles render of
    the body alone from the front)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    result = bpy.ops.import_scene.haha_avatar(filepath=path)
    check(result == {"FINISHED"}, "%s: import %s" % (tag, result))
    scene = bpy.context.scene
    arm = [o for o in scene.objects if o.type == "ARMATURE"][0]
    body, gaussians = arm.data["haha_body"], arm.data["haha_gaussians"]
    gaussians.hide_render = True
    if arm.animation_data:  # the whole file carries an animation: both at the rest pose
        arm.animation_data.action = None
    for pb in arm.pose.bones:
        pb.matrix_basis.identity()
    bpy.context.view_layer.update()
    evaluated = body.evaluated_get(bpy.context.evaluated_depsgraph_get())
    co = np.array([evaluated.matrix_world @ v.co for v in evaluated.to_mesh().vertices])
    lo, hi = co.min(0), co.max(0)
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    place_front(cam, lo, hi)
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 4
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    scene.render.film_transparent = True
    scene.render.resolution_x = scene.render.resolution_y = 96
    scene.render.filepath = os.path.join(args.work, tag + ".png")
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(scene.render.filepath)
    alpha = np.array(img.pixels[:]).reshape(-1, 4)[:, 3]
    return body, alpha > 0.5


def place_front(cam, lo, hi):
    """An orthographic camera in front of the body (glTF +Z is Blender's -Y) covering it."""
    centre = (lo + hi) / 2
    cam.data.ortho_scale = float(max(hi[0] - lo[0], hi[2] - lo[2])) * 1.1
    cam.location = (centre[0], lo[1] - 3.0, centre[2])
    cam.rotation_euler = (np.pi / 2, 0.0, 0.0)  # looking along +Y
    cam.data.clip_end = 100.0


os.makedirs(args.work, exist_ok=True)
body, cut = body_mask(args.cut, "cut")
avatar = haha.Avatar(args.cut)
want = avatar.mesh_coverage
attr = body.data.attributes.get(addon.shading.COVERAGE_ATTRIBUTE)
got = np.zeros(len(body.data.vertices), np.float32)
if attr is not None:
    attr.data.foreach_get("value", got)
check(attr is not None and want is not None and np.array_equal(got, want),
      "the body's haha_coverage is the runtime's mesh coverage (%d values)" % len(got))
mat = body.data.materials[0]
check(mat.blend_method == "CLIP" and mat.shadow_method == "CLIP", "the body material clips (%s)" % mat.blend_method)
whole_body, whole = body_mask(args.whole, "whole")
check(whole_body.data.attributes.get(addon.shading.COVERAGE_ATTRIBUTE) is None and
      whole_body.data.materials[0].blend_method != "CLIP", "a file without a coverage: no attribute, an opaque material")
outside = int(np.count_nonzero(cut & ~whole))
check(0 < cut.sum() < 0.9 * whole.sum() and outside <= 0.01 * cut.sum(),
      "Cycles, the body alone: %d px cut / %d px whole (%d outside)" % (cut.sum(), whole.sum(), outside))
print("PASS" if not failures else "FAILED: %d check(s)" % len(failures), flush=True)
sys.exit(1 if failures else 0)
