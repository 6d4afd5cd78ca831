"""Finding, loading and declaring libhaha_runtime.so (ctypes; no compiled extension).

The library is looked up, in this order:
  1. the file named by the environment variable HAHA_RUNTIME_LIBRARY (nothing else is tried);
  2. next to the package: its own folder, then the folders above it up to two levels (the
     install layout: P/lib/python/haha/ beside P/lib/libhaha_runtime.so);
  3. the dynamic loader's search path (LD_LIBRARY_PATH, ldconfig's cache).
The first library found is loaded once, on the first call that needs it.
"""
import ctypes
import ctypes.util
import os
import threading

from .errors import STATUS_ERRORS, InternalError, LibraryNotFoundError

# The C API this package is written against (haha_runtime.h): same major.minor required.
API_MAJOR, API_MINOR = 0, 1
SONAME = "libhaha_runtime.so.%d.%d" % (API_MAJOR, API_MINOR)
NAMES = (SONAME, "libhaha_runtime.so")

_lock = threading.Lock()
_lib = None

c_float_p = ctypes.POINTER(ctypes.c_float)
c_uint32_p = ctypes.POINTER(ctypes.c_uint32)
c_uint8_p = ctypes.POINTER(ctypes.c_uint8)
c_int32_p = ctypes.POINTER(ctypes.c_int32)


class AvatarInfo(ctypes.Structure):
    _fields_ = [(name, ctypes.c_int32) for name in (
        "num_vertices", "num_faces", "num_gaussians", "num_joints", "texture_width", "texture_height",
        "has_pose_correctives", "missing_pose_correctives")]


class GaussianArrays(ctypes.Structure):
    _fields_ = [("capacity", ctypes.c_size_t), ("means", c_float_p), ("rotations", c_float_p),
                ("scales", c_float_p), ("colors", c_float_p), ("opacities", c_float_p)]


class CCamera(ctypes.Structure):
    _fields_ = [("width", ctypes.c_int32), ("height", ctypes.c_int32), ("fx", ctypes.c_float),
                ("fy", ctypes.c_float), ("cx", ctypes.c_float), ("cy", ctypes.c_float),
                ("rotation", ctypes.c_float * 9), ("translation", ctypes.c_float * 3),
                ("near_plane", ctypes.c_float), ("far_plane", ctypes.c_float)]


_vp = ctypes.c_void_p
_st = ctypes.c_int
_sz = ctypes.c_size_t
# name: (restype, argtypes). Opaque objects travel as void pointers.
_PROTOTYPES = {
    "haha_version": (_st, [c_int32_p, c_int32_p, c_int32_p]),
    "haha_version_string": (ctypes.c_char_p, []),
    "haha_last_error": (ctypes.c_char_p, []),
    "haha_status_string": (ctypes.c_char_p, [_st]),
    "haha_set_num_threads": (_st, [ctypes.c_int]),
    "haha_avatar_load": (_st, [ctypes.c_char_p, ctypes.c_char_p, ctypes.POINTER(_vp)]),
    "haha_avatar_load_memory": (_st, [ctypes.c_char_p, _sz, ctypes.c_char_p, ctypes.c_char_p, ctypes.POINTER(_vp)]),
    "haha_avatar_load_lod": (_st, [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int32, ctypes.POINTER(_vp)]),
    "haha_avatar_free": (None, [_vp]),
    "haha_avatar_get_info": (_st, [_vp, ctypes.POINTER(AvatarInfo)]),
    "haha_avatar_faces": (_st, [_vp, c_uint32_p, _sz]),
    "haha_avatar_face_uvs": (_st, [_vp, c_float_p, _sz]),
    "haha_avatar_texture": (_st, [_vp, c_uint8_p, _sz]),
    "haha_avatar_mesh_coverage": (_st, [_vp, c_float_p, _sz, c_int32_p]),
    "haha_posed_create": (_st, [_vp, ctypes.POINTER(_vp)]),
    "haha_posed_free": (None, [_vp]),
    "haha_repose": (_st, [_vp, c_float_p, c_float_p, c_float_p, _sz, c_float_p, _sz]),
    "haha_posed_vertices": (_st, [_vp, c_float_p, _sz]),
    "haha_posed_normals": (_st, [_vp, c_float_p, _sz]),
    "haha_posed_joints": (_st, [_vp, c_float_p, _sz]),
    "haha_posed_gaussians": (_st, [_vp, ctypes.POINTER(GaussianArrays)]),
    "haha_render": (_st, [_vp, ctypes.POINTER(CCamera), c_float_p, ctypes.c_uint32, ctypes.c_int, _vp, _sz]),
    "haha_avatar_animation_count": (_st, [_vp, c_int32_p]),
    "haha_avatar_animation_info": (_st, [_vp, ctypes.c_int32, ctypes.c_char_p, _sz, ctypes.POINTER(ctypes.c_double),
                                         c_int32_p, ctypes.POINTER(ctypes.c_double)]),
    "haha_avatar_sample_animation": (_st, [_vp, ctypes.c_int32, ctypes.c_double, c_float_p, c_float_p]),
    "haha_motion_load": (_st, [ctypes.c_char_p, ctypes.POINTER(_vp)]),
    "haha_motion_load_for_avatar": (_st, [ctypes.c_char_p, _vp, ctypes.POINTER(_vp)]),
    "haha_motion_free": (None, [_vp]),
    "haha_motion_info": (_st, [_vp, c_int32_p, ctypes.POINTER(ctypes.c_double)]),
    "haha_motion_frame": (_st, [_vp, ctypes.c_int32, c_float_p, c_float_p]),
    "haha_write_png": (_st, [ctypes.c_char_p, ctypes.c_int32, ctypes.c_int32, ctypes.c_int32, c_uint8_p]),
}


