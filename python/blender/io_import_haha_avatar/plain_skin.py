"""The file's skin weights, recovered from the runtime's own skinning.

The C API exposes no skin weights and a Draco mesh cannot be decoded in Blender's Python, so
the weights are read back from reposes of the same file with its pose correctives removed
(the runtime then skins it as a plain glTF skin, format/spec.md): turning joint j alone by R
moves vertex v by W_j (R - I)(v - c_j), W_j the summed weight of j's subtree, and a joint's
own weight is its subtree's minus its children's. Exact to float32 for any pack.
"""
import json
import struct

import numpy as np

from .glb_skeleton import read_gltf_json

_JSON = 0x4E4F534A


def without_pose_correctives(path):
    """The bytes of the .glb at `path` with the embedded pose correctives dropped from its
    JSON (the binary chunk unchanged): the runtime reposes it by linear blend skinning only."""
    gltf = read_gltf_json(path)
    body = gltf["extensions"]["HAHA_gaussian_avatar"]["body"]
    body.pop("poseCorrectives", None)
    body["trainedWithPoseCorrectives"] = False
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)  # chunks are 4-byte aligned
    with open(path, "rb") as f:
        head = f.read(20)
        rest = f.read()[struct.unpack("<I", head[12:16])[0]:]
    total = 20 + len(text) + len(rest)
    return head[:8] + struct.pack("<III", total, len(text), _JSON) + text + rest


def subtree_weights(avatar, rest_vertices, rest_joints, angle=np.pi / 2):
    """(V, J): each joint's subtree weight per vertex, least squares over two turns of the
    joint (about two axes, so no vertex lies on both)."""
    V, J = len(rest_vertices), len(rest_joints)
    out = np.ones((V, J))
    for j in range(1, J):
        num, den = np.zeros(V), np.zeros(V)
        for axis in ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)):
            pose = np.zeros((J, 3))
            pose[j] = angle * np.asarray(axis)
            moved = avatar.repose(pose).vertices.astype(np.float64) - rest_vertices
            c, s = np.cos(angle), np.sin(angle)
            a = np.asarray(axis)
            d = rest_vertices - rest_joints[j]
            u = (c - 1.0) * d + s * np.cross(a, d) + (1.0 - c) * np.outer(d @ a, a)  # (R - I) d, Rodrigues
            num += np.einsum("ij,ij->i", moved, u)
            den += np.einsum("ij,ij->i", u, u)
        out[:, j] = num / np.maximum(den, 1e-30)
    return out


def skin_weights(avatar, parents, rest_vertices, rest_joints):
    """(V, J) weights of the plain-skinned `avatar` (a joint's subtree weight less its
    children's), float32 noise (below 1e-5) dropped and each row renormalised to one."""
    sub = subtree_weights(avatar, np.asarray(rest_vertices, np.float64), np.asarray(rest_joints, np.float64))
    w = sub.copy()
    for j, p in enumerate(parents):
        if p >= 0:
            w[:, p] -= sub[:, j]
    w[w < 1e-5] = 0.0
    return w / np.maximum(w.sum(axis=1, keepdims=True), 1e-12)
