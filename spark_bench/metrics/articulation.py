"""Articulation errors of one predicted joint against one ground-truth joint, on world-frame axes.

A joint is compared through its world-frame axis line (a point on the axis and a unit direction,
from forward kinematics at rest, in the benchmark frame) and its type:

- :func:`axis_error`: the angle between the directions, sign ignored, in [0, pi/2] radians;
- :func:`line_distance`: the distance between the two axis lines (PivotErr), with parallel lines
  handled by the point-to-line distance instead of a division by zero;
- :func:`same_type`: joint types compared with ``continuous`` counted as ``revolute``.

PivotErr follows FreeArt3D's evaluation code (``eval_utils/joints.py``, function ``eval_joint``, called
once per object by ``evaluate_partnet.py``; read in the public ``PeterZs/FreeArt3D`` copy): when the
ground-truth joint is revolute, the error is ``|(o_pred - o_gt) . (a_pred x a_gt)| / |a_pred x a_gt|``,
the distance between the ground truth's axis line and the predicted joint's line (its axis direction
through its origin) *whatever the predicted type*; a ground-truth prismatic joint has none (NaN there,
None here). Differences, all deliberate: ``continuous`` counts as revolute (FreeArt3D knows only
revolute and prismatic); parallel axes give the point-to-line distance where FreeArt3D divides by zero;
an object may have several joints (FreeArt3D's objects have one), matched by part
(:mod:`spark_bench.metrics.matching`); AxisErr is computed with ``atan2`` (the same angle as
FreeArt3D's ``min(arccos(a.b), arccos(-a.b))``, without its loss of digits near 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.asset.joint_type import is_rotational

#: Below this value of ``|a x b|`` (unit directions: the sine of the angle between the axes), the
#: axes count as parallel and PivotErr is the point-to-line distance. The skew-line formula is well
#: conditioned far below it; the guard only keeps the normal of the two axes from being noise.
PARALLEL_TOLERANCE = 1e-6

_TYPE_CLASS = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed"}


@dataclass(frozen=True)
class JointAxis:
    """A movable joint as the metrics see it: type and world-frame axis line.

    :param name: joint name
    :param type: ``revolute``, ``continuous`` or ``prismatic``
    :param point: a point on the axis line, benchmark frame
    :param direction: unit axis direction, benchmark frame
    """

    name: str
    type: str
    point: np.ndarray
    direction: np.ndarray

    @property
    def is_rotational(self) -> bool:
        return is_rotational(self.type)


def unit(vector) -> np.ndarray:
    """``vector`` scaled to unit length.

    :raises ValueError: for a zero or non-finite vector
    """
    vector = np.asarray(vector, dtype=np.float64)
    norm = float(np.linalg.norm(vector))
    if not np.isfinite(norm) or norm <= 0.0:
        raise ValueError(f"axis direction {vector.tolist()} has no direction")
    return vector / norm


def axis_error(direction_a, direction_b) -> float:
    """Angle between two axis directions, sign ignored: ``min(angle(a, b), angle(-a, b))``.

    Computed as ``atan2(|a x b|, |a . b|)``, which stays accurate near 0 and pi/2 where ``arccos``
    loses digits.

    :param direction_a: first direction (any non-zero length)
    :param direction_b: second direction (any non-zero length)
    :returns: radians in [0, pi/2]
    """
    a, b = unit(direction_a), unit(direction_b)
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), abs(float(np.dot(a, b)))))


def point_line_distance(point, line_point, line_direction) -> float:
    """Distance from ``point`` to the line through ``line_point`` along ``line_direction``."""
    d = unit(line_direction)
    offset = np.asarray(point, dtype=np.float64) - np.asarray(line_point, dtype=np.float64)
    return float(np.linalg.norm(offset - np.dot(offset, d) * d))


def line_distance(point_a, direction_a, point_b, direction_b,
                  parallel_tolerance: float = PARALLEL_TOLERANCE) -> float:
    """Distance between two lines in space (PivotErr).

    Skew lines: ``|(p_b - p_a) . n| / |n|`` with ``n = a x b``. When ``|a x b|`` (unit directions)
    is below ``parallel_tolerance`` the lines are parallel and the distance is that of ``p_b`` to
    line ``a``, the same for every point of line ``b``.

    :param point_a: a point on the first line
    :param direction_a: direction of the first line
    :param point_b: a point on the second line
    :param direction_b: direction of the second line
    :param parallel_tolerance: threshold on ``|a x b|`` below which the lines count as parallel
    """
    a, b = unit(direction_a), unit(direction_b)
    offset = np.asarray(point_b, dtype=np.float64) - np.asarray(point_a, dtype=np.float64)
    normal = np.cross(a, b)
    sine = float(np.linalg.norm(normal))
    if sine < parallel_tolerance:
        return point_line_distance(point_b, point_a, a)
    return float(abs(np.dot(offset, normal)) / sine)


def type_class(joint_type: str) -> str:
    """The class a type is compared by: ``continuous`` is a ``revolute`` without limits."""
    try:
        return _TYPE_CLASS[joint_type]
    except KeyError:
        raise ValueError(f"unknown joint type {joint_type!r}") from None


def same_type(type_a: str, type_b: str) -> bool:
    """Whether two joint types agree for TypeErr (``continuous`` counts as ``revolute``)."""
    return type_class(type_a) == type_class(type_b)


@dataclass
class JointErrors:
    """Errors of one matched pair of joints.

    :param axis_err: AxisErr, radians in [0, pi/2]
    :param pivot_err: PivotErr in benchmark-frame units; None when the ground-truth joint does not rotate
    :param type_match: whether the types agree (``continuous`` counts as ``revolute``)
    """

    axis_err: float
    pivot_err: float | None
    type_match: bool


def compare_joints(pred: JointAxis, gt: JointAxis, parallel_tolerance: float = PARALLEL_TOLERANCE) -> JointErrors:
    """AxisErr, PivotErr and type agreement of a predicted joint against a ground-truth joint.

    PivotErr (FreeArt3D's rule): for a rotating ground-truth joint, the distance between its axis line
    and the predicted joint's line, whatever the predicted type (a prismatic prediction is scored by
    its axis through its origin); None for a prismatic ground-truth joint.

    :param pred: the predicted joint
    :param gt: the ground-truth joint
    :param parallel_tolerance: see :func:`line_distance`
    """
    pivot = None
    if gt.is_rotational:
        pivot = line_distance(gt.point, gt.direction, pred.point, pred.direction, parallel_tolerance)
    return JointErrors(axis_error(pred.direction, gt.direction), pivot, same_type(pred.type, gt.type))
