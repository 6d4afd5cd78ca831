"""Finding the `haha` Python package (and through it libhaha_runtime.so) from Blender.

Tried in order: an already importable `haha`; the folders in HAHA_PYTHONPATH; the package
bundled inside this add-on (the zip of scripts/blender-addon-zip.sh, whose libs/ holds the
libraries the runtime needs that Blender does not bring: loaded first, so the runtime's
own loading finds them by name); the package where `cmake --install` / the build tree put it
relative to this add-on (_paths.py, written by CMake: P/share/haha/blender/addons/<add-on>
-> P/lib/python).
"""
import ctypes
import importlib
import os
import sys


def _candidates():
    here = os.path.dirname(os.path.abspath(__file__))
    dirs = [d for d in os.environ.get("HAHA_PYTHONPATH", "").split(os.pathsep) if d]
    dirs.append(here)
    try:
        from . import _paths
        dirs.append(os.path.normpath(os.path.join(here, _paths.PYTHON_DIR_FROM_ADDON)))
    except ImportError:
        pass
    return dirs


def _preload_bundled_libraries():
    """Loads libs/*.so of a zip install globally; a library that needs another of them is
    retried after the rest (no order is recorded)."""
    libs = os.path.join(os.path.dirname(os.path.abspath(__file__)), "libs")
    pending = sorted(os.path.join(libs, n) for n in os.listdir(libs)) if os.path.isdir(libs) else []
    while pending:
        failed = []
        for path in pending:
            try:
                ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
            except OSError:
                failed.append(path)
        if len(failed) == len(pending):
            raise RuntimeError("HAHA avatar import: cannot load the bundled %s" % ", ".join(failed))
        pending = failed


def import_haha():
    """The `haha` module; RuntimeError with one line saying where it was looked for."""
    try:
        return importlib.import_module("haha")
    except ImportError:
        pass
    tried = []
    for d in _candidates():
        if os.path.isfile(os.path.join(d, "haha", "__init__.py")):
            _preload_bundled_libraries()
            if d not in sys.path:
                sys.path.append(d)
            return importlib.import_module("haha")
        tried.append(d)
    raise RuntimeError("HAHA avatar import: the Python package `haha` was not found (looked in %s); "
                       "set HAHA_PYTHONPATH to the folder holding haha/ (P/lib/python of the install)"
                       % (", ".join(tried) or "nowhere"))
