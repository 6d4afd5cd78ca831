"""haha.Motion: a motion .npz (AMASS SMPL-X / SMPL+H, or haha's parameter files)."""
import ctypes
import os

import numpy as np

from ._library import Owned, call
from .errors import ArgumentError


class Motion:
    """A sequence of SMPL-X poses read by the runtime (haha_motion_load).

    Motion(path, avatar=None): with an avatar, an AMASS (Z-up) motion is turned upright
    about the avatar's rest pelvis, as `haha render` does. len(motion) frames at motion.fps;
    motion[i] is (pose (165,), transl (3,)); motion.poses (T, 165), motion.translations (T, 3).
    """

    def __init__(self, path, avatar=None):
        if not isinstance(path, (str, bytes, os.PathLike)):
            raise ArgumentError("path: expected a path, got %s" % type(path).__name__)
        self._owned = Owned("haha_motion_free")
        if avatar is None:
            call("haha_motion_load", os.fsencode(path), ctypes.byref(self._owned.ptr))
        else:
            call("haha_motion_load_for_avatar", os.fsencode(path), avatar._handle, ctypes.byref(self._owned.ptr))
        self._handle = self._owned.ptr
        self.path = os.fspath(path)
        n, fps = ctypes.c_int32(), ctypes.c_double()
        call("haha_motion_info", self._handle, ctypes.byref(n), ctypes.byref(fps))
        self.num_frames, self.fps = n.value, fps.value

    def __len__(self):
        return self.num_frames

    def __repr__(self):
        return "haha.Motion(%r: %d frames at %g fps)" % (self.path, self.num_frames, self.fps)

    def __getitem__(self, frame):
        """(pose float32[165], transl float32[3]) of one frame (negative indices count from the end)."""
        f = int(frame)
        if f < 0:
            f += self.num_frames
        if not 0 <= f < self.num_frames:
            raise IndexError("frame %d out of range: the motion has %d frames" % (int(frame), self.num_frames))
        pose, transl = np.zeros(165, np.float32), np.zeros(3, np.float32)
        fp = ctypes.POINTER(ctypes.c_float)
        call("haha_motion_frame", self._handle, f, pose.ctypes.data_as(fp), transl.ctypes.data_as(fp))
        return pose, transl

    def __iter__(self):
        for f in range(self.num_frames):
            yield self[f]

    @property
    def poses(self):
        """(T, 165) float32 axis-angle poses."""
        return np.stack([p for p, _ in self]) if self.num_frames else np.zeros((0, 165), np.float32)

    @property
    def translations(self):
        """(T, 3) float32 translations."""
        return np.stack([t for _, t in self]) if self.num_frames else np.zeros((0, 3), np.float32)
