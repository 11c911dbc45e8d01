"""Matching predicted movable parts to ground-truth ones: Hungarian algorithm on part Chamfer distance.

Matching is joint-centric: each movable joint contributes one part (the links it moves and no other
movable joint below it moves), so two joints are compared exactly when their parts are matched.
Parts with the same geometry (a prismatic and a continuous joint chained through a helper link, the
screw cap of a bottle) tie on Chamfer distance; a tiny tie-break term then prefers pairs of the same
joint type and, after that, closer axes, so that an asset compared with itself is matched to itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from spark_bench.metrics.shape import build_tree, nearest_distances

#: Weight of the tie-break term (values in [0, 1]) next to Chamfer distances in benchmark-frame units:
#: far below any Chamfer difference that means something, far above floating-point noise.
TIE_BREAK_WEIGHT = 1e-6
#: Stands in for an impossible pair (a part without geometry) in the assignment problem.
_UNMATCHABLE = 1e6


@dataclass(frozen=True)
class PartPair:
    """One matched pair: indices into the predicted and ground-truth part lists, and their cost.

    :param pred: index of the predicted part
    :param gt: index of the ground-truth part
    :param cost: part-to-part Chamfer distance at rest (on the matching samples)
    """

    pred: int
    gt: int
    cost: float


def part_cost_matrix(pred_parts: Sequence[np.ndarray | None], gt_parts: Sequence[np.ndarray | None],
                     workers: int = -1) -> np.ndarray:
    """Chamfer distance between every predicted and every ground-truth part (``inf`` for a part
    without geometry).

    :param pred_parts: point samples of each predicted part (None: no geometry)
    :param gt_parts: point samples of each ground-truth part (None: no geometry)
    :param workers: threads for the nearest-neighbour queries
    """
    cost = np.full((len(pred_parts), len(gt_parts)), np.inf)
    # one tree per part, not one per pair: the same numbers as chamfer_distance on every pair
    pred_trees = [None if p is None else build_tree(p) for p in pred_parts]
    gt_trees = [None if g is None else build_tree(g) for g in gt_parts]
    for i, (pred, pred_tree) in enumerate(zip(pred_parts, pred_trees)):
        for j, (gt, gt_tree) in enumerate(zip(gt_parts, gt_trees)):
            if pred is not None and gt is not None:
                d_pg = nearest_distances(pred, gt_tree, workers)
                d_gp = nearest_distances(gt, pred_tree, workers)
                cost[i, j] = float(d_pg.mean() + d_gp.mean())
    return cost


def match_parts(cost: np.ndarray, tie_break: np.ndarray | None = None) -> list[PartPair]:
    """Minimum-cost one-to-one matching (Hungarian algorithm); rectangular matrices leave the
    surplus parts of the longer side unmatched, and pairs of infinite cost are never returned.

    :param cost: (n_pred, n_gt) costs, ``inf`` where a pair is impossible
    :param tie_break: optional (n_pred, n_gt) values in [0, 1] added with weight
        :data:`TIE_BREAK_WEIGHT`, to order pairs whose costs tie
    :returns: the matched pairs, by ground-truth index
    """
    cost = np.asarray(cost, dtype=np.float64)
    if cost.size == 0:
        return []
    if np.isnan(cost).any():
        raise ValueError("part costs contain NaN")
    finite = np.isfinite(cost)
    work = np.where(finite, cost, _UNMATCHABLE)
    if tie_break is not None:
        work = work + TIE_BREAK_WEIGHT * np.clip(np.asarray(tie_break, dtype=np.float64), 0.0, 1.0)
    rows, cols = linear_sum_assignment(work)
    pairs = [PartPair(int(i), int(j), float(cost[i, j])) for i, j in zip(rows, cols) if finite[i, j]]
    return sorted(pairs, key=lambda p: p.gt)
