#!/usr/bin/env python3
"""Writes the small pickle fixtures under tests/fixtures/pickle/ that tests/io/pickle_test.cpp
and tests/data/readers_test.cpp read. Run once by a developer (needs Python 3 and
numpy, e.g. Debian's python3-numpy):

    /usr/bin/python3 scripts/make_pickle_fixtures.py

The outputs are committed, so neither the build nor the tests need Python. Every value is
a simple formula of its position; the C++ tests recompute the same formulas.
"""
import collections
import os
import pickle

import numpy as np

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "pickle")


def smplx_frame(frame, dtype=np.float32, lead=()):
    """SMPL-X parameters of one frame, value = frame + 0.01 * (key number) + 0.001 * index."""
    sizes = [("global_orient", 3), ("transl", 3), ("body_pose", 63), ("left_hand_pose", 45),
             ("right_hand_pose", 45), ("jaw_pose", 3), ("leye_pose", 3), ("reye_pose", 3),
             ("expression", 10), ("betas", 10)]
    d = {}
    for k, (name, n) in enumerate(sizes):
        v = frame + 0.01 * k + 0.001 * np.arange(n)
        d[name] = v.astype(dtype).reshape(lead + (n,))
    return d


def smplifyx_frame(frame):
    """A SMPLify-X result dict: (1, D) arrays, 12 PCA hand coefficients, camera keys."""
    d = {
        "camera_rotation": np.eye(3, dtype=np.float32).reshape(1, 3, 3),
        "camera_translation": np.array([[0.1 * frame, -0.2, 5.0 + frame]], np.float32),
        "betas": (0.1 * np.arange(10) - 0.3).astype(np.float32).reshape(1, 10),
        "global_orient": np.array([[np.pi, 0.0, 0.1 * frame]], np.float32),
        "left_hand_pose": (0.05 * (np.arange(12) + frame)).astype(np.float32).reshape(1, 12),
        "right_hand_pose": (-0.05 * (np.arange(12) + frame)).astype(np.float32).reshape(1, 12),
        "jaw_pose": np.array([[0.2, 0.0, 0.0]], np.float32),
        "leye_pose": np.zeros((1, 3), np.float32),
        "reye_pose": np.zeros((1, 3), np.float32),
        "expression": (0.01 * np.arange(10)).astype(np.float32).reshape(1, 10),
        "body_pose": (0.001 * np.arange(63) * (frame + 1)).astype(np.float32).reshape(1, 63),
    }
    return d


def values():
    """Every value kind the reader must handle."""
    shared = [1, 2, 3]
    return {
        "none": None, "true": True, "false": False,
        "ints": [0, 1, -1, 255, 256, 65535, 65536, -2**31, 2**31, 2**40, -2**63, 2**63 - 1],
        "float": 1.5, "neg_float": -2.25e-3,
        "text": "h\u00e9llo", "raw": b"\x00\x01\xff",
        "tuple": (1, 2.5, "x"), "nested": [[1.0, 2.0], [3.0, 4.0]],
        "shared_a": shared, "shared_b": shared,
        "ordered": collections.OrderedDict([("b", 2), ("a", 1)]),
        "f32_scalar": np.float32(0.25), "i64_scalar": np.int64(-7),
        "f64": np.arange(6, dtype=np.float64).reshape(2, 3) / 4.0,
        "f32": (np.arange(24, dtype=np.float32) - 3.5).reshape(2, 3, 4),
        "fortran": np.asfortranarray(np.arange(6, dtype=np.float32).reshape(3, 2)),
        "big_endian": np.arange(4, dtype=">f8") * 1.5,
        "i64": np.array([-5, 0, 2**40], dtype=np.int64),
        "i32": np.array([[-1, 2], [3, -4]], dtype=np.int32),
        "u32": np.array([0, 4000000000], dtype=np.uint32),
        "u8": np.array([0, 7, 255], dtype=np.uint8),
        "i16": np.array([-300, 300], dtype=np.int16),
        "bool": np.array([True, False, True]),
        "f16": np.array([0.5, -2.0, 65504.0], dtype=np.float16),
        "zero_d": np.array(3.0),
        "empty": np.zeros((0, 3), np.float32),
        "unicode_array": np.array(["ab", "c"]),
        "object_array": np.array([{"x": 1}, None], dtype=object),
        7: "int key",
    }


def write(name, obj, protocol):
    with open(os.path.join(OUT, name), "wb") as f:
        pickle.dump(obj, f, protocol=protocol)


class Evil:
    """Pickles as a call of os.system; the reader must refuse it (never loaded here)."""

    def __reduce__(self):
        return (os.system, ("echo pwned",))


def main():
    os.makedirs(OUT, exist_ok=True)
    for p in (2, 3, 4, 5):
        write(f"values_p{p}.pkl", values(), p)
    write("smplx_f64_lead1_p2.pkl", smplx_frame(3, np.float64, (1,)), 2)
    write("evil_global.pkl", {"betas": np.zeros(10, np.float32), "x": Evil()}, 2)
    # NumPy 2 spells the module numpy._core; numpy 1.x here cannot write that, so rename
    # the text GLOBAL arguments of a protocol-2 pickle (still a valid pickle).
    b = pickle.dumps({"a": np.arange(3, dtype=np.float32), "s": np.float64(2.5)}, protocol=2)
    write_bytes = b.replace(b"cnumpy.core.multiarray\n", b"cnumpy._core.multiarray\n")
    assert write_bytes != b
    with open(os.path.join(OUT, "numpy2_p2.pkl"), "wb") as f:
        f.write(write_bytes)
    # X-Humans takes: SMPLX/mesh-f%05d_smplx.pkl, dicts of 1-D float32 arrays.
    xh = os.path.join(OUT, "xhumans")
    os.makedirs(xh, exist_ok=True)
    for frame in range(1, 4):
        write(os.path.join("xhumans", f"mesh-f{frame:05d}_smplx.pkl"), smplx_frame(frame), 4)
    # SMPLify-X results: results/<image stem>/000.pkl, protocol 2.
    for frame in range(3):
        d = os.path.join(OUT, "smplifyx", f"{frame:05d}")
        os.makedirs(d, exist_ok=True)
        write(os.path.join("smplifyx", f"{frame:05d}", "000.pkl"), smplifyx_frame(frame), 2)


if __name__ == "__main__":
    main()
