"""numpy <-> ctypes helpers and the checks on array arguments (shapes, finiteness)."""
import ctypes

import numpy as np

from .errors import ArgumentError

NUM_JOINTS = 55
NUM_POSE_VALUES = 3 * NUM_JOINTS


def ptr(array, ctype):
    """A ctypes pointer to a C-contiguous numpy array (None stays None)."""
    if array is None:
        return None
    return array.ctypes.data_as(ctypes.POINTER(ctype))


def float_values(name, values, shapes, what):
    """values as a C-contiguous float32 array of `size` elements; ArgumentError otherwise.

    shapes: the accepted shapes (the first one's size is the element count), `what` says them
    in words for the message.
    """
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ArgumentError("%s: expected %s of numbers (%s)" % (name, what, e)) from None
    if a.shape not in shapes:
        raise ArgumentError("%s: expected %s, got shape %s" % (name, what, a.shape))
    if not np.all(np.isfinite(a)):
        raise ArgumentError("%s: non-finite value (NaN or infinity)" % name)
    return np.ascontiguousarray(a.reshape(-1), dtype=np.float32)


def pose_values(pose):
    """An SMPL-X pose (165 values or (55, 3)) as float32[165]; None stays None (rest pose)."""
    if pose is None:
        return None
    return float_values("pose", pose, [(NUM_POSE_VALUES,), (NUM_JOINTS, 3)],
                        "165 axis-angle values or shape (55, 3)")


def translation_values(transl):
    """A translation (3 values) as float32[3]; None stays None (no translation)."""
    if transl is None:
        return None
    return float_values("transl", transl, [(3,)], "3 values")


def shape_values(name, values):
    """betas / expression: the runtime refuses any (a packed avatar's shape is baked)."""
    if values is None:
        return None, 0
    a = np.ascontiguousarray(np.asarray(values, dtype=np.float32).reshape(-1))
    return a, a.size