def _candidates():
    """Library paths to try, in order (see the module's docstring)."""
    here = os.path.dirname(os.path.abspath(__file__))
    folders = [here, os.path.dirname(here), os.path.dirname(os.path.dirname(here))]
    paths = [os.path.join(d, n) for d in folders for n in NAMES]
    return [p for p in paths if os.path.exists(p)] + list(NAMES)


def _open(path):
    lib = ctypes.CDLL(path)  # CDLL releases the GIL during calls: poses render in parallel threads
    for name, (restype, argtypes) in _PROTOTYPES.items():
        fn = getattr(lib, name)
        fn.restype = restype
        fn.argtypes = argtypes
    major, minor = ctypes.c_int32(), ctypes.c_int32()
    lib.haha_version(ctypes.byref(major), ctypes.byref(minor), None)
    if (major.value, minor.value) != (API_MAJOR, API_MINOR):
        raise LibraryNotFoundError("%s: runtime version %d.%d, this package needs %d.%d"
                                   % (path, major.value, minor.value, API_MAJOR, API_MINOR))
    return lib


def _load():
    forced = os.environ.get("HAHA_RUNTIME_LIBRARY")
    if forced:
        try:
            return _open(forced)
        except OSError as e:
            raise LibraryNotFoundError("HAHA_RUNTIME_LIBRARY=%s: cannot load: %s" % (forced, e)) from None
    tried = []
    for path in _candidates():
        try:
            return _open(path)
        except OSError as e:
            tried.append("%s (%s)" % (path, str(e).split(":")[-1].strip()))
    found = ctypes.util.find_library("haha_runtime")
    if found:
        return _open(found)
    raise LibraryNotFoundError("libhaha_runtime.so not found: tried %s; set HAHA_RUNTIME_LIBRARY to its path"
                               % ", ".join(tried))


def lib():
    """The loaded library (loaded on first use; LibraryNotFoundError when it cannot be)."""
    global _lib
    if _lib is None:
        with _lock:
            if _lib is None:
                _lib = _load()
    return _lib


def library_path():
    """The path the library was loaded from (loads it if needed)."""
    return lib()._name


def check(status):
    """Raises the exception of a failed haha_status, with the thread's last error line."""
    if status == 0:
        return
    message = lib().haha_last_error().decode("utf-8", "replace")
    cls = STATUS_ERRORS.get(status, InternalError)
    name = lib().haha_status_string(status).decode()
    raise cls(message or name, name)


def call(name, *args):
    """Calls haha_<name> and raises on a failed status."""
    check(getattr(lib(), name)(*args))


class Owned:
    """Owns one library object (avatar, pose state, motion): frees it with `free_name` when
    the last Python reference goes. `keep` is held until then (a pose state keeps its
    avatar's Owned, so the avatar is freed after every state made from it)."""

    def __init__(self, free_name, keep=None):
        self.ptr = ctypes.c_void_p()
        self._free = getattr(lib(), free_name)
        self._keep = keep

    def __del__(self):
        if self.ptr:
            self._free(self.ptr)
            self.ptr = ctypes.c_void_p()
        self._keep = None
