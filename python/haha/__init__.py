"""haha: load, repose and render HAHA avatars (.glb) from Python.

A thin ctypes binding of libhaha_runtime.so's C API (runtime/include/haha/haha_runtime.h):
no compiled extension, so any CPython 3 with numpy loads it (Blender's too).

    import haha
    avatar = haha.Avatar("avatar.glb")               # haha.FileError / haha.FormatError
    pose = np.zeros((55, 3)); pose[haha.joint_index("left_shoulder"), 2] = -1.0
    posed = avatar.repose(pose, transl=[0, 0, 0])
    posed.vertices      # (V, 3) float32, indexed by avatar.faces (F, 3)
    posed.gaussians     # (G, 14): centre, rotation (w, x, y, z), scale, colour, opacity
    camera = haha.framing_camera(posed.vertices, 512)
    image = avatar.render(camera, background=(1, 1, 1))   # (512, 512, 3) uint8
    haha.write_png("posed.png", image)

Conventions: SMPL-X rest frame, metres, Y up, body facing +Z; poses are 55 joints x
axis-angle (haha.JOINT_NAMES); OpenCV pinhole cameras (haha.Camera). The library is found
through HAHA_RUNTIME_LIBRARY, next to the package, or on the loader's path (haha._library).
"""
from ._library import library_path, lib
from .animation import Animation
from .avatar import Avatar
from .camera import Camera, framing_camera
from .errors import (ArgumentError, FileError, FormatError, HahaError, InternalError, LibraryNotFoundError,
                     OutOfMemoryError, StateError)
from .images import write_png
from .joints import JOINT_NAMES, joint_index
from .motion import Motion
from .pose_state import PoseState, Posed

NUM_JOINTS = 55
NUM_POSE_VALUES = 165
MESH_COVERAGE_CUTOFF = 0.5  # HAHA_MESH_COVERAGE_CUTOFF: the mesh draws where coverage >= this

__all__ = ["Animation", "Avatar", "Camera", "Motion", "PoseState", "Posed", "framing_camera", "write_png", "JOINT_NAMES",
           "joint_index", "NUM_JOINTS", "NUM_POSE_VALUES", "MESH_COVERAGE_CUTOFF", "runtime_version", "set_num_threads", "library_path",
           "HahaError", "ArgumentError", "FileError", "FormatError", "StateError", "OutOfMemoryError",
           "InternalError", "LibraryNotFoundError"]


def runtime_version():
    """The loaded library's version string ("0.1.0")."""
    return lib().haha_version_string().decode()


def set_num_threads(n):
    """OpenMP threads for repose and render started from the calling thread (n >= 1)."""
    from ._library import call
    call("haha_set_num_threads", int(n))
