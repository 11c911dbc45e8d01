"""One entry point for the eval runner and the CLI: :func:`compute_metrics` (pred vs gt assets).

Order of work: check both assets; map each into its own benchmark frame; optionally align the
prediction (``icp``); shape scores at rest and at the open state; part matching at rest; shape scores
per matched part; joint errors per matched pair, each with the ground-truth part's GAPartNet class when
the ground truth carries GAPartNet annotations. Every surface is sampled with the same seed, so an
asset compared with itself gives exactly zero everywhere and a rerun gives identical numbers.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.metrics.align import align_points
from spark_bench.metrics.articulation import JointAxis, axis_error, compare_joints, same_type
from spark_bench.metrics.geometry import (
    benchmark_transform,
    has_area,
    joint_axes,
    part_class,
    part_links,
    posed_triangles,
    transform_triangles,
    validate_asset,
)
from spark_bench.metrics.matching import match_parts, part_cost_matrix
from spark_bench.metrics.report import JointMatch, MetricsResult
from spark_bench.metrics.sampling import sample_pair, sample_triangles
from spark_bench.metrics.shape import FSCORE_THRESHOLDS, ShapeScores, shape_scores

ALIGN_MODES = ("none", "icp")


class _Side:
    """One asset mapped into the frame it is measured in, with its movable parts."""

    def __init__(self, asset: ArticulatedAsset):
        validate_asset(asset)
        self.asset = asset
        self.normalization = benchmark_transform(asset)
        self.alignment = np.eye(4)
        self.joints = [j.name for j in asset.movable_joints()]
        self.parts = {name: part_links(asset, name) for name in self.joints}

    @property
    def frame(self) -> np.ndarray:
        """World frame -> benchmark frame (-> aligned frame, for an aligned prediction)."""
        return self.alignment @ self.normalization

    def triangles(self, q=None, links=None) -> np.ndarray:
        return transform_triangles(self.frame, posed_triangles(self.asset, q, links))

    def rest(self, links=None) -> np.ndarray:
        return self.triangles(self.asset.rest_configuration(), links)

    def open(self) -> np.ndarray:
        return self.triangles(self.asset.open_configuration())

    def axes(self) -> list[JointAxis]:
        return joint_axes(self.asset, self.frame)


def _check_area(triangles: np.ndarray, what: str, where: str) -> None:
    if not has_area(triangles):
        raise InputError(where, f"empty mesh: {what} has no surface to sample")


def _sample(triangles: np.ndarray, n: int, seed: int, what: str, where: str) -> np.ndarray:
    _check_area(triangles, what, where)
    return sample_triangles(triangles, n, seed)


def _part_samples(side: _Side, n: int, seed: int) -> list[np.ndarray | None]:
    out = []
    for name in side.joints:
        triangles = side.rest(side.parts[name])
        out.append(sample_triangles(triangles, n, seed) if has_area(triangles) else None)
    return out


def _tie_break(pred_axes: list[JointAxis], gt_axes: list[JointAxis]) -> np.ndarray:
    """Between parts whose costs tie: a type mismatch weighs more than any axis angle."""
    out = np.zeros((len(pred_axes), len(gt_axes)))
    for i, p in enumerate(pred_axes):
        for j, g in enumerate(gt_axes):
            out[i, j] = 0.5 * (not same_type(p.type, g.type)) + 0.4 * axis_error(p.direction, g.direction) / (np.pi / 2)
    return out


def compute_metrics(pred: ArticulatedAsset, gt: ArticulatedAsset, n_samples: int = 100_000, seed: int = 0,
                    align: str = "none", thresholds: Sequence[float] = FSCORE_THRESHOLDS,
                    n_match_samples: int = 10_000, n_align_samples: int = 3_000, workers: int = -1
                    ) -> MetricsResult:
    """Shape and articulation metrics of ``pred`` against ``gt`` (the definitions of docs/conventions.md).

    :param pred: predicted asset (any frame: it is normalized here)
    :param gt: ground-truth asset (any frame: it is normalized here)
    :param n_samples: surface samples per shape (whole object at rest and open, each matched part)
    :param seed: sampling seed
    :param align: ``none`` or ``icp`` (rotation about Z and scale grid, then ICP; see
        :mod:`spark_bench.metrics.align`)
    :param thresholds: F-Score thresholds, benchmark-frame units
    :param n_match_samples: surface samples per part for the part matching
    :param n_align_samples: surface samples per asset for the alignment search
    :param workers: threads for nearest-neighbour queries (-1: every core)
    :raises InputError: for an empty mesh, NaN values, a zero axis, or an unknown ``align``
    """
    if align not in ALIGN_MODES:
        raise InputError(None, f"unknown alignment {align!r}; expected one of {', '.join(ALIGN_MODES)}")
    if n_samples < 1 or n_match_samples < 1 or n_align_samples < 1:
        raise InputError(None, "sample counts must be positive")
    thresholds = tuple(float(t) for t in thresholds)
    p_side, g_side = _Side(pred), _Side(gt)
    p_where, g_where = pred.source or pred.name, gt.source or gt.name

    if align == "icp":
        source = _sample(p_side.rest(), n_align_samples, seed, "the prediction", p_where)
        target = _sample(g_side.rest(), n_align_samples, seed, "the ground truth", g_where)
        p_side.alignment = align_points(source, target, workers=workers).matrix

    def scores(pred_triangles, gt_triangles, what: str, n: int = n_samples) -> ShapeScores:
        _check_area(pred_triangles, f"the prediction {what}", p_where)
        _check_area(gt_triangles, f"the ground truth {what}", g_where)
        return shape_scores(*sample_pair(pred_triangles, gt_triangles, n, seed), thresholds, workers)

    rest = scores(p_side.rest(), g_side.rest(), "at rest")
    opened = scores(p_side.open(), g_side.open(), "at the open state")

    p_axes, g_axes = p_side.axes(), g_side.axes()
    cost = part_cost_matrix(_part_samples(p_side, n_match_samples, seed),
                            _part_samples(g_side, n_match_samples, seed), workers)
    pairs = match_parts(cost, _tie_break(p_axes, g_axes))
    matches = []
    for pair in pairs:
        p_axis, g_axis = p_axes[pair.pred], g_axes[pair.gt]
        p_links, g_links = p_side.parts[p_axis.name], g_side.parts[g_axis.name]
        errors = compare_joints(p_axis, g_axis)
        part = scores(p_side.rest(p_links), g_side.rest(g_links), f"part of {g_axis.name}")
        matches.append(JointMatch(g_axis.name, p_axis.name, g_axis.type, p_axis.type, list(g_links),
                                  list(p_links), pair.cost, errors.axis_err, errors.pivot_err,
                                  errors.type_match, part, part_class(gt, g_axis.name)))
    matched_gt = {m.gt_joint for m in matches}
    matched_pred = {m.pred_joint for m in matches}
    return MetricsResult(
        rest=rest, open=opened, matches=matches,
        missing_joints=[name for name in g_side.joints if name not in matched_gt],
        extra_joints=[name for name in p_side.joints if name not in matched_pred],
        thresholds=thresholds, n_samples=int(n_samples), n_match_samples=int(n_match_samples),
        seed=int(seed), align=align,
        alignment=p_side.alignment,
        pred_name=pred.name, gt_name=gt.name,
        part_classes={name: c for name in g_side.joints if (c := part_class(gt, name)) is not None})
