"""Pose states (haha_posed) and the posed results they return."""
import ctypes

import numpy as np

from . import _arrays
from ._library import GaussianArrays, Owned, call
from .camera import Camera
from .errors import ArgumentError

_FORMATS = {(False, False): (0, 3, np.uint8), (True, False): (1, 4, np.uint8),
            (False, True): (2, 3, np.float32), (True, True): (3, 4, np.float32)}
_LAYERS = {"both": 0, "gaussians": 1, "mesh": 2}


class Posed:
    """One repose's results, copied out of the library (later reposes do not change them).

    vertices  (V, 3) float32  posed body vertices, world space, metres, in avatar.faces' order
    normals   (V, 3) float32  unit area-weighted vertex normals
    joints    (55, 3) float32 posed joint positions (haha.JOINT_NAMES order)
    means     (G, 3) float32  Gaussian centres;  rotations (G, 4) world quaternions (w, x, y, z)
    scales    (G, 3) float32  world standard deviations (linear, metres)
    colors    (G, 3) float32  RGB in [0, 1];  opacities (G,) float32 in [0, 1]
    gaussians (G, 14) float32 the same side by side: centre, rotation, scale, colour, opacity
    pose (165,), transl (3,)  the parameters it was posed with
    """

    GAUSSIAN_COLUMNS = ("x", "y", "z", "qw", "qx", "qy", "qz", "sx", "sy", "sz", "r", "g", "b", "opacity")

    def __init__(self, handle, info, pose, transl):
        v, g = info.num_vertices, info.num_gaussians
        self.pose, self.transl = pose, transl
        self.vertices = _read(handle, "haha_posed_vertices", (v, 3))
        self.normals = _read(handle, "haha_posed_normals", (v, 3))
        self.joints = _read(handle, "haha_posed_joints", (_arrays.NUM_JOINTS, 3))
        self.gaussians = np.zeros((g, 14), dtype=np.float32)
        cols = [np.zeros((g, n), dtype=np.float32) for n in (3, 4, 3, 3, 1)]
        arrays = GaussianArrays(g, *[_arrays.ptr(c, ctypes.c_float) for c in cols])
        call("haha_posed_gaussians", handle, ctypes.byref(arrays))
        np.concatenate(cols, axis=1, out=self.gaussians)
        self.means, self.rotations, self.scales, self.colors = cols[:4]
        self.opacities = cols[4][:, 0]

    def __repr__(self):
        return "haha.Posed(%d vertices, %d Gaussians)" % (len(self.vertices), len(self.gaussians))


def _read(handle, fn, shape):
    out = np.zeros(shape, dtype=np.float32)
    call(fn, handle, _arrays.ptr(out, ctypes.c_float), out.size)
    return out


class PoseState:
    """One pose state of an avatar (haha_posed) with its render scratch.

    Use one per thread or per character: distinct states repose and render concurrently
    (the library releases the GIL); one state serves one thread at a time.
    """

    def __init__(self, avatar_owned, info):
        self._owned = Owned("haha_posed_free", keep=avatar_owned)  # the avatar outlives the state
        call("haha_posed_create", avatar_owned.ptr, ctypes.byref(self._owned.ptr))
        self._handle = self._owned.ptr
        self._info = info
        self._reposed = False

    def repose(self, pose=None, transl=None, betas=None, expression=None):
        """Poses the avatar and returns a Posed with its arrays.

        pose: SMPL-X axis-angle, 165 values or shape (55, 3) (global orient, 21 body joints,
        jaw, eyes, 15 + 15 finger joints; haha.JOINT_NAMES); None is the rest pose.
        transl: 3 values added to every vertex; None is 0. betas / expression: a packed
        avatar's shape is baked, so the runtime refuses any (ArgumentError); leave them None.
        """
        p = _arrays.pose_values(pose)
        t = _arrays.translation_values(transl)
        b, nb = _arrays.shape_values("betas", betas)
        e, ne = _arrays.shape_values("expression", expression)
        f = ctypes.c_float
        call("haha_repose", self._handle, _arrays.ptr(p, f), _arrays.ptr(t, f), _arrays.ptr(b, f), nb,
             _arrays.ptr(e, f), ne)
        self._reposed = True
        pose_out = np.zeros(_arrays.NUM_POSE_VALUES, np.float32) if p is None else p
        return Posed(self._handle, self._info, pose_out, np.zeros(3, np.float32) if t is None else t)

    def render(self, camera, pose=None, transl=None, background=None, layers="both", alpha=False, float32=False):
        """Renders with the built-in merged renderer (textured mesh + Gaussians, as `haha render`).

        camera: a haha.Camera. pose / transl: repose first (else the last repose is drawn; the rest pose
        when there was none).
        background: RGB in [0, 1] (None: black). layers: "both", "mesh" or "gaussians".
        Returns (H, W, 3) uint8, or (H, W, 4) with alpha=True (coverage), float32 values
        (unclamped) with float32=True.
        """
        if not isinstance(camera, Camera):
            raise ArgumentError("camera: expected a haha.Camera, got %s" % type(camera).__name__)
        if layers not in _LAYERS:
            raise ArgumentError("layers: expected 'both', 'mesh' or 'gaussians', got %r" % (layers,))
        if pose is not None or transl is not None or not self._reposed:
            self.repose(pose, transl)
        bg = None if background is None else _arrays.float_values("background", background, [(3,)], "3 values")
        fmt, channels, dtype = _FORMATS[(bool(alpha), bool(float32))]
        image = np.zeros((camera.height, camera.width, channels), dtype=dtype)
        call("haha_render", self._handle, ctypes.byref(camera._c()), _arrays.ptr(bg, ctypes.c_float),
             _LAYERS[layers], fmt, image.ctypes.data_as(ctypes.c_void_p), image.nbytes)
        return image
