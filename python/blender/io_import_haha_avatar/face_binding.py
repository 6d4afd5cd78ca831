"""Each Gaussian's face and its local offset, rotation and scale in that face's frame
(format/spec.md, "Face frames and posing"), recovered from the runtime's reposing.

The C API gives posed Gaussians only, so the binding is read back: the rest centre fixes
the local offset for any candidate face (the nearest faces by centroid), and two probe poses
pick the one candidate whose frame carries the centre where the runtime puts it; a
Gaussian none of them carries (far from its face) is tried on every face.
"""
import numpy as np

CANDIDATES = 24  # nearest faces tried per Gaussian first
MATCH = 1e-5  # m: a face that carries the centre within this at the probe poses is its own


def face_frames(vertices, faces, scale_divisor):
    """Centre T (F, 3), frame R (F, 3, 3) with columns e, n, e x n, and scale k (F,) of
    every face, exactly as format/spec.md defines them."""
    v0, v1, v2 = (vertices[faces[:, i]].astype(np.float64) for i in range(3))
    t = (v0 + v1 + v2) / 3.0
    e = v2 - v1
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    n = np.cross(e, v0 - v1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    r = np.stack([e, n, np.cross(e, n)], axis=2)
    b = np.linalg.norm(v0 - v2, axis=1)
    h = np.linalg.norm(np.cross(v2 - v1, v0 - v1), axis=1) / b
    return t, r, (b + h) / 2.0 / scale_divisor


def _nearest_faces(points, centroids, k):
    """(N, k) indices of the k face centroids nearest each point (mathutils' KD-tree)."""
    from mathutils.kdtree import KDTree
    tree = KDTree(len(centroids))
    for i, c in enumerate(centroids):
        tree.insert(c, i)
    tree.balance()
    out = np.empty((len(points), k), np.int64)
    for g, p in enumerate(points):
        found = tree.find_n(p, k)
        out[g] = [f[1] for f in found] + [found[-1][1]] * (k - len(found))
    return out


def quat_mul(a, b):
    """Hamilton products of (N, 4) (w, x, y, z) quaternions."""
    aw, ax, ay, az = a.T
    bw, bx, by, bz = b.T
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], 1)


def matrix_to_quat(m):
    """(N, 3, 3) rotations -> (N, 4) unit quaternions (w, x, y, z): Shepperd's method, each
    row from its largest diagonal combination (stable near 180 degrees)."""
    tr = np.trace(m, axis1=1, axis2=2)
    pick = np.argmax(np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], 1), axis=1)
    q = np.empty((len(m), 4))
    for i in range(4):
        s = pick == i
        a = m[s]
        if i == 0:
            r = np.sqrt(1.0 + tr[s]) * 2
            q[s] = np.stack([r / 4, (a[:, 2, 1] - a[:, 1, 2]) / r, (a[:, 0, 2] - a[:, 2, 0]) / r, (a[:, 1, 0] - a[:, 0, 1]) / r], 1)
            continue
        x, y, z = i - 1, i % 3, (i + 1) % 3  # the picked axis and the two after it
        r = np.sqrt(1.0 + a[:, x, x] - a[:, y, y] - a[:, z, z]) * 2
        v = np.empty((len(a), 4))
        v[:, 0] = (a[:, z, y] - a[:, y, z]) / r
        v[:, 1 + x] = r / 4
        v[:, 1 + y] = (a[:, x, y] + a[:, y, x]) / r
        v[:, 1 + z] = (a[:, x, z] + a[:, z, x]) / r
        q[s] = v
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def probe_poses(num_joints):
    """Two poses that bend every joint a little, about varied axes: a face that carries a
    centre right in both is its face (one pose can leave neighbours moving alike)."""
    j = np.arange(num_joints, dtype=np.float64)[:, None]
    return [0.35 * np.sin(np.array([1.0, 2.3, 3.7]) * (j + 1.0)), 0.5 * np.cos(np.array([1.7, 0.6, 2.9]) * (j + 2.0))]


def _carry(rest_means, probes, cand, rest_frames):
    """Local offsets (N, C, 3) of rest centres in candidate faces `cand` (N, C) and how far
    each face's posed frames carry them from the runtime's posed centres, the worst over the
    probes [(posed centres (N, 1, 3), posed frames)] (N, C)."""
    t0, r0, k0 = (a[cand] for a in rest_frames)
    mu = np.einsum("gkji,gkj->gki", r0, rest_means - t0) / k0[:, :, None]
    miss = 0.0
    for posed_means, frames in probes:
        t1, r1, k1 = (a[cand] for a in frames)
        guess = t1 + k1[:, :, None] * np.einsum("gkij,gkj->gki", r1, mu)
        miss = np.maximum(miss, np.linalg.norm(guess - posed_means, axis=2))
    return mu, miss


def bind(avatar, faces, scale_divisor):
    """{"face", "offset", "rotation" (w, x, y, z), "scale", "color", "opacity", "error"} per
    Gaussian in the file's order; error: the chosen face's worst miss at the probe poses (m)."""
    rest = avatar.repose()
    probes = []
    for pose in probe_poses(avatar.num_joints):
        posed = avatar.repose(pose)
        probes.append((posed.means.astype(np.float64), face_frames(posed.vertices, faces, scale_divisor)))
    t0, r0, k0 = face_frames(rest.vertices, faces, scale_divisor)
    means = rest.means.astype(np.float64)
    cand = _nearest_faces(means, t0, min(CANDIDATES, len(faces)))
    mu, miss = _carry(means[:, None, :], [(m[:, None, :], f) for m, f in probes], cand, (t0, r0, k0))
    best = np.argmin(miss, axis=1)
    g = np.arange(len(means))
    face, offset, error = cand[g, best], mu[g, best], miss[g, best]
    everywhere = np.arange(len(faces))[None, :]
    for i in np.flatnonzero(error > MATCH):  # far from its face: try them all
        m, e = _carry(means[i:i + 1, None, :], [(m[i:i + 1, None, :], f) for m, f in probes], everywhere, (t0, r0, k0))
        b = int(np.argmin(e[0]))
        face[i], offset[i], error[i] = b, m[0, b], e[0, b]
    frame_q = matrix_to_quat(r0[face])
    frame_q[:, 1:] *= -1.0  # conjugate: the local rotation is q(R)^-1 * world rotation
    return {"face": face, "offset": offset, "scale": rest.scales / k0[face][:, None],
            "rotation": quat_mul(frame_q, rest.rotations.astype(np.float64)),
            "color": rest.colors, "opacity": rest.opacities, "error": error}
