"""Writing images through the runtime (haha_write_png)."""
import ctypes
import os

import numpy as np

from ._library import call
from .errors import ArgumentError


def write_png(path, image):
    """Writes an 8-bit image, (H, W) grey or (H, W, C) with C in 1..4, as a PNG (path ends in .png).

    The file appears complete or not at all. Float images are taken as [0, 1] and rounded.
    """
    a = np.asarray(image)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ArgumentError("image: expected shape (H, W) or (H, W, 1..4), got %s" % (np.shape(image),))
    if a.dtype != np.uint8:
        a = np.round(255.0 * np.clip(a.astype(np.float64), 0.0, 1.0)).astype(np.uint8)
    a = np.ascontiguousarray(a)
    call("haha_write_png", os.fsencode(path), a.shape[1], a.shape[0], a.shape[2],
         a.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8)))
