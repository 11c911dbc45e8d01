"""Optional alignment of a prediction to the ground truth (``--align icp``).

Both assets are already in their own benchmark frame (rest-pose box centered, max extent 2). The
search tries a grid of rotations about the up axis (world Z) and of uniform scales, refines each
start with rigid point-to-point ICP on surface samples, and keeps the transform with the lowest
symmetric Chamfer distance (the identity is a candidate too, so aligning never makes the samples it
was chosen on worse). The result is a similarity ``x -> s R x + t``: points (mesh vertices, pivots)
take all of it, axis directions take ``R`` only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from spark_bench.metrics.shape import KDTree, build_tree, nearest_distances, query_nearest

#: Default start angles about Z: every 30 degrees, so ICP starts within 15 degrees of any yaw.
DEFAULT_ANGLES = tuple(np.deg2rad(np.arange(0, 360, 30)))
#: Default start scales (the two boxes are normalized already; rotation changes the box).
DEFAULT_SCALES = (0.9, 1.0, 1.1)


@dataclass
class Alignment:
    """A similarity transform found by :func:`align_points`.

    :param matrix: 4x4 matrix ``[[s R, t], [0, 1]]``
    :param cd: symmetric Chamfer distance on the alignment samples after the transform
    :param start_angle: the grid angle (radians about Z) the best start came from; None: identity
    :param start_scale: the grid scale the best start came from; None: identity
    """

    matrix: np.ndarray
    cd: float
    start_angle: float | None = None
    start_scale: float | None = None

    @property
    def scale(self) -> float:
        return similarity_scale(self.matrix)

    @property
    def rotation(self) -> np.ndarray:
        return self.matrix[:3, :3] / self.scale

    def apply_points(self, points: np.ndarray) -> np.ndarray:
        """The full transform on (N, 3) points."""
        return np.asarray(points, dtype=np.float64) @ self.matrix[:3, :3].T + self.matrix[:3, 3]

    def apply_direction(self, direction: np.ndarray) -> np.ndarray:
        """The rotation only, on a direction (translation never leaks into axes)."""
        return self.rotation @ np.asarray(direction, dtype=np.float64)


def similarity_scale(matrix) -> float:
    """The uniform scale ``s`` of a similarity ``[[s R, t], [0, 1]]`` (the cube root of its determinant).

    :param matrix: 4x4 similarity (a nested list, as a results row stores it, or an array)
    """
    return float(np.cbrt(np.linalg.det(np.asarray(matrix, dtype=np.float64)[:3, :3])))


def similarity_yaw_deg(matrix) -> float:
    """The turn about Z of a similarity ``[[s R, t], [0, 1]]`` whose ``R`` turns about Z, in degrees in
    (-180, 180].

    :param matrix: 4x4 similarity (a nested list or an array)
    """
    linear = np.asarray(matrix, dtype=np.float64)[:3, :3]
    return float(np.degrees(np.arctan2(linear[1, 0], linear[0, 0])))


def identity_alignment(cd: float = float("nan")) -> Alignment:
    """The do-nothing alignment (``--align none``)."""
    return Alignment(np.eye(4), cd)


def rotation_z(angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` radians about the Z axis."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rigid_fit(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """4x4 rigid transform minimizing ``sum |R source_i + t - target_i|^2`` (Kabsch, no reflection)."""
    mu_s, mu_t = source.mean(0), target.mean(0)
    h = (source - mu_s).T @ (target - mu_t)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    out = np.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = mu_t - rot @ mu_s
    return out


def _apply(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def icp(source: np.ndarray, target_tree: KDTree, initial: np.ndarray, max_iterations: int = 30,
        tolerance: float = 1e-6, workers: int = -1) -> np.ndarray:
    """Rigid point-to-point ICP of ``source`` onto the points of ``target_tree``, from ``initial``.

    :param source: (N, 3) points to move
    :param target_tree: k-d tree on the target points (:func:`~spark_bench.metrics.shape.build_tree`)
    :param initial: 4x4 starting transform (may contain a scale, which ICP keeps)
    :param max_iterations: iteration cap
    :param tolerance: stop when the mean residual improves by less than this
    :param workers: threads for the nearest-neighbour queries
    :returns: 4x4 transform ``rigid @ initial``
    """
    target = np.asarray(target_tree.data_pts).reshape(-1, 3)
    matrix = np.array(initial, dtype=np.float64)
    previous = np.inf
    for _ in range(max_iterations):
        moved = _apply(matrix, source)
        dist, index = query_nearest(target_tree, moved, workers)
        error = float(dist.mean())
        if previous - error < tolerance:
            break
        previous = error
        matrix = rigid_fit(moved, target[index]) @ matrix
    return matrix


def align_points(source: np.ndarray, target: np.ndarray, angles: Sequence[float] = DEFAULT_ANGLES,
                 scales: Sequence[float] = DEFAULT_SCALES, max_iterations: int = 50,
                 coarse_iterations: int = 8, n_refine: int = 3, tolerance: float = 1e-6,
                 workers: int = -1) -> Alignment:
    """The similarity that best maps ``source`` samples onto ``target`` samples.

    Every grid start gets ``coarse_iterations`` of ICP; the ``n_refine`` best (by symmetric Chamfer
    distance) continue up to ``max_iterations``; the best of those, or the identity, wins.

    :param source: (N, 3) samples of the prediction (benchmark frame)
    :param target: (M, 3) samples of the ground truth (benchmark frame)
    :param angles: start rotations about Z, radians
    :param scales: start uniform scales
    :param max_iterations: ICP iterations for the refined starts
    :param coarse_iterations: ICP iterations for every start
    :param n_refine: how many starts are refined
    :param tolerance: ICP stopping tolerance on the mean residual
    :param workers: threads for the nearest-neighbour queries
    """
    source = np.asarray(source, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    target_tree = build_tree(target)

    def score(matrix: np.ndarray) -> float:  # chamfer_distance, with the target's tree built once
        moved = _apply(matrix, source)
        d_st = nearest_distances(moved, target_tree, workers)
        d_ts = nearest_distances(target, build_tree(moved), workers)
        return float(d_st.mean() + d_ts.mean())

    coarse = []
    for angle in angles:
        for scale in scales:
            start = np.eye(4)
            start[:3, :3] = scale * rotation_z(angle)
            matrix = icp(source, target_tree, start, coarse_iterations, tolerance, workers)
            coarse.append((score(matrix), matrix, float(angle), float(scale)))
    coarse.sort(key=lambda c: c[0])
    best = identity_alignment(score(np.eye(4)))
    for _, matrix, angle, scale in coarse[:n_refine]:
        matrix = icp(source, target_tree, matrix, max_iterations, tolerance, workers)
        cd = score(matrix)
        if cd < best.cd:
            best = Alignment(matrix, cd, angle, scale)
    return best
