"""Finding the `haha` Python package (and through it libhaha_runtime.so) from Blender.

Tried in order: an already importable `haha`; the folders in HAHA_PYTHONPATH; the package
where `cmake --install` / the build tree put it relative to this add-on (_paths.py, written
by CMake: P/share/haha/blender/addons/<add-on> -> P/lib/python).
"""
import importlib
import os
import sys


def _candidates():
    here = os.path.dirname(os.path.abspath(__file__))
    dirs = [d for d in os.environ.get("HAHA_PYTHONPATH", "").split(os.pathsep) if d]
    try:
        from . import _paths
        dirs.append(os.path.normpath(os.path.join(here, _paths.PYTHON_DIR_FROM_ADDON)))
    except ImportError:
        pass
    return dirs


def import_haha():
    """The `haha` module; RuntimeError with one line saying where it was looked for."""
    try:
        return importlib.import_module("haha")
    except ImportError:
        pass
    tried = []
    for d in _candidates():
        if os.path.isfile(os.path.join(d, "haha", "__init__.py")):
            if d not in sys.path:
                sys.path.append(d)
            return importlib.import_module("haha")
        tried.append(d)
    raise RuntimeError("HAHA avatar import: the Python package `haha` was not found (looked in %s); "
                       "set HAHA_PYTHONPATH to the folder holding haha/ (P/lib/python of the install)"
                       % (", ".join(tried) or "nowhere"))
