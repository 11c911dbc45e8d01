"""Articulate-Anything's protocol (Le et al., ICLR 2025): a per-joint success cascade and link placement.

Read in ``vlongle/articulate-anything`` at commit ``1edb4b4a80e9679234e36873d91c52e0759d670c``, file
``articulate_anything/utils/metric.py`` (and ``articulate_anything/api/odio_urdf.py`` for the joint states
it compares). Each fact, with the function it comes from:

- **Frame and units** (``odio_urdf.py``, ``URDF.get_joint_states``): the world frame of the URDF at rest,
  in the file's length units (no normalization): the joint position ``R_parent @ xyz + p_parent``, the
  joint orientation ``R_parent @ R(rpy)`` as a quaternion ``[x, y, z, w]``, the axis
  ``R_joint @ <axis>``, the ``<limit>`` as written (0, 0 without one). Here: the same world frame from
  spark-bench's forward kinematics, in the file's units (a PartNet-Mobility object loaded at real size is
  measured back in its file units, :func:`~spark_bench.metrics.protocols.joints.file_units_per_length`).
- **Per-joint differences** (``metric.py``, ``compute_joint_diff``): axis angle
  ``min(arccos(a1.a2/|a1||a2|), arccos(-a2.a1/...))`` (clipped, radians); origin distance, for a
  ground-truth ``revolute`` joint ``|(p1 - p2).w| / |w|`` with ``w = a2 x a1`` and, when ``w`` is all-close
  to 0 (parallel axes), a **fixed-direction fallback** ``w = a2 x (1, 0, 0)`` (or ``a1 x (0, 1, 0)`` when
  ``a2`` is all-close to x): the offset along one perpendicular, not the line distance; for any other
  ground-truth type the Euclidean distance of the joint positions; joint-frame orientation angle
  ``2 arccos |q1.q2|``; limit motion ``m = a (upper - lower)``, direction ``1 - d1.d2``, range ``|m2 - m1|``,
  the prediction's axis and limits flipped when that gives a smaller direction difference; type by
  string equality (``continuous`` is not ``revolute``).
- **Success cascade** (``compute_joint_diff_score``): type equal, then axis <= 0.25 rad, then
  ``(origin distance + orientation angle) / 2 <= 0.05`` (a length plus an angle), then limit direction
  <= 1.0 and range <= 1.6057; the first failed test is the failure reason.
- **Prismatic forgiveness** (``adjust_result_for_prismatic``, defaults of ``compute_joint_pred_result``):
  a ground-truth prismatic joint failing on ``joint_origin`` or ``joint_limit`` counts as a success.
- **Which joints** (``compute_joint_pred_result``, ``joint_types=["revolute", "prismatic"]``): the
  ground truth's revolute and prismatic joints (``continuous`` ones are not scored); a joint without a
  prediction is the worst case (``create_worst_case_gt_result``: a failure).
- **Aggregation** (``analyze_joint_pred_by_type``): success rates pooled over joints, overall and per
  ground-truth type; ``axis_err`` is the mean ``joint_axis`` and ``pivot_err`` the mean origin distance
  of the matched revolute joints (not numbers AA prints); over several objects,
  :func:`spark_bench.metrics.protocols.tables.pooled` pools them again.
- **Link placement** (``average_link_difference``, ``reduce_link_diff``, ``analyze_link_placement_by_type``):
  per link, the distance between the centres of the world axis-aligned boxes and ``2 arccos |q1.q2|`` of
  the link orientations; means over links, ``average_diff = (position + orientation) / 2``; success when
  ``average_diff < 0.05`` (strict). Here the links are the matched joints' parts (box of the part's
  visual meshes at rest; AA's box is PyBullet's ``getAABB`` of the link) and the orientation is the child
  link's world rotation.

Not reproduced, on purpose: the matching (AA pairs joints by semantic names from ``semantics.txt``; here
by spark-bench's part matching); ``strategy="gt"`` (the best of N seeds *as scored against the ground
truth*, ``pick_best_joint_gt``: one prediction per case here, so it is the identity); the parent pose of
a chained joint (AA composes it with the parent link's *visual* origin, ``URDF.get_pose``; spark-bench's
assets keep no visual origin, so chained joints use the true link pose; identical for children of the
root); NaN from ``arccos`` of a quaternion dot product that rounds above 1 (here 0): for a joint AA's
NaN passes its ``>`` tests as 0 does, but for link placement ``NaN < 0.05`` is False, so AA's own code
fails the link placement of some objects compared with themselves (2 of 6 PartNet-Mobility objects in
``benchmarks/protocols/parity_joint.py``), where this module passes them.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.metrics.protocols.base import ProtocolInfo, ProtocolResult
from spark_bench.metrics.protocols.joints import JointRecord, paired_records, part_aabb_center

AXIS_CUTOFF = 0.25
ORIGIN_CUTOFF = 0.05
LIMIT_DIRECTION_CUTOFF = 1.0
LIMIT_RANGE_CUTOFF = 1.6057
LINK_CUTOFF = 0.05
#: Ground-truth joint types the paper scores (``compute_joint_pred_result``'s ``joint_types``).
SCORED_TYPES = ("revolute", "prismatic")
FAILURE_REASONS = ("joint_type", "joint_axis", "joint_origin", "joint_limit", "no_valid_result")

INFO = ProtocolInfo(
    name="articulate-anything",
    paper="Le et al., Articulate-Anything, ICLR 2025",
    source="github.com/vlongle/articulate-anything @ 1edb4b4a; articulate_anything/utils/metric.py "
           "(compute_joint_diff, compute_joint_diff_score, adjust_result_for_prismatic, "
           "average_link_difference, reduce_link_diff), articulate_anything/api/odio_urdf.py (get_joint_states)",
    units={"joint_success_rate": "fraction", "revolute_success_rate": "fraction",
           "prismatic_success_rate": "fraction", "link_placement_success": "fraction",
           "link_position_diff": "file units", "link_orientation_diff": "rad", "link_average_diff": "mixed",
           "axis_err": "rad", "pivot_err": "file units", "n_joints": "count", "n_revolute": "count",
           "n_prismatic": "count",
           **{f"failure_{r}": "fraction" for r in FAILURE_REASONS}},
    columns=(("link_placement_success", "Link placement"), ("revolute_success_rate", "Revolute"),
             ("prismatic_success_rate", "Prismatic"), ("joint_success_rate", "Joint (all)")),
    differs="World frame of the file at rest, file units, no normalization (spark-bench: benchmark frame, "
            "longest side 2); a joint succeeds by a cascade type -> axis <= 0.25 rad -> (origin distance + "
            "orientation angle)/2 <= 0.05 -> limits, prismatic origin/limit failures forgiven; rates pooled "
            "over joints; continuous joints not scored; joints matched by spark-bench's part matching, not "
            "by AA's semantic names; one prediction per case (AA's default takes the best of N seeds as "
            "scored against the ground truth).")


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.arccos(np.clip(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)), -1.0, 1.0)))


def _quaternion_angle(q1: np.ndarray, q2: np.ndarray) -> float:
    return float(2.0 * np.arccos(min(abs(float(np.sum(q1 * q2))), 1.0)))


def _limit_motion(a1, l1, u1, a2, l2, u2) -> tuple[float, float]:
    m1, m2 = a1 * (u1 - l1), a2 * (u2 - l2)
    d1 = m1 / np.linalg.norm(m1) if np.linalg.norm(m1) != 0 else a1
    d2 = m2 / np.linalg.norm(m2) if np.linalg.norm(m2) != 0 else a2
    return float(1.0 - np.dot(d1, d2)), float(np.linalg.norm(m2 - m1))


def origin_distance(gt_type: str, p1: np.ndarray, a1: np.ndarray, p2: np.ndarray, a2: np.ndarray) -> float:
    """AA's joint-origin distance: the fixed-direction line distance for a revolute ground truth.

    :param gt_type: the ground-truth joint type
    :param p1: ground-truth joint position
    :param a1: ground-truth axis
    :param p2: predicted joint position
    :param a2: predicted axis
    """
    if gt_type != JointType.REVOLUTE:
        return float(np.linalg.norm(p1 - p2))
    w = np.cross(a2, a1)
    if np.allclose(w, 0):
        w = np.cross(a2, [1, 0, 0]) if not np.allclose(a2, [1, 0, 0]) else np.cross(a1, [0, 1, 0])
    return float(abs(np.dot(p1 - p2, w)) / np.linalg.norm(w))


def joint_diff(gt: JointRecord, pred: JointRecord) -> dict:
    """AA's ``compute_joint_diff`` output for one pair: type, origin (xyz, orientation), axis, limit.

    :param gt: the ground-truth joint
    :param pred: the predicted joint
    """
    a1, a2 = gt.world_axis, pred.world_axis
    axis = min(_angle(a1, a2), _angle(-a2, a1))
    original = _limit_motion(a1, gt.lower, gt.upper, a2, pred.lower, pred.upper)
    flipped = _limit_motion(a1, gt.lower, gt.upper, -a2, -pred.upper, -pred.lower)
    direction, motion_range = original if original[0] < flipped[0] else flipped
    return {"joint_type": gt.type == pred.type,
            "joint_origin": {"xyz": origin_distance(gt.type, gt.world_point, a1, pred.world_point, a2),
                             "orientation": _quaternion_angle(gt.world_quaternion, pred.world_quaternion)},
            "joint_axis": axis,
            "joint_limit": {"direction_diff": direction, "range_diff": motion_range}}


def failure_reason(diff: dict, gt_type: str) -> str:
    """AA's cascade (``compute_joint_diff_score``) then its prismatic forgiveness: ``success`` or the
    first failed test.

    :param diff: :func:`joint_diff`'s output
    :param gt_type: the ground-truth joint type
    """
    if diff["joint_type"] != 1:
        return "joint_type"
    if diff["joint_axis"] > AXIS_CUTOFF:
        return "joint_axis"
    reason = "success"
    if (diff["joint_origin"]["xyz"] + diff["joint_origin"]["orientation"]) / 2 > ORIGIN_CUTOFF:
        reason = "joint_origin"
    elif (diff["joint_limit"]["direction_diff"] > LIMIT_DIRECTION_CUTOFF
          or diff["joint_limit"]["range_diff"] > LIMIT_RANGE_CUTOFF):
        reason = "joint_limit"
    if gt_type == JointType.PRISMATIC and reason in ("joint_origin", "joint_limit"):
        return "success"
    return reason


def link_poses(pred: ArticulatedAsset, gt: ArticulatedAsset, pairs) -> list[dict]:
    """Per matched part with geometry: ``{"link", "pred": {"bbox_position", "orientation"}, "gt": ...}``, the
    box centre (file units) and the world orientation ``[x, y, z, w]`` of the part's first link at rest.

    :param pred: the prediction
    :param gt: the ground truth
    :param pairs: ``(ground-truth joint, predicted joint)`` records
    """
    p_poses, g_poses = pred.link_poses(pred.rest_configuration()), gt.link_poses(gt.rest_configuration())
    out = []
    for g, p in pairs:
        g_centre, p_centre = part_aabb_center(gt, g.links), part_aabb_center(pred, p.links)
        if g_centre is None or p_centre is None:
            continue
        out.append({"link": g.links[0],
                    "pred": {"bbox_position": p_centre,
                             "orientation": Rotation.from_matrix(p_poses[p.links[0]][:3, :3]).as_quat()},
                    "gt": {"bbox_position": g_centre,
                           "orientation": Rotation.from_matrix(g_poses[g.links[0]][:3, :3]).as_quat()}})
    return out


def link_placement(poses: list[dict]) -> dict[str, float | None]:
    """``average_link_difference`` then ``reduce_link_diff`` and the ``< 0.05`` test over
    :func:`link_poses`' output (None without a placed part).

    :param poses: :func:`link_poses`' output
    """
    if not poses:  # AA would average over no link (0, a success); nothing was placed here
        return {"link_position_diff": None, "link_orientation_diff": None, "link_average_diff": None,
                "link_placement_success": None}
    positions = [float(np.linalg.norm(np.asarray(e["pred"]["bbox_position"]) - np.asarray(e["gt"]["bbox_position"])))
                 for e in poses]
    orientations = [_quaternion_angle(np.asarray(e["pred"]["orientation"]), np.asarray(e["gt"]["orientation"]))
                    for e in poses]
    position = sum(positions) / len(positions)
    orientation = sum(orientations) / len(orientations)
    average = (position + orientation) / 2
    return {"link_position_diff": position, "link_orientation_diff": orientation, "link_average_diff": average,
            "link_placement_success": float(average < LINK_CUTOFF)}


def joint_outcomes(pairs: list[tuple[JointRecord, JointRecord | None]]) -> list[dict]:
    """Per scored ground-truth joint: ``{"gt_type", "reason", "diff"}`` (``diff`` None when missing).

    :param pairs: every ground-truth joint with its matched prediction (None: missing); joints of types
        AA does not score are skipped
    """
    out = []
    for g, p in pairs:
        if g.type not in SCORED_TYPES:
            continue
        diff = None if p is None else joint_diff(g, p)
        out.append({"gt_type": g.type, "diff": diff,
                    "reason": "no_valid_result" if diff is None else failure_reason(diff, g.type)})
    return out


def joint_metrics(outcomes: list[dict]) -> dict[str, float | None]:
    """Rates pooled over the joints (``analyze_joint_pred_by_type``) and mean errors of the matched ones.

    :param outcomes: :func:`joint_outcomes`'s output
    """
    def rate(flags: list[bool]) -> float | None:
        return float(np.mean(flags)) if flags else None

    reasons = [o["reason"] for o in outcomes]
    success = [r == "success" for r in reasons]
    diffs = [o for o in outcomes if o["diff"] is not None]
    axes = [o["diff"]["joint_axis"] for o in diffs]
    pivots = [o["diff"]["joint_origin"]["xyz"] for o in diffs if o["gt_type"] == JointType.REVOLUTE]
    return {
        "joint_success_rate": rate(success),
        "revolute_success_rate": rate([s for s, o in zip(success, outcomes) if o["gt_type"] == JointType.REVOLUTE]),
        "prismatic_success_rate": rate([s for s, o in zip(success, outcomes) if o["gt_type"] == JointType.PRISMATIC]),
        **{f"failure_{r}": rate([x == r for x in reasons]) for r in FAILURE_REASONS},
        "axis_err": float(np.mean(axes)) if axes else None,
        "pivot_err": float(np.mean(pivots)) if pivots else None,
        "n_joints": float(len(outcomes)),
        "n_revolute": float(sum(o["gt_type"] == JointType.REVOLUTE for o in outcomes)),
        "n_prismatic": float(sum(o["gt_type"] == JointType.PRISMATIC for o in outcomes))}


def score(pred: ArticulatedAsset, gt: ArticulatedAsset, seed: int = 0) -> ProtocolResult:
    """Articulate-Anything's joint success and link placement of ``pred`` against ``gt``.

    :param pred: the prediction, as loaded
    :param gt: the ground truth, as loaded
    :param seed: sampling seed of spark-bench's part matching
    """
    pairs, _ = paired_records(pred, gt, seed)
    outcomes = joint_outcomes(pairs)
    placed = [(g, p) for g, p in pairs if p is not None and g.type in SCORED_TYPES]
    metrics = {**joint_metrics(outcomes), **link_placement(link_poses(pred, gt, placed))}
    notes = []
    missing = sum(o["diff"] is None for o in outcomes)
    if missing:
        notes.append(f"{missing} ground-truth joint(s) without a matched prediction (failures)")
    skipped = [g.name for g, _ in pairs if g.type not in SCORED_TYPES]
    if skipped:
        notes.append(f"not scored (AA scores revolute and prismatic joints only): {', '.join(skipped)}")
    return ProtocolResult(INFO.name, metrics, {k: INFO.units[k] for k in metrics}, notes)
