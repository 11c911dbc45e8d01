"""Shape metrics on point samples: Chamfer distance and F-Score (the PartCrafter convention).

With ``d_pg`` the Euclidean (not squared) distance from each predicted point to its nearest
ground-truth point and ``d_gp`` the other way round::

    CD  = mean(d_pg) + mean(d_gp)
    P   = mean(d_pg < tau),  R = mean(d_gp < tau),  F@tau = 2 P R / (P + R)   (0 when P + R = 0)

PartCrafter computes the nearest neighbours with scikit-learn's ``NearestNeighbors`` (a single-threaded
k-d tree); here pykdtree's k-d trees answer the same exact queries, in float64, on every core (OpenMP).
The distances are bit-identical to scikit-learn's on the same samples (``benchmarks/measure_metrics.py``).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cache

import numpy as np
from pykdtree.kdtree import KDTree

#: F-Score thresholds of the benchmark (docs/conventions.md "Shape metrics"), in benchmark-frame units.
FSCORE_THRESHOLDS = (0.1, 0.5)
#: Leaf size of the k-d trees (measured on 1e5 surface samples: 32 is the fastest of 8-64).
LEAF_SIZE = 32
#: Below this many points per set, building trees in threads costs more than it saves.
PARALLEL_MIN_POINTS = 20_000


def build_tree(points: np.ndarray) -> KDTree:
    """A k-d tree on (N, 3) float64 points, N >= 1."""
    return KDTree(np.ascontiguousarray(points, dtype=np.float64), leafsize=LEAF_SIZE)


@cache
def _thread_controller():
    """threadpoolctl's view of the loaded thread pools, found once per process: finding them scans the
    process's loaded libraries (about 1 ms), too slow to repeat for every query of an ICP loop.
    pykdtree's OpenMP runtime is loaded with this module, so a view taken later always holds it."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextmanager
def thread_limit(workers: int) -> Iterator[None]:
    """At most ``workers`` OpenMP threads for pykdtree's queries inside the block (-1: no limit).

    The limit is process-wide while it lasts (OpenMP has no per-call setting); worker processes of an
    evaluation set ``OMP_NUM_THREADS`` instead.
    """
    if workers is None or workers < 1:
        yield
        return
    with _thread_controller().limit(limits=workers, user_api="openmp"):
        yield


