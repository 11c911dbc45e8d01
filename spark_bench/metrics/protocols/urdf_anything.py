"""URDF-Anything's protocol (2025): joint success in the URDF's parent-local frame, missing joints failed.

Read in ``LZVSDY/URDF-Anything_CODE`` at commit ``6d77613f2b601cddb86d164a19411e447a1ea559``, file
``scripts/eval_metric.py``. Each fact, with the function it comes from:

- **Frame and units** (``eval_root``, ``axis_world_from_rpy``): each joint as the URDF writes it, in
  its parent link's frame and the file's units: ``origin.xyz``, ``origin.rpy``, and the axis
  ``R(rpy) @ normalize(axis)`` (the joint's own rotation only, never the parent's pose); no normalization
  of the object. Here: the same values from the asset's joints (lengths in the file's units,
  :func:`~spark_bench.metrics.protocols.joints.file_units_per_length`).
- **Type** (``eval_root``): case-insensitive string equality (``continuous`` is not ``revolute``).
- **Axis** (``axis_angle_error_rad``): ``arccos |u.v|`` (clipped), radians; within when ``<= 0.25``.
- **Origin** (``revolute_origin_axisline_distance``, ``quat_angle_distance_rad``): for a ground-truth
  ``revolute`` joint the distance of the axis lines ``|(p1 - p2).w| / |w|`` with ``w = a2 x a1`` (unit
  axes) and, when ``w`` is all-close to 0 (``atol=1e-6``), the fixed-direction fallback
  ``a2 x (1, 0, 0)`` (``a1 x (0, 1, 0)`` when ``a2`` is x); for other types the Euclidean distance;
  orientation ``2 arccos |q1.q2|`` of the ``rpy`` quaternions; combined ``0.5 (xyz + orientation)``,
  within when ``<= 0.05``.
- **Success** (``eval_root``): type ∧ axis within ∧ origin within; a ground-truth joint without a
  prediction counts False in every rate and adds no error value.
- **Matching** (``build_joint_map``): by joint ``id``, which the paper's pipeline aligns with the ground
  truth upstream (labels / Hungarian); here spark-bench's part matching.
- **Aggregation** (``eval_root``, ``aggregate``, ``rate``): rates pooled over all ground-truth joints of all
  objects; errors as mean (median, std) over the joints that have a prediction. Over several objects,
  :func:`spark_bench.metrics.protocols.tables.pooled` pools them again. ``axis_err`` is its
  ``axis_angle_error_rad``; ``pivot_err`` (not a number of its output) is the mean ``origin_xyz_error`` over
  the ground-truth revolute joints: the axis-line distance with its fallback, parent-frame file units.

Not reproduced: the rounding of the rates to 4 decimals (``round(rate(...), 4)``); mIoU (the paper's
segmentation score, from its own inference JSON; not computable from two assets); the JSON parsing of
a language model's answer.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult
from spark_bench.metrics.protocols.joints import JointRecord, paired_records

ANGULAR_CUTOFF = 0.25
EUCLIDEAN_CUTOFF = 0.05

INFO = ProtocolInfo(
    name="urdf-anything",
    paper="URDF-Anything, 2025",
    source="github.com/LZVSDY/URDF-Anything_CODE @ 6d77613f; scripts/eval_metric.py (eval_root, "
           "axis_world_from_rpy, axis_angle_error_rad, revolute_origin_axisline_distance, "
           "quat_angle_distance_rad)",
    units={"type_correct": "fraction", "axis_within": "fraction", "origin_within": "fraction",
           "joint_success_rate": "fraction", "missing_rate": "fraction",
           "axis_angle_error_rad": "rad", "origin_xyz_error": "file units",
           "origin_orientation_error_rad": "rad", "origin_combined_error": "mixed",
           "axis_err": "rad", "pivot_err": "file units", "num_gt_joints": "count", "num_pred_joints": "count",
           "missing_joints": "count"},
    columns=(("type_correct", "Type"), ("axis_within", "Axis"), ("origin_within", "Origin"),
             ("joint_success_rate", "Success"), ("axis_angle_error_rad", "Axis err (rad)"),
             ("origin_xyz_error", "Origin err")),
    differs="Each joint in its parent link's frame as the URDF writes it (origin xyz/rpy, axis turned by "
            "rpy only), file units, no normalization (spark-bench: world-frame axis lines in the benchmark "
            "frame, longest side 2); success = type (continuous is not revolute) ∧ axis <= 0.25 rad ∧ "
            "0.5·(xyz + orientation) <= 0.05; missing joints fail; rates pooled over joints; joints "
            "matched by spark-bench's part matching, not by the paper's ids.")


def _rotation(rpy: np.ndarray) -> np.ndarray:
    return Rotation.from_euler("xyz", rpy).as_matrix()


def axis_in_joint_frame(record: JointRecord) -> np.ndarray:
    """The axis as ``axis_world_from_rpy`` computes it: ``R(rpy) @ unit(axis)``.

    :param record: the joint
    """
    return _rotation(record.local_rpy) @ record.local_axis


def axis_angle(a1: np.ndarray, a2: np.ndarray) -> float:
    """``arccos |u.v|`` of the unit axes, radians in [0, pi/2].

    :param a1: first axis (non-zero)
    :param a2: second axis (non-zero)
    """
    u, v = a1 / np.linalg.norm(a1), a2 / np.linalg.norm(a2)
    return float(np.arccos(abs(float(np.clip(np.dot(u, v), -1.0, 1.0)))))


def origin_xyz_error(gt_type: str, p1: np.ndarray, a1: np.ndarray, p2: np.ndarray, a2: np.ndarray) -> float:
    """The origin distance: axis lines (fixed-direction fallback) for a revolute ground truth.

    :param gt_type: the ground-truth joint type
    :param p1: ground-truth origin xyz
    :param a1: ground-truth axis (rpy-turned)
    :param p2: predicted origin xyz
    :param a2: predicted axis (rpy-turned)
    """
    if gt_type != JointType.REVOLUTE:
        return float(np.linalg.norm(p1 - p2))
    a1, a2 = a1 / np.linalg.norm(a1), a2 / np.linalg.norm(a2)
    w = np.cross(a2, a1)
    if np.allclose(w, 0, atol=1e-6):
        w = np.cross(a2, [1, 0, 0]) if not np.allclose(a2, [1, 0, 0], atol=1e-6) else np.cross(a1, [0, 1, 0])
    norm = float(np.linalg.norm(w))
    if norm < 1e-12:
        return float(np.linalg.norm(p1 - p2))
    return float(abs(np.dot(p1 - p2, w)) / norm)


def rpy_angle(rpy1: np.ndarray, rpy2: np.ndarray) -> float:
    """``2 arccos |q1.q2|`` of the two ``rpy`` rotations, radians.

    :param rpy1: first roll-pitch-yaw
    :param rpy2: second roll-pitch-yaw
    """
    q1 = Rotation.from_euler("xyz", rpy1).as_quat()
    q2 = Rotation.from_euler("xyz", rpy2).as_quat()
    return float(2.0 * np.arccos(abs(float(np.clip(np.dot(q1, q2), -1.0, 1.0)))))


def joint_entry(gt: JointRecord, pred: JointRecord) -> dict:
    """Everything ``eval_root`` computes for one ground-truth joint with a prediction.

    :param gt: the ground-truth joint
    :param pred: the predicted joint
    """
    a_gt, a_pred = axis_in_joint_frame(gt), axis_in_joint_frame(pred)
    type_ok = pred.type.lower() == gt.type.lower()
    axis = axis_angle(a_gt, a_pred)
    xyz = origin_xyz_error(gt.type.lower(), gt.local_xyz, a_gt, pred.local_xyz, a_pred)
    orientation = rpy_angle(gt.local_rpy, pred.local_rpy)
    combined = 0.5 * (xyz + orientation)
    return {"gt_type": gt.type.lower(), "type_ok": type_ok, "axis_err": axis, "axis_ok": axis <= ANGULAR_CUTOFF, "xyz": xyz,
            "orientation": orientation, "combined": combined, "origin_ok": combined <= EUCLIDEAN_CUTOFF,
            "success": bool(type_ok and axis <= ANGULAR_CUTOFF and combined <= EUCLIDEAN_CUTOFF)}


def _mean(values: list[float]) -> float | None:
    return float(np.mean(values)) if values else None


def articulation_metrics(pairs: list[tuple[JointRecord, JointRecord | None]], n_pred: int
                         ) -> dict[str, float | None]:
    """``eval_root``'s articulation numbers over ``(ground-truth joint, its prediction or None)`` pairs.

    :param pairs: every ground-truth joint with its matched prediction (None: missing)
    :param n_pred: how many joints the prediction has
    """
    entries = [joint_entry(g, p) for g, p in pairs if p is not None]
    n, missing = len(pairs), sum(p is None for _, p in pairs)

    def rate(key: str) -> float:
        return sum(bool(e[key]) for e in entries) / n if n else 0.0  # eval_root's rate of an empty list

    return {
        "type_correct": rate("type_ok"), "axis_within": rate("axis_ok"), "origin_within": rate("origin_ok"),
        "joint_success_rate": rate("success"),
        "missing_rate": missing / n if n else 0.0,
        "axis_angle_error_rad": _mean([e["axis_err"] for e in entries]),
        "origin_xyz_error": _mean([e["xyz"] for e in entries]),
        "origin_orientation_error_rad": _mean([e["orientation"] for e in entries]),
        "origin_combined_error": _mean([e["combined"] for e in entries]),
        "axis_err": _mean([e["axis_err"] for e in entries]),
        "pivot_err": _mean([e["xyz"] for e in entries if e["gt_type"] == JointType.REVOLUTE]),
        "num_gt_joints": float(n), "num_pred_joints": float(n_pred), "missing_joints": float(missing)}


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0) -> ProtocolResult:
    """URDF-Anything's articulation rates and errors of ``pred`` against ``gt``.

    :param pred: the prediction, as loaded
    :param gt: the ground truth, as loaded
    :param seed: sampling seed of spark-bench's part matching
    """
    pairs, n_pred = paired_records(pred, gt, seed)
    metrics = articulation_metrics(pairs, n_pred)
    missing = int(metrics["missing_joints"])
    notes = [f"{missing} ground-truth joint(s) without a matched prediction count as failures"] if missing else []
    return ProtocolResult(INFO.name, metrics, {k: INFO.units[k] for k in metrics}, notes)
