"""A prediction paired with the ground truth it is scored on, for the scores that open each ground-truth
joint (:mod:`spark_bench.opening.judge`, :mod:`spark_bench.rl.transfer`).

- **Which ground-truth joints are opening tasks**: drawers and doors (:data:`OPENING_TYPES`,
  :func:`opening_joints`).
- **The pairing**: the predicted joint the metrics matched with each ground-truth joint
  (``metrics["matching"]``, :meth:`Pairing.predicted_joint`).
- **The frames**: the ground truth as stored (``gt_bench``) and at its real size (``gt_metres``); the
  prediction's joints carried into ``gt_metres`` (:func:`predicted_joints_in_gt_metres`).
- **The object acted on** (:func:`object_acted_on`): the case's source object when it is on this machine and
  agrees with the prepared ground truth, else the ground truth in metres, with why.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.transforms import unit
from spark_bench.envs.registration import ENV_OF_JOINT_TYPE
from spark_bench.errors import InputError

#: The ground-truth joint types that are opening tasks: drawers (prismatic) and doors (revolute).
OPENING_TYPES = (JointType.PRISMATIC, JointType.REVOLUTE)
#: A result's ``acts_on`` when the policies act on the case's source object (:func:`object_acted_on`);
#: otherwise it names what they act on and why.
ACTS_ON_SOURCE = "source"
#: How closely a source's drawers and doors must agree with the prepared ground truth's in metres to stand
#: in for it: axis angle (radians), and pivot and prismatic range as a fraction of the object's diagonal
#: (the ground truth went through the normalization and its files: on partnet_dev and real_objects it
#: agrees to 1e-15, benchmarks/results/open_source.md).
SOURCE_ANGLE_TOL = 1e-3
SOURCE_LENGTH_TOL = 1e-3
#: Why a ground-truth joint counts as not opened when the metrics matched no predicted joint with it.
NOT_MATCHED = "no matched predicted joint"


def one_line(exc: Exception, limit: int = 200) -> str:
    """An exception's message on one line, at most ``limit`` characters (a ``reason`` or ``why``).

    :param exc: the exception
    :param limit: most characters kept
    """
    return " ".join(str(exc).split())[:limit]


def opening_joints(asset) -> list:
    """The joints of ``asset`` that are opening tasks (:data:`OPENING_TYPES`), in the asset's order.

    :param asset: an :class:`~spark_bench.asset.model.ArticulatedAsset`
    """
    return [joint for joint in asset.movable_joints() if joint.type in OPENING_TYPES]


# ----- the one rule for a joint nobody can open ----------------------------------------------------
# ----- the prediction, paired with the ground truth -------------------------------------------------
def predicted_joints_in_gt_metres(pred, pred_to_gt_metres) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
    """``{predicted joint: (unit axis, pivot, type)}`` carried into the ground truth's frame in metres.

    :param pred: the predicted asset as stored
    :param pred_to_gt_metres: 4x4 similarity (:func:`spark_bench.data.case.prediction_to_gt_metres`)
    """
    frame = np.asarray(pred_to_gt_metres, dtype=np.float64)
    out = {}
    for name, (point, direction) in pred.joint_frames().items():
        out[name] = (unit(frame[:3, :3] @ direction), frame[:3, :3] @ point + frame[:3, 3], pred.joints[name].type)
    return out


# ----- the object the policies act on --------------------------------------------------------------
def source_mismatch(source, gt_metres) -> str | None:
    """How a source object's drawers and doors differ from the prepared ground truth's in metres (the first
    difference, one line), or None when they agree (:data:`SOURCE_ANGLE_TOL`, :data:`SOURCE_LENGTH_TOL`).

    :param source: the case's source object as loaded
    :param gt_metres: the case's ground truth at its real size
    """
    gt_joints = {joint.name: joint for joint in opening_joints(gt_metres)}
    source_joints = {joint.name: joint for joint in opening_joints(source)}
    if set(gt_joints) != set(source_joints):
        return f"drawers and doors {sorted(source_joints)} are not the ground truth's {sorted(gt_joints)}"
    length_tol = SOURCE_LENGTH_TOL * float(np.linalg.norm(np.ptp(gt_metres.bounds(), axis=0)))
    gt_frames, source_frames = gt_metres.joint_frames(), source.joint_frames()
    for name, joint in gt_joints.items():
        other = source_joints[name]
        (gt_point, gt_axis), (point, axis) = gt_frames[name], source_frames[name]
        angle = float(np.arccos(np.clip(np.dot(unit(gt_axis), unit(axis)), -1.0, 1.0)))
        range_tol = length_tol if joint.type == JointType.PRISMATIC else SOURCE_ANGLE_TOL
        if other.type != joint.type:
            return f"joint {name} is {other.type}, the ground truth's {joint.type}"
        if angle > SOURCE_ANGLE_TOL or np.linalg.norm(np.asarray(point) - gt_point) > length_tol:
            return f"joint {name}'s axis line is not the ground truth's"
        if max(abs(other.lower - joint.lower), abs(other.upper - joint.upper)) > range_tol:
            return f"joint {name}'s range is not the ground truth's"
    return None


def object_acted_on(gt_folder: str | Path, gt_metres):
    """``(object, acts_on)``: what the policies open, and what it is (a result's ``acts_on``).

    A benchmark case's source object (``case.json``'s ``source``) as the dataset gives it, in metres:
    :data:`ACTS_ON_SOURCE`. Otherwise ``gt_metres``, never silently: ``acts_on`` is ``"prepared gt (...)"``
    with why (the source is not on this machine, unreadable, or its drawers and doors are not the ground
    truth's: :func:`source_mismatch`), or ``"object folder"`` for a ground truth that is no case (in metres
    already, acted on as it is).

    :param gt_folder: the ground-truth object folder
    :param gt_metres: its object at its real size (:func:`spark_bench.data.case.ground_truth_in_metres`)
    """
    from spark_bench.data.case import BenchmarkCase

    case = BenchmarkCase.of_gt_folder(gt_folder)
    if case is None:
        return gt_metres, "object folder"
    folder = case.source_folder
    if folder is None or not folder.exists():
        return gt_metres, f"prepared gt (source not found: {folder})"
    try:
        source = case.load_source()
    except (InputError, OSError, ValueError) as exc:  # a broken download: the prepared gt still stands
        return gt_metres, f"prepared gt (source unreadable: {one_line(exc)})"
    differs = source_mismatch(source, gt_metres)
    if differs is not None:
        return gt_metres, f"prepared gt (source differs: {differs})"
    return source, ACTS_ON_SOURCE


@dataclass
class Pairing:
    """A prediction and the ground truth it is scored on (:func:`load_pairing`).

    :param gt_bench: the ground truth as stored (a case's: benchmark frame)
    :param gt_metres: the object the policies act on, in metres: the case's source object when found
        (:func:`object_acted_on`), else the ground truth at its real size; the frame of both
    :param pred: the prediction as stored (its own world frame); ``gt_bench`` itself for the oracle
    :param pred_to_gt_metres: 4x4 similarity from ``pred``'s world frame into ``gt_metres``'
    :param matched: ``{ground-truth joint: predicted joint}`` from the metrics' matching
    :param acts_on: what ``gt_metres`` is (:func:`object_acted_on`)
    """

    gt_bench: object
    gt_metres: object
    pred: object
    pred_to_gt_metres: np.ndarray
    matched: dict[str, str]
    acts_on: str = "object folder"

    @cached_property
    def estimates(self) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
        """Every predicted joint as ``(unit axis, pivot, type)`` in ``gt_metres``' frame."""
        return predicted_joints_in_gt_metres(self.pred, self.pred_to_gt_metres)

    def predicted_joint(self, gt_joint: str) -> tuple[str | None, str | None]:
        """``(predicted joint, why it cannot be attempted)`` for a ground-truth joint: the name is None when
        none was matched; the reason is None when a policy can be told the predicted joint (an environment
        opens its type, :data:`~spark_bench.envs.registration.ENV_OF_JOINT_TYPE`).

        :param gt_joint: the ground-truth joint's name
        """
        name = self.matched.get(gt_joint)
        if name is None or name not in self.pred.joints:
            return name, NOT_MATCHED
        pred_type = self.pred.joints[name].type
        if pred_type not in ENV_OF_JOINT_TYPE:
            return name, f"the matched predicted joint is {pred_type}"
        return name, None


def matched_joints(metrics: dict) -> dict[str, str]:
    """``{ground-truth joint: predicted joint}`` of the metrics' matching (pairs without a prediction
    dropped).

    :param metrics: the prediction's metrics (their ``matching``)
    """
    return {m["gt_joint"]: m["pred_joint"] for m in metrics.get("matching", []) if m.get("pred_joint")}


def load_pairing(pred_folder: str | Path, gt_folder: str | Path, metrics: dict, gt_bench=None) -> Pairing:
    """Load a prediction and its ground truth for a score.

    :param pred_folder: the predicted object folder
    :param gt_folder: the ground-truth object folder (a benchmark case's ``gt/`` is brought to metres; its
        source object, when on this machine, is what the policies act on: :func:`object_acted_on`)
    :param metrics: the prediction's metrics (``matching``: gt_joint / pred_joint pairs; ``alignment``)
    :param gt_bench: the object of ``gt_folder`` if the caller already loaded it (not modified)
    """
    from spark_bench.data import load_object
    from spark_bench.data.case import ground_truth_in_metres, prediction_to_gt_metres

    gt_bench, gt_metres, bench_to_metres = ground_truth_in_metres(gt_folder, gt_bench)
    acted_on, acts_on = object_acted_on(gt_folder, gt_metres)
    # the oracle's prediction is the ground-truth folder itself: loaded once (a real object takes seconds)
    same_folder = Path(pred_folder).resolve() == Path(gt_folder).resolve()
    pred = gt_bench if same_folder else load_object(pred_folder)
    frame = prediction_to_gt_metres(pred, gt_bench, metrics.get("alignment"), bench_to_metres)
    return Pairing(gt_bench, acted_on, pred, frame, matched_joints(metrics), acts_on)
