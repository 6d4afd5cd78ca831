"""haha.Avatar: a loaded .glb avatar (haha_avatar) with its default pose state."""
import ctypes
import os

import numpy as np

from ._library import AvatarInfo, Owned, call
from .animation import animation_index, list_animations, sample_animation
from .errors import ArgumentError
from .pose_state import PoseState


def _path_bytes(name, path):
    if path is None:
        return None
    if not isinstance(path, (str, bytes, os.PathLike)):
        raise ArgumentError("%s: expected a path, got %s" % (name, type(path).__name__))
    return os.fsencode(path)


class Avatar:
    """A packed HAHA avatar (.glb), loaded and validated by libhaha_runtime.so.

    Avatar(path, body_model=None, max_gaussians=None)
      path: the .glb file. body_model: the SMPL-X .npz the avatar was trained with, for pose
      correctives a file does not embed (ignored when it does). max_gaussians: for files
      packed with importance tiers (haha pack --lod), load only the tiers within that count.
    Raises haha.FileError (cannot open / read) or haha.FormatError (invalid contents) with the
    library's one-line message naming the file.

    The avatar is immutable; repose() and render() use its default PoseState (one thread at
    a time): make more with pose_state() to pose it in parallel threads.
    """

    def __init__(self, path, body_model=None, max_gaussians=None):
        p, m = _path_bytes("path", path), _path_bytes("body_model", body_model)
        if p is None:
            raise ArgumentError("path: expected a path, got None")
        self._owned = Owned("haha_avatar_free")
        if max_gaussians is None:
            call("haha_avatar_load", p, m, ctypes.byref(self._owned.ptr))
        else:
            call("haha_avatar_load_lod", p, m, int(max_gaussians), ctypes.byref(self._owned.ptr))
        self.path = os.fspath(path)
        self._setup()

    @classmethod
    def from_bytes(cls, data, name=None, body_model=None):
        """An avatar from the file's bytes in memory; `name` names it in error messages."""
        self = cls.__new__(cls)
        self._owned = Owned("haha_avatar_free")
        buf = bytes(data)
        call("haha_avatar_load_memory", buf, len(buf), None if name is None else str(name).encode(),
             _path_bytes("body_model", body_model), ctypes.byref(self._owned.ptr))
        self.path = name
        self._setup()
        return self

    def _setup(self):
        self._handle = self._owned.ptr
        self._info = AvatarInfo()
        call("haha_avatar_get_info", self._handle, ctypes.byref(self._info))
        self._state = PoseState(self._owned, self._info)

    def __repr__(self):
        i = self._info
        return "haha.Avatar(%r: %d vertices, %d faces, %d Gaussians, texture %d x %d)" % (
            self.path, i.num_vertices, i.num_faces, i.num_gaussians, i.texture_width, i.texture_height)

    num_vertices = property(lambda self: self._info.num_vertices, doc="V: body vertices")
    num_faces = property(lambda self: self._info.num_faces, doc="F: triangles")
    num_gaussians = property(lambda self: self._info.num_gaussians, doc="G: Gaussians")
    num_joints = property(lambda self: self._info.num_joints, doc="skin joints (55, haha.JOINT_NAMES)")
    texture_size = property(lambda self: (self._info.texture_width, self._info.texture_height),
                            doc="(width, height) of the texture; (0, 0) without one")
    has_pose_correctives = property(lambda self: bool(self._info.has_pose_correctives),
                                    doc="reposes apply pose-corrective blend shapes")
    missing_pose_correctives = property(lambda self: bool(self._info.missing_pose_correctives),
                                        doc="trained with pose correctives the runtime lacks: pass body_model")

    @property
    def faces(self):
        """(F, 3) uint32 vertex indices, counter-clockwise seen from outside (SMPL-X winding)."""
        out = np.zeros((self.num_faces, 3), dtype=np.uint32)
        call("haha_avatar_faces", self._handle, out.ctypes.data_as(ctypes.POINTER(ctypes.c_uint32)), out.size)
        return out

    @property
    def face_uvs(self):
        """(F, 3, 2) float32 texture coordinates per face corner; v = 1 is the texture's top row."""
        out = np.zeros((self.num_faces, 3, 2), dtype=np.float32)
        call("haha_avatar_face_uvs", self._handle, out.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), out.size)
        return out

    @property
    def mesh_coverage(self):
        """(V,) float32 coverage per body vertex, or None when the file has none (the whole mesh
        draws). The mesh draws where the interpolation of a face's three values is >=
        haha.MESH_COVERAGE_CUTOFF: discard the rest (and keep it out of the depth pass)."""
        out = np.zeros(self.num_vertices, dtype=np.float32)
        has = ctypes.c_int32(0)
        call("haha_avatar_mesh_coverage", self._handle, out.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), out.size,
             ctypes.byref(has))
        return out if has.value else None

    @property
    def texture(self):
        """(H, W, 3) uint8 texture, top row first, display-encoded as stored; None without one."""
        w, h = self.texture_size
        if w == 0 or h == 0:
            return None
        out = np.zeros((h, w, 3), dtype=np.uint8)
        call("haha_avatar_texture", self._handle, out.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8)), out.size)
        return out

    @property
    def animations(self):
        """[haha.Animation(index, name, duration, frames, fps), ...]: the file's glTF animations."""
        return list_animations(self._handle)

    def sample_animation(self, animation, time):
        """(pose float32[165], transl float32[3]) of an animation (name or index) at `time` seconds,
        interpolated as glTF viewers play it; pass them to repose() or render()."""
        return sample_animation(self._handle, animation_index(self.animations, animation), time)

    def pose_state(self):
        """A new PoseState of this avatar (its own repose / render scratch, for another thread)."""
        return PoseState(self._owned, self._info)

    def repose(self, pose=None, transl=None, betas=None, expression=None):
        """Poses the avatar; returns a haha.Posed (.vertices (V, 3), .gaussians (G, 14), ...).

        pose: SMPL-X axis-angle, 165 values or (55, 3); transl: 3 values. See PoseState.repose.
        """
        return self._state.repose(pose, transl, betas, expression)

    def render(self, camera, pose=None, transl=None, background=None, layers="both", alpha=False, float32=False):
        """Renders (H, W, 3) uint8 with the built-in merged renderer; see PoseState.render."""
        return self._state.render(camera, pose, transl, background, layers, alpha, float32)
