"""OpenCV pinhole cameras for Avatar.render (haha_camera of the C API).

x_cam = rotation @ x_world + translation; pixel = (fx x / z + cx, fy y / z + cy), x right,
y down, z forward, pixel centres at +0.5 (a centred principal point is cx = width / 2).
"""
import json

import numpy as np

from ._arrays import float_values
from ._library import CCamera
from .errors import ArgumentError, FileError, FormatError


class Camera:
    """A pinhole camera: size in pixels, intrinsics in pixels, world-to-camera extrinsics.

    near / far: clip distances along z (0 selects the runtime's 0.01 / 100).
    """

    def __init__(self, width, height, fx, fy, cx, cy, rotation=None, translation=None, near=0.0, far=0.0):
        self.width, self.height = int(width), int(height)
        if not (1 <= self.width <= 16384 and 1 <= self.height <= 16384):
            raise ArgumentError("camera: width and height must be in 1..16384, got %d x %d" % (self.width, self.height))
        self.fx, self.fy, self.cx, self.cy = (float(v) for v in (fx, fy, cx, cy))
        self.rotation = float_values("camera rotation", np.eye(3) if rotation is None else rotation,
                                     [(3, 3), (9,)], "a 3 x 3 matrix").reshape(3, 3)
        self.translation = float_values("camera translation", np.zeros(3) if translation is None else translation,
                                        [(3,)], "3 values")
        self.near, self.far = float(near), float(far)

    def __repr__(self):
        return "haha.Camera(%d x %d, fx=%g, fy=%g, cx=%g, cy=%g)" % (
            self.width, self.height, self.fx, self.fy, self.cx, self.cy)

    @classmethod
    def from_json(cls, path):
        """A camera from haha's cam.json ({"width", "height", "K", "world_to_camera"[, "near", "far"]})."""
        try:
            with open(path, "r", encoding="utf-8") as f:
                d = json.load(f)
        except OSError as e:
            raise FileError("%s: cannot read: %s" % (path, e.strerror)) from None
        except ValueError as e:
            raise FormatError("%s: not JSON: %s" % (path, e)) from None
        try:
            k = np.asarray(d["K"], dtype=np.float64)
            m = np.asarray(d["world_to_camera"], dtype=np.float64)
            return cls(d["width"], d["height"], k[0, 0], k[1, 1], k[0, 2], k[1, 2], m[:3, :3], m[:3, 3],
                       d.get("near", 0.0), d.get("far", 0.0))
        except (KeyError, IndexError, TypeError, ValueError) as e:
            raise FormatError("%s: not a camera (width, height, K 3x3, world_to_camera 4x4): %s" % (path, e)) from None

    def to_dict(self):
        """The cam.json dictionary of this camera (json.dump it for `haha render --camera`)."""
        m = np.eye(4)
        m[:3, :3] = self.rotation
        m[:3, 3] = self.translation
        d = {"width": self.width, "height": self.height,
             "K": [[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]],
             "world_to_camera": m.tolist()}
        if self.near > 0:
            d["near"] = self.near
        if self.far > 0:
            d["far"] = self.far
        return d

    def _c(self):
        c = CCamera()
        c.width, c.height = self.width, self.height
        c.fx, c.fy, c.cx, c.cy = self.fx, self.fy, self.cx, self.cy
        c.rotation[:] = [float(v) for v in self.rotation.reshape(-1)]
        c.translation[:] = [float(v) for v in self.translation]
        c.near_plane, c.far_plane = self.near, self.far
        return c


def framing_camera(vertices, size):
    """The front camera of samples/c and `haha render`: looking along world -Z at the box of
    `vertices` (V, 3) with a 15% margin, size x size pixels, fx = fy = 1.5 size.

    Computed in float32 in the C sample's order of operations, so it is the sample's camera
    bit for bit.
    """
    f32 = np.float32
    v = np.asarray(vertices, dtype=np.float32).reshape(-1, 3)
    lo, hi = v.min(axis=0), v.max(axis=0)
    size = int(size)
    fx = f32(1.5) * f32(size)
    cxy = f32(0.5) * f32(size)
    centre = [f32(0.5) * (lo[k] + hi[k]) for k in range(3)]
    w, h = hi[0] - lo[0], hi[1] - lo[1]
    half = f32(0.5) * f32(1.15) * (w if w > h else h)
    dist = half * fx / (f32(0.5) * f32(size)) + f32(0.5) * (hi[2] - lo[2])
    eye_z = centre[2] + dist
    return Camera(size, size, fx, fx, cxy, cxy, np.diag([1.0, -1.0, -1.0]), [-centre[0], centre[1], eye_z],
                  f32(0.01), f32(4.0) * dist + f32(10.0))
