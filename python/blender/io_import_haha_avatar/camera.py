"""Blender cameras and render settings that match `haha render` (OpenCV pinholes, unlit)."""
import bpy
import numpy as np
from mathutils import Matrix


def add_opencv_camera(name, cam, avatar_root, collection):
    """A Blender camera equal to an OpenCV pinhole of haha's cam.json dictionary (world =
    the avatar frame of `avatar_root`, the imported armature). Square pixels (fx == fy)."""
    w, h = int(cam["width"]), int(cam["height"])
    k = np.asarray(cam["K"], np.float64)
    m = np.asarray(cam["world_to_camera"], np.float64)
    r, t = m[:3, :3], m[:3, 3]
    data = bpy.data.cameras.new(name)
    data.sensor_fit = "HORIZONTAL" if w >= h else "VERTICAL"
    data.sensor_width = data.sensor_height = 36.0
    data.lens = k[0, 0] * 36.0 / max(w, h)
    data.shift_x = -(k[0, 2] - 0.5 * w) / max(w, h)
    data.shift_y = (k[1, 2] - 0.5 * h) / max(w, h)
    data.clip_start = cam.get("near", 0.01)
    data.clip_end = cam.get("far", 100.0)
    pose = np.eye(4)
    pose[:3, :3] = r.T @ np.diag([1.0, -1.0, -1.0])  # OpenCV (y down, z forward) -> Blender camera axes
    pose[:3, 3] = -r.T @ t
    obj = bpy.data.objects.new(name, data)
    collection.objects.link(obj)
    obj.matrix_world = avatar_root.matrix_world @ Matrix(pose.tolist())
    return obj


def use_camera(gaussians, cam_obj, scene):
    """Points the splats of `gaussians` (an imported Gaussian object) at camera `cam_obj` and
    gives them its pixel size (1 / focal length in pixels at the scene's resolution, for haha
    render's 0.3 px^2 low-pass). Call again after changing the camera's lens or resolution."""
    from .scene_build import set_input
    data = cam_obj.data
    res = scene.render.resolution_percentage / 100.0
    w, h = scene.render.resolution_x * res, scene.render.resolution_y * res
    fit = data.sensor_fit if data.sensor_fit != "AUTO" else ("HORIZONTAL" if w >= h else "VERTICAL")
    sensor = data.sensor_width if (fit == "HORIZONTAL" or data.sensor_fit == "AUTO") else data.sensor_height
    pixels = w if fit == "HORIZONTAL" else h
    mod = gaussians.modifiers["HAHA Gaussians"]
    set_input(mod, "Camera", cam_obj)
    set_input(mod, "Pixel Size", float(sensor / (data.lens * pixels)) if data.type == "PERSP" else 0.0)
    gaussians.update_tag()


def match_haha_render(scene, width, height, background=(1.0, 1.0, 1.0), samples=256):
    """Cycles settings for a render comparable to `haha render`: view transform Raw (display
    values in and out), a background of the given display colour, a pixel filter of a point
    (haha render samples each pixel at its centre), no dither, enough transparent bounces for
    stacked splats."""
    scene.render.engine = "CYCLES"
    scene.render.resolution_x, scene.render.resolution_y = int(width), int(height)
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.render.dither_intensity = 0.0
    scene.view_settings.view_transform = "Raw"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 0
    scene.cycles.transparent_max_bounces = 1024
    if scene.world is None:
        scene.world = bpy.data.worlds.new("HAHA background")
    scene.world.use_nodes = True
    bg = scene.world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (*background, 1.0)  # display values (Raw)
    bg.inputs["Strength"].default_value = 1.0
