"""Small rigid-transform helpers on plain NumPy arrays (4x4 homogeneous matrices)."""

from __future__ import annotations

import numpy as np


def unit(vector, what: str | None = None) -> np.ndarray:
    """``vector`` (as float64) scaled to unit length.

    :param vector: a vector
    :param what: what the vector is, for the error message; when given, a zero or non-finite vector is
        a ``ValueError`` ("``what`` [x, y, z] has no direction"); when None it is divided all the same
        (NumPy gives NaN or inf entries, with its RuntimeWarning)
    """
    vector = np.asarray(vector, dtype=np.float64)
    norm = np.linalg.norm(vector)
    if what is not None and (not np.isfinite(norm) or norm <= 0.0):
        raise ValueError(f"{what} {vector.tolist()} has no direction")
    return vector / norm


def rpy_to_matrix(rpy) -> np.ndarray:
    """3x3 rotation from URDF roll-pitch-yaw (fixed axes X, then Y, then Z): ``R = Rz(y) Ry(p) Rx(r)``."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_to_rpy(rot: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw of a 3x3 rotation (inverse of :func:`rpy_to_matrix`)."""
    rot = np.asarray(rot, dtype=float)
    sp = -rot[2, 0]
    if abs(sp) < 1.0 - 1e-9:
        p = np.arcsin(sp)
        r = np.arctan2(rot[2, 1], rot[2, 2])
        y = np.arctan2(rot[1, 0], rot[0, 0])
    else:  # gimbal lock: fold yaw into roll
        p = np.pi / 2 * np.sign(sp)
        r = np.arctan2(-rot[1, 2], rot[1, 1])
        y = 0.0
    return np.array([r, p, y])


def make_transform(rotation=None, translation=None) -> np.ndarray:
    """4x4 transform from an optional 3x3 rotation and an optional translation."""
    out = np.eye(4)
    if rotation is not None:
        out[:3, :3] = rotation
    if translation is not None:
        out[:3, 3] = translation
    return out


def origin_to_matrix(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4 transform of a URDF ``<origin xyz rpy>``."""
    return make_transform(rpy_to_matrix(rpy), np.asarray(xyz, dtype=float))


def axis_angle_matrix(axis, angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` radians about the unit vector ``axis`` (Rodrigues)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def transform_points(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to an (N, 3) array of points."""
    points = np.asarray(points, dtype=float)
    return points @ transform[:3, :3].T + transform[:3, 3]


def invert_transform(transform: np.ndarray) -> np.ndarray:
    """Inverse of a rigid 4x4 transform."""
    out = np.eye(4)
    rot = transform[:3, :3]
    out[:3, :3] = rot.T
    out[:3, 3] = -rot.T @ transform[:3, 3]
    return out
