"""Keeps an imported avatar's body and Gaussians on its armature's pose.

The armature's bones give the SMPL-X pose (each bone's rotation in the avatar frame, the
root bone's location as the translation); the runtime reposes the avatar exactly as
`haha render` does (LBS with the file's pose correctives, then every Gaussian on its posed
triangle's frame) and the posed vertices and Gaussians are written into the two meshes.
Handlers run it when the pose changes (posing in the viewport, drivers) and on every frame
change (playing an action, rendering an animation).
"""
import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import runtime_link

_live = {}  # armature data name -> {"avatar", "state", "key"}
_busy = False


def _quat_from_matrix(m):
    """Unit quaternion (w, x, y, z) of a rotation matrix (float64, Shepperd's method).
    Not mathutils' to_quaternion(): that one is single precision, and the pose it gives
    feeds the runtime's reposing, which the tests hold to 0.1 mm."""
    t = np.trace(m)
    cands = [t, m[0, 0], m[1, 1], m[2, 2]]
    i = int(np.argmax(cands))
    if i == 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = (0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s)
    elif i == 1:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = ((m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s)
    elif i == 2:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s)
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s)
    q = np.array(q)
    return q / np.linalg.norm(q)


def axis_angle(m):
    """The axis-angle vector of a rotation matrix."""
    q = _quat_from_matrix(m)
    if q[0] < 0:
        q = -q
    v = q[1:]
    n = np.linalg.norm(v)
    return np.zeros(3) if n < 1e-12 else v * (2.0 * np.arctan2(n, q[0]) / n)


def armature_pose(arm):
    """(pose (55, 3), transl (3,)) of an armature object (evaluated or not) in SMPL-X terms:
    bone j's rotation about its head in the avatar frame, B R_basis B^T (B: its rest axes)."""
    names = list(arm.data["haha_joint_names"])
    pose = np.zeros((len(names), 3))
    transl = np.zeros(3)
    for j, name in enumerate(names):
        pb = arm.pose.bones[name]
        b = np.array(pb.bone.matrix_local.to_3x3(), dtype=np.float64)
        basis = pb.matrix_basis
        r = np.array(basis.to_quaternion().normalized().to_matrix(), dtype=np.float64)
        pose[j] = axis_angle(b @ r @ b.T)
        if j == 0:
            transl = b @ np.array(basis.translation, dtype=np.float64)
    return pose, transl


def srgb_to_linear(c):
    c = np.clip(np.asarray(c, np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def quat_to_euler_xyz(q):
    """(G, 4) (w, x, y, z) -> (G, 3) Euler XYZ (Blender's: R = Rz Ry Rx)."""
    w, x, y, z = (q[:, i].astype(np.float64) for i in range(4))
    r20 = 2 * (x * z - w * y)
    r21, r22 = 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    r10, r00 = 2 * (x * y + w * z), 1 - 2 * (y * y + z * z)
    return np.stack([np.arctan2(r21, r22), np.arcsin(np.clip(-r20, -1, 1)), np.arctan2(r10, r00)], 1)


def live_avatar(arm):
    """The loaded runtime avatar of an imported armature (loaded once per session)."""
    key = arm.data.name
    entry = _live.get(key)
    if entry is None or entry["path"] != arm.data["haha_avatar_path"]:
        haha = runtime_link.import_haha()
        path = bpy.path.abspath(arm.data["haha_avatar_path"])
        avatar = haha.Avatar(path)
        entry = {"avatar": avatar, "state": avatar.pose_state(), "key": None, "path": arm.data["haha_avatar_path"]}
        _live[key] = entry
    return entry


def quat_to_matrix(q):
    """(G, 4) (w, x, y, z) -> (G, 3, 3) rotation matrices."""
    w, x, y, z = (q[:, i].astype(np.float64) for i in range(4))
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], 1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], 1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1)], 1)


def write_gaussians(obj, posed, colors=True):
    """Centres, rotations (Euler XYZ), scales and the material's inverse frames (rows of
    (R diag(k s))^-1, k the drawn ellipsoid's deviations) of the posed Gaussians."""
    from .scene_build import SPHERE_SIGMAS
    me = obj.data
    me.vertices.foreach_set("co", posed.means.reshape(-1))
    me.attributes["haha_rotation"].data.foreach_set("vector", quat_to_euler_xyz(posed.rotations).reshape(-1))
    me.attributes["haha_scale"].data.foreach_set("vector", posed.scales.reshape(-1))
    inv = np.swapaxes(quat_to_matrix(posed.rotations), 1, 2)  # R^T
    inv /= SPHERE_SIGMAS * np.maximum(posed.scales.astype(np.float64), 1e-12)[:, :, None]
    for i in range(3):
        me.attributes["haha_inv%d" % i].data.foreach_set("vector", np.ascontiguousarray(inv[:, i, :]).reshape(-1))
    if colors:
        rgba = np.ones((len(posed.colors), 4))
        rgba[:, :3] = srgb_to_linear(posed.colors)
        me.attributes["haha_color"].data.foreach_set("color", rgba.reshape(-1))
        me.attributes["haha_opacity"].data.foreach_set("value", posed.opacities)
    me.update()


def sync(arm, source=None, force=False):
    """Reposes the avatar of armature `arm` from the pose of `source` (its evaluated copy,
    default: itself) and writes body and Gaussians; nothing when the pose did not change."""
    pose, transl = armature_pose(source or arm)
    entry = live_avatar(arm)
    key = (pose.astype(np.float32).tobytes(), transl.astype(np.float32).tobytes())
    if not force and key == entry["key"]:
        return None
    posed = entry["state"].repose(pose.astype(np.float32), transl.astype(np.float32))
    body, gaussians = arm.data.get("haha_body"), arm.data.get("haha_gaussians")
    if body is not None:
        body.data.vertices.foreach_set("co", posed.vertices.reshape(-1))
        body.data.update()
    if gaussians is not None:
        write_gaussians(gaussians, posed, colors=entry["key"] is None or force)
    entry["key"] = key
    return posed


def _avatar_armatures(scene):
    return [o for o in scene.objects if o.type == "ARMATURE" and "haha_avatar_path" in o.data]


def _sync_scene(scene, depsgraph):
    global _busy
    if _busy:
        return
    _busy = True
    try:
        for arm in _avatar_armatures(scene):
            try:
                sync(arm, arm.evaluated_get(depsgraph) if depsgraph is not None else None)
            except Exception as e:  # a handler must not raise into Blender; say it once per pose
                print("HAHA avatar %s: %s" % (arm.name, e))
    finally:
        _busy = False


@persistent
def on_depsgraph_update(scene, depsgraph=None):
    _sync_scene(scene, depsgraph)


@persistent
def on_frame_change(scene, depsgraph=None):
    _sync_scene(scene, depsgraph)


@persistent
def on_load(*_args):
    _live.clear()


def register():
    for lst, fn in ((bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
                    (bpy.app.handlers.frame_change_post, on_frame_change), (bpy.app.handlers.load_post, on_load)):
        if fn not in lst:
            lst.append(fn)


def unregister():
    for lst, fn in ((bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
                    (bpy.app.handlers.frame_change_post, on_frame_change), (bpy.app.handlers.load_post, on_load)):
        if fn in lst:
            lst.remove(fn)
    _live.clear()