def query_nearest(tree: KDTree, query: np.ndarray, workers: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Distance to and index of each query point's nearest point in ``tree`` (exact, Euclidean).

    :param tree: a tree from :func:`build_tree`
    :param query: (N, 3) points
    :param workers: threads for the queries (-1: every core)
    :returns: ``(distances (N,) float64, indices (N,) intp)``
    """
    query = np.ascontiguousarray(query, dtype=np.float64)
    with thread_limit(workers):
        distances, indices = tree.query(query, k=1)
    return distances, indices.astype(np.intp)


def nearest_distances(query: np.ndarray, reference: KDTree | np.ndarray, workers: int = -1) -> np.ndarray:
    """Distance from each query point to its nearest reference point (exact, Euclidean).

    :param query: (N, 3) points
    :param reference: the reference points (M, 3), or a tree on them from :func:`build_tree`
    :param workers: threads for the queries (-1: every core)
    """
    tree = reference if isinstance(reference, KDTree) else build_tree(reference)
    return query_nearest(tree, query, workers)[0]


def mutual_nearest_distances(points_a: np.ndarray, points_b: np.ndarray, workers: int = -1
                             ) -> tuple[np.ndarray, np.ndarray]:
    """``(d_ab, d_ba)``: nearest-neighbour distances from ``a`` to ``b`` and from ``b`` to ``a``.

    :param points_a: (N, 3) points
    :param points_b: (M, 3) points
    :param workers: threads for the queries (-1: every core)
    """
    tree_a, tree_b = build_trees(points_a, points_b, parallel=workers != 1)
    return nearest_distances(points_a, tree_b, workers), nearest_distances(points_b, tree_a, workers)


def build_trees(*point_sets: np.ndarray, parallel: bool = True) -> list[KDTree]:
    """k-d trees on several point sets, built in concurrent threads (pykdtree builds without the GIL)
    when ``parallel`` and the sets are large enough to pay for the threads."""
    if not parallel or len(point_sets) == 1 or min(len(p) for p in point_sets) < PARALLEL_MIN_POINTS:
        return [build_tree(p) for p in point_sets]
    with ThreadPoolExecutor(len(point_sets)) as pool:
        return list(pool.map(build_tree, point_sets))


@dataclass
class ShapeScores:
    """Chamfer distance and F-Scores of a predicted surface against a ground-truth surface.

    :param cd: ``mean(d_pg) + mean(d_gp)``, benchmark-frame units
    :param fscore: F-Score by threshold
    :param precision: fraction of predicted points within the threshold of the ground truth
    :param recall: fraction of ground-truth points within the threshold of the prediction
    :param n_points: number of (predicted, ground-truth) samples
    """

    cd: float
    fscore: dict[float, float] = field(default_factory=dict)
    precision: dict[float, float] = field(default_factory=dict)
    recall: dict[float, float] = field(default_factory=dict)
    n_points: tuple[int, int] = (0, 0)

    def to_dict(self, prefix: str = "", suffix: str = "") -> dict[str, float]:
        """``{prefix + "cd" + suffix: ..., prefix + "fscore" + suffix + "@0.1": ...}``."""
        out = {f"{prefix}cd{suffix}": self.cd}
        out.update({f"{prefix}fscore{suffix}@{t:g}": f for t, f in self.fscore.items()})
        return out


def fscore(precision: float, recall: float) -> float:
    """Harmonic mean of precision and recall; 0 when both are 0 (PartCrafter divides by zero there)."""
    total = precision + recall
    return 0.0 if total <= 0.0 else 2.0 * precision * recall / total


def scores_from_distances(d_pred_to_gt: np.ndarray, d_gt_to_pred: np.ndarray,
                          thresholds: Sequence[float] = FSCORE_THRESHOLDS) -> ShapeScores:
    """Chamfer distance and F-Scores from the two arrays of nearest-neighbour distances.

    :param d_pred_to_gt: distance of each predicted point to the ground truth
    :param d_gt_to_pred: distance of each ground-truth point to the prediction
    :param thresholds: F-Score thresholds
    """
    out = ShapeScores(cd=float(np.mean(d_pred_to_gt) + np.mean(d_gt_to_pred)),
                      n_points=(len(d_pred_to_gt), len(d_gt_to_pred)))
    for tau in thresholds:
        p = float(np.mean(d_pred_to_gt < tau))
        r = float(np.mean(d_gt_to_pred < tau))
        out.precision[float(tau)], out.recall[float(tau)] = p, r
        out.fscore[float(tau)] = fscore(p, r)
    return out


def shape_scores(pred_points: np.ndarray, gt_points: np.ndarray,
                 thresholds: Sequence[float] = FSCORE_THRESHOLDS, workers: int = -1) -> ShapeScores:
    """Chamfer distance and F-Scores between two point samples.

    :param pred_points: (N, 3) samples of the predicted surface
    :param gt_points: (M, 3) samples of the ground-truth surface
    :param thresholds: F-Score thresholds
    :param workers: threads for the nearest-neighbour queries (-1: every core)
    """
    d_pg, d_gp = mutual_nearest_distances(pred_points, gt_points, workers)
    return scores_from_distances(d_pg, d_gp, thresholds)


def chamfer_distance(points_a: np.ndarray, points_b: np.ndarray, workers: int = -1) -> float:
    """Symmetric Chamfer distance ``mean(d_ab) + mean(d_ba)`` between two point samples."""
    d_ab, d_ba = mutual_nearest_distances(points_a, points_b, workers)
    return float(d_ab.mean() + d_ba.mean())
