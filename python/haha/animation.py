"""The glTF animations stored in an avatar's file (haha pack --animation), sampled by the runtime."""
import collections
import ctypes

import numpy as np

from ._library import call
from .errors import ArgumentError

Animation = collections.namedtuple("Animation", "index name duration frames fps")
Animation.__doc__ = """One animation: its index, name, duration (s), frames (at the rate it was packed at), fps."""


def list_animations(handle):
    """[Animation, ...] of the avatar behind `handle`, in file order."""
    n = ctypes.c_int32()
    call("haha_avatar_animation_count", handle, ctypes.byref(n))
    out = []
    for i in range(n.value):
        name = ctypes.create_string_buffer(1024)
        duration, frames, fps = ctypes.c_double(), ctypes.c_int32(), ctypes.c_double()
        call("haha_avatar_animation_info", handle, i, name, len(name), ctypes.byref(duration), ctypes.byref(frames),
             ctypes.byref(fps))
        out.append(Animation(i, name.value.decode("utf-8", "replace"), duration.value, frames.value, fps.value))
    return out


def animation_index(animations, key):
    """The index of animation `key` (a name, or an index into the list)."""
    for a in animations:
        if a.name == key:
            return a.index
    if isinstance(key, (int, np.integer)) and 0 <= int(key) < len(animations):
        return int(key)
    raise ArgumentError("no animation %r (the avatar has %s)" % (
        key, ", ".join("%d %r" % (a.index, a.name) for a in animations) or "none"))


def sample_animation(handle, index, time):
    """(pose float32[165], transl float32[3]) of animation `index` at `time` seconds."""
    pose, transl = np.zeros(165, np.float32), np.zeros(3, np.float32)
    fp = ctypes.POINTER(ctypes.c_float)
    call("haha_avatar_sample_animation", handle, int(index), float(time), pose.ctypes.data_as(fp),
         transl.ctypes.data_as(fp))
    return pose, transl
