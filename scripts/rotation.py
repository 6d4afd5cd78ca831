"""Axis-angle <-> rotation matrix for the measurement scripts (numpy; SMPL-X stores
axis-angle vectors)."""
import numpy as np


def rodrigues(v):
    """The rotation matrix of axis-angle vector v (radians)."""
    th = np.linalg.norm(v)
    if th < 1e-12:
        return np.eye(3)
    k = v / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def log_rotation(R):
    """The axis-angle vector of rotation matrix R (angle in [0, pi])."""
    th = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    if th < 1e-9:
        return np.zeros(3)
    if th > np.pi - 1e-4:  # near pi: the axis from the symmetric part
        w, V = np.linalg.eigh((R + np.eye(3)) / 2)
        return V[:, np.argmax(w)] * th
    return th / (2 * np.sin(th)) * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
